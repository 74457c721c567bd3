"""The package's shape (docs/architecture.md), read from the source with ``ast``: the import
graph of ``adapter.*`` (imports at module level and inside functions alike) has no cycle, each
room imports only the rooms below it, and no module reaches into another's private names.

Each checker is a plain function over ``{module name: source}``, so that the tests at the end
can plant a cycle, an upward import or a private access in a small made-up package and see the
checker catch it.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "adapter"

#: the rooms, by module-name prefix (the longest prefix wins)
ROOMS = {
    "adapter": "front",                 # the package's public surface (__init__)
    "adapter.cli": "front",
    "adapter.errors": "base",
    "adapter.scene": "base",
    "adapter.scenevalues": "base",     # the scene's value checks (a leaf: adapter.errors)
    "adapter.scenefile": "base",       # the scene written out as TOML (a leaf)
    "adapter.resources": "base",
    "adapter.vtkfiles": "base",         # a leaf: imports only adapter.errors
    "adapter.foamfiles": "base",        # a leaf: the time-folder scan
    "adapter.options": "base",          # command-line option types (argparse type=)
    "adapter.jsonfiles": "base",        # a leaf: strict JSON, the one NaN/inf cleaner
    "adapter.body": "body",
    "adapter.motion": "motion",
    "adapter.coupling": "coupling",
    "adapter.foam": "foam",
    "adapter.studies": "studies",
    "adapter.reports": "reports",
    "adapter.validation": "validation",
}

#: room -> the rooms it may import (besides itself); docs/architecture.md has the same table
ALLOWED = {
    "base": set(),
    "body": {"base"},
    "reports": {"base"},
    "motion": {"base", "body", "reports"},
    "coupling": {"base", "body", "motion"},
    "foam": {"base", "body", "motion", "coupling", "reports"},
    "studies": {"base", "body", "motion", "coupling", "foam", "reports"},
    "validation": {"base", "body", "motion", "coupling", "foam", "reports"},
    "front": {"base", "body", "motion", "coupling", "foam", "studies", "reports", "validation"},
}

#: state that only its own module writes (attribute -> owning module); others call a method
OWNED_STATE = {
    "status": "adapter.motion.integrators",      # Integrator.restart()
    "n_steps": "adapter.motion.integrators",
    "step_index": "adapter.motion.animator",     # Animator.reset(), restore(), advance_to()
}


# -- reading the package ----------------------------------------------------------------------

def package_sources(root: Path = PACKAGE) -> dict[str, str]:
    """{module name: source} of every Python file under ``root`` (packages as their name)."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path.read_text()
    return out


def _is_package(name: str, sources: dict[str, str]) -> bool:
    return any(other.startswith(name + ".") for other in sources)


def _absolute(module: str | None, level: int, name: str, sources) -> str:
    """The absolute module name of ``from <level dots><module> import ...`` in ``name``."""
    if level == 0:
        return module or ""
    base = name.split(".") if _is_package(name, sources) else name.split(".")[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([module] if module else []))


def imports(name: str, source: str, sources: dict[str, str]):
    """(imported module, line, imported names, alias map) of every ``adapter`` import in
    ``source``, at any depth (module level or inside functions)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "adapter":
                    found.append((a.name, node.lineno, [], {a.asname or a.name: a.name}))
        elif isinstance(node, ast.ImportFrom):
            mod = _absolute(node.module, node.level, name, sources)
            if mod.split(".")[0] != "adapter":
                continue
            for a in node.names:
                sub = f"{mod}.{a.name}"
                if sub in sources:      # `from adapter.body import springs`: the module
                    found.append((sub, node.lineno, [], {a.asname or a.name: sub}))
                else:
                    found.append((mod, node.lineno, [a.name], {}))
    return found


def import_graph(sources: dict[str, str]) -> dict[str, set[str]]:
    """module -> the ``adapter`` modules it imports (the nearest known module of each)."""
    graph = {}
    for name, source in sources.items():
        edges = set()
        for mod, _, _, _ in imports(name, source, sources):
            while mod not in sources and "." in mod:
                mod = mod.rsplit(".", 1)[0]
            if mod != name:
                edges.add(mod)
        graph[name] = edges
    return graph


def room(module: str) -> str:
    best = max((p for p in ROOMS if module == p or module.startswith(p + ".")), key=len)
    return ROOMS[best]


# -- the checks -----------------------------------------------------------------------------

def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles (each as a closed path of modules), by depth-first search."""
    cycles, state, path = [], {}, []

    def visit(node):
        state[node] = "open"
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                cycles.append(path[path.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt)
        path.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node)
    return cycles


def room_violations(graph: dict[str, set[str]]) -> list[str]:
    """Every import of a room that :data:`ALLOWED` does not give the importing room."""
    bad = []
    for mod, edges in sorted(graph.items()):
        mine = room(mod)
        for other in sorted(edges):
            theirs = room(other)
            if theirs != mine and theirs not in ALLOWED[mine]:
                bad.append(f"{mod} ({mine}) imports {other} ({theirs})")
    return bad


def _defined_private(tree: ast.AST) -> set[str]:
    """The private names a module defines: functions, classes, assigned names and attributes."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            names.add(node.value)       # object.__setattr__(self, "_x", ...)
    return {n for n in names if n.startswith("_")}


def _private(attr: str) -> bool:
    return attr.startswith("_") and not (attr.startswith("__") and attr.endswith("__"))


def private_crossings(sources: dict[str, str]) -> list[str]:
    """Private names used across module lines: ``from m import _x``, ``m._x`` of an imported
    module ``m``, ``obj._x`` where this module does not define ``_x`` (another class's
    private method or attribute), and a write of :data:`OWNED_STATE` outside its module."""
    bad = []
    for name, source in sorted(sources.items()):
        tree = ast.parse(source)
        aliases = {}
        for mod, line, names, alias in imports(name, source, sources):
            aliases.update(alias)
            bad += [f"{name}:{line}: from {mod} import {n}" for n in names if _private(n)]
        own = _defined_private(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                base = node.value
                if isinstance(base, ast.Name) and base.id in aliases:
                    bad.append(f"{name}:{node.lineno}: {aliases[base.id]}.{node.attr}")
                elif not (isinstance(base, ast.Name) and base.id in ("self", "cls")) \
                        and node.attr not in own:
                    bad.append(f"{name}:{node.lineno}: {ast.unparse(node)} (defined elsewhere)")
            if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                for t in targets:
                    if isinstance(t, ast.Attribute) and t.attr in OWNED_STATE \
                            and OWNED_STATE[t.attr] != name \
                            and not (isinstance(t.value, ast.Name) and t.value.id == "self"):
                        bad.append(f"{name}:{node.lineno}: writes {ast.unparse(t)}, the state "
                                   f"of {OWNED_STATE[t.attr]}")
    return bad


def private_uses_by_tests(tests: dict[str, str], sources: dict[str, str]) -> list[str]:
    """Private names of ``adapter`` modules that the tests (``{file name: source}``) use:
    ``from adapter.m import _x`` and ``m._x`` of an imported ``adapter`` module. A test goes
    through what the package offers other modules."""
    bad = []
    for name, source in sorted(tests.items()):
        aliases = {}
        for mod, line, names, alias in imports(f"tests.{name}", source, sources):
            aliases.update(alias)
            bad += [f"{name}:{line}: from {mod} import {n}" for n in names if _private(n)]
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Attribute) and _private(node.attr) \
                    and isinstance(node.value, ast.Name) and node.value.id in aliases:
                bad.append(f"{name}:{node.lineno}: {aliases[node.value.id]}.{node.attr}")
    return bad


#: where the size limits hold (issue 14): every room, the top's modules and the reports'
#: pvbatch scripts included
SIZED_ROOMS = ("adapter",)
MAX_MODULE_LINES = 400
MAX_CLASS_LINES = 250


def oversized(sources: dict[str, str], rooms=SIZED_ROOMS) -> list[str]:
    """Modules over :data:`MAX_MODULE_LINES` lines and classes over :data:`MAX_CLASS_LINES`
    in ``rooms``."""
    bad = []
    for name, source in sorted(sources.items()):
        if not any(name == r or name.startswith(r + ".") for r in rooms):
            continue
        n = len(source.splitlines())
        if n > MAX_MODULE_LINES:
            bad.append(f"{name}: {n} lines")
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.ClassDef):
                size = node.end_lineno - node.lineno + 1
                if size > MAX_CLASS_LINES:
                    bad.append(f"{name}.{node.name}: {size} lines")
    return bad


#: the limit for a function in adapter/ (issue 29), its body and docstring counted; no function
#: is allowed over it (no allow-list)
MAX_FUNCTION_LINES = 80


def long_functions(sources: dict[str, str], rooms=SIZED_ROOMS) -> list[str]:
    """Functions and methods over :data:`MAX_FUNCTION_LINES` lines in ``rooms``."""
    bad = []
    for name, source in sorted(sources.items()):
        if any(name == r or name.startswith(r + ".") for r in rooms):
            for node in ast.walk(ast.parse(source)):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    size = node.end_lineno - node.lineno + 1
                    if size > MAX_FUNCTION_LINES:
                        bad.append(f"{name}.{node.name}: {size} lines")
    return bad


# -- the package ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def sources():
    return package_sources()


def test_every_module_is_in_a_room(sources):
    assert "adapter.motion.animator" in sources and "adapter.coupling.server" in sources
    unknown = [m for m in sources if not any(m == p or m.startswith(p + ".") for p in ROOMS)]
    assert not unknown


def test_the_import_graph_has_no_cycle(sources):
    assert find_cycles(import_graph(sources)) == []


def test_each_room_imports_only_the_rooms_below_it(sources):
    assert room_violations(import_graph(sources)) == []


def test_vtkfiles_is_a_leaf(sources):
    """The one module for VTK files imports nothing from the adapter but its exceptions."""
    assert import_graph(sources)["adapter.vtkfiles"] <= {"adapter.errors"}


def test_foamfiles_is_a_leaf(sources):
    """The time-folder scan, shared by the case's modules and the reports, imports nothing
    from the adapter."""
    assert import_graph(sources)["adapter.foamfiles"] == set()


def test_the_tests_use_no_private_name_of_the_package(sources):
    here = Path(__file__).parent
    tests = {".".join(p.relative_to(here).with_suffix("").parts): p.read_text()
             for p in sorted(here.rglob("*.py"))}
    assert private_uses_by_tests(tests, sources) == []
    planted = {"test_x": "from adapter.body import springs\n"
                         "from adapter.body.springs import _kernel\n"
                         "def test_k():\n    springs._kernel()\n    obj._own = 1\n"}
    assert private_uses_by_tests(planted, _planted()) == [
        "test_x:2: from adapter.body.springs import _kernel",
        "test_x:4: adapter.body.springs._kernel"]


#: the C++ plugin: its files are held to the module limit too
PLUGIN = PACKAGE / "foam" / "plugin"


def test_the_plugin_files_are_small():
    sizes = {p.name: len(p.read_text().splitlines()) for p in PLUGIN.rglob("*.[CH]")}
    assert sizes and {k: n for k, n in sizes.items() if n > MAX_MODULE_LINES} == {}


# -- C++ classes ------------------------------------------------------------------------------
# A C++ class's size is its code lines (neither blank nor only comment): those of its
# declaration in a .H (``class X ... };`` at column 0, inline members included) plus those of
# its members defined in the .C files (``... X::name(...) ... { ... }``, wherever they are).
# Code lines, not all lines, because OpenFOAM's style puts a ``//-`` comment on every member.

def _blank_comments_and_strings(text: str) -> str:
    """``text`` with comments and string/char literals blanked out, newlines kept."""
    keep_newlines = lambda m: re.sub(r"[^\n]", " ", m.group(0))     # noqa: E731
    pattern = r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\''
    return re.sub(pattern, keep_newlines, text, flags=re.S)


def _closing_brace(text: str, opening: int) -> int:
    depth = 0
    for i in range(opening, len(text)):
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        if depth == 0:
            return i
    raise ValueError("unbalanced braces")


def _code_lines(text: str) -> int:
    return sum(1 for line in text.splitlines() if line.strip())


_DECLARATION = re.compile(r"^(?:class|struct)\s+(\w+)[^;{]*\{", re.M)
_MEMBER = re.compile(r"\b(\w+)::\s*(?:~?\w+|operator[^(]*)\s*\(")


def cpp_class_sizes(files: dict[str, str]) -> dict[str, int]:
    """{class: code lines} of the classes declared in the ``.H`` of ``{file name: text}``."""
    sizes: dict[str, int] = {}
    for name, text in sorted(files.items()):
        if name.endswith(".H"):
            text = _blank_comments_and_strings(text)
            for m in _DECLARATION.finditer(text):
                end = _closing_brace(text, m.end() - 1)
                sizes[m[1]] = sizes.get(m[1], 0) + _code_lines(text[m.start():end + 1])
    for name, text in sorted(files.items()):
        if not name.endswith(".C"):
            continue
        text = _blank_comments_and_strings(text)
        head = i = 0                    # head: where the current top-level statement began
        while i < len(text):
            if text[i] == "{" and not re.search(r"\bnamespace\s*\w*\s*$", text[head:i]):
                end = _closing_brace(text, i)
                m = _MEMBER.search(text[head:i])
                if m and m[1] in sizes:
                    sizes[m[1]] += _code_lines(text[head:end + 1])
                head = i = end + 1
                continue
            if text[i] in "{};":        # a namespace opened or closed, a statement ended
                head = i + 1
            i += 1
    return sizes


def test_the_plugin_classes_are_small():
    sizes = cpp_class_sizes({p.name: p.read_text() for p in PLUGIN.rglob("*.[CH]")})
    # the counter finds the plugin's main classes (one it missed would pass unseen)
    assert {"stepServerDisplacementPointPatchVectorField", "stepServerLink", "stepServerClient",
            "whaleLoads", "whaleBlendedDisplacementMotionSolver"} <= sizes.keys()
    assert {k: n for k, n in sizes.items() if n > MAX_CLASS_LINES} == {}


def test_the_cpp_class_size_counts_declaration_and_definitions():
    header = (
        "/* class Fake in a comment { */\n"
        "class Big\n:\n    public Base\n{\n    int x_;\n\n    //- comment\npublic:\n"
        "    int x() const\n    {\n        return x_;\n    }\n};\n"
        "class Fwd;\n"
    )                                                   # 11 code lines in the declaration
    source = (
        '#include "Big.H"\n\nnamespace Foam\n{\n\nnamespace\n{\nint helper() { return 1; }\n}\n'
        "\nint Big::\nf(int a) const\n{\n    // a comment\n    return a;\n}\n"       # 5
        "\nBig::Big()\n:\n    x_(helper())\n{}\n"                                    # 4
        '\nBig::~Big()\n{\n    const char* s = "}";\n}\n'                             # 4
        "\nmakeType(Big)\n\n} // End namespace Foam\n"
    )
    sizes = cpp_class_sizes({"Big.H": header, "Big.C": source, "Other.C": "int Big::g() {}\n"})
    assert sizes == {"Big": 11 + 5 + 4 + 4 + 1}


def test_no_private_name_crosses_a_module_line(sources):
    assert private_crossings(sources) == []


def test_modules_and_classes_are_small(sources):
    assert oversized(sources) == []
    big = {"adapter.foam.big": "class Big:\n" + "    x = 1\n" * MAX_CLASS_LINES}
    assert oversized(big) == ["adapter.foam.big.Big: 251 lines"]


def test_functions_are_short(sources):
    assert long_functions(sources) == []
    body = "    x = 1\n" * (MAX_FUNCTION_LINES - 1)
    assert long_functions({"adapter.foam.f": "def ok():\n" + body}) == []
    big = "class C:\n  def big(self):\n" + body + "    y = 2\n"     # a method, 81 lines
    assert long_functions({"adapter.foam.f": big}) == ["adapter.foam.f.big: 81 lines"]


#: the limit for a test file (issue 29): a file over it holds more than one concern
MAX_TEST_FILE_LINES = 500


def test_test_files_are_small():
    tests = Path(__file__).parent
    sizes = {str(p.relative_to(tests)): len(p.read_text().splitlines())
             for p in sorted(tests.rglob("*.py"))}
    assert "test_architecture.py" in sizes
    assert {k: n for k, n in sizes.items() if n > MAX_TEST_FILE_LINES} == {}


# -- the checks catch what they are for -----------------------------------------------------

def _planted(**changes) -> dict[str, str]:
    base = {
        "adapter": "",
        "adapter.errors": "",
        "adapter.body": "",
        "adapter.body.springs": "def edge_forces(): pass\ndef _kernel(): pass\n",
        "adapter.motion": "",
        "adapter.motion.integrators": "from adapter.body.springs import edge_forces\n"
                                      "class I:\n    def _step(self): pass\n",
        "adapter.motion.stability": "from adapter.motion.integrators import I\n",
    }
    base.update(changes)
    return base


def test_the_clean_plant_passes():
    src = _planted()
    graph = import_graph(src)
    assert graph["adapter.motion.stability"] == {"adapter.motion.integrators"}
    assert find_cycles(graph) == [] and room_violations(graph) == []
    assert private_crossings(src) == []


def test_a_cycle_hidden_in_a_function_is_caught():
    src = _planted(**{"adapter.motion.integrators":
                      "def f():\n    from adapter.motion.stability import g\n"})
    src["adapter.motion.stability"] = "from . import integrators\n"     # relative, too
    cycles = find_cycles(import_graph(src))
    assert cycles and set(cycles[0]) == {"adapter.motion.integrators",
                                         "adapter.motion.stability"}


def test_an_upward_import_is_caught():
    src = _planted(**{"adapter.body.springs": "import adapter.motion.integrators\n"})
    assert room_violations(import_graph(src)) == [
        "adapter.body.springs (body) imports adapter.motion.integrators (motion)"]


@pytest.mark.parametrize("code, what", [
    ("from adapter.body.springs import _kernel\n", "import _kernel"),
    ("from adapter.body import springs\nx = springs._kernel\n", "springs._kernel"),
    ("def f(integ):\n    return integ._step(1)\n", "integ._step"),
    ("def f(integ):\n    integ.status = 'running'\n", "writes integ.status"),
])
def test_a_private_crossing_is_caught(code, what):
    found = private_crossings(_planted(**{"adapter.motion.stability": code}))
    assert len(found) == 1 and what in found[0]


def test_a_module_may_use_its_own_private_names_on_other_objects():
    code = "def f(proc):\n    proc._tag = 1\n    return proc._tag\n"
    assert private_crossings(_planted(**{"adapter.motion.stability": code})) == []
