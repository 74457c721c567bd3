"""The documentation as a newcomer meets it: README.md short, every page under docs/ reachable
from it by links, every relative link resolving (anchors included), nothing pointing outside the
repository; and the README's own commands, the quick ones run as written.

Markdown is read with a few regular expressions: links ``[text](target)`` and images
``![alt](target)`` outside fenced and indented code and outside inline code spans; anchors are
GitHub's (lower case, punctuation dropped, spaces to hyphens).
"""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
README = REPO / "README.md"
DOCS = REPO / "docs"

#: README.md's length limit (issue 27: "at most about 120 lines")
README_MAX_LINES = 130

_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(([^()\s]+)(?:\s+\"[^\"]*\")?\)")


def prose(text: str, spans: bool = True) -> str:
    """The text without fenced code, indented code blocks and (``spans``) inline code spans."""
    out, fence, in_code, blank = [], False, False, True
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fence = not fence
            out.append("")
            continue
        if fence:
            out.append("")
            continue
        is_indented = line.startswith("    ") or line.startswith("\t")
        in_code = is_indented and (blank or in_code)
        out.append("" if in_code else re.sub(r"`[^`]*`", "``", line) if spans else line)
        blank = not line.strip()
    return "\n".join(out)


def links(text: str) -> list[str]:
    """The targets of the links and images of a markdown text."""
    return _LINK.findall(prose(text))


def slug(heading: str) -> str:
    """GitHub's anchor of a heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every anchor of a markdown file (duplicate headings get -1, -2, ... as on GitHub)."""
    seen: dict[str, int] = {}
    found = set()
    for m in re.finditer(r"^#{1,6}\s+(.*?)\s*#*\s*$", prose(path.read_text(), spans=False), re.M):
        base = slug(m[1])
        n = seen.get(base, 0)
        found.add(base if n == 0 else f"{base}-{n}")
        seen[base] = n + 1
    return found


def is_external(target: str) -> bool:
    return re.match(r"^[a-z][a-z0-9+.-]*:", target) is not None


def pages() -> list[Path]:
    return [README, *sorted(DOCS.rglob("*.md"))]


def resolve(page: Path, target: str) -> tuple[Path, str]:
    path, _, anchor = target.partition("#")
    return ((page.parent / path).resolve() if path else page), anchor


def rel(path: Path) -> str:
    return path.relative_to(REPO).as_posix() if path.is_relative_to(REPO) else str(path)


# -- the checkers, plain functions so that the tests below can feed them made-up pages --------

def broken_links(page_list: list[Path]) -> list[str]:
    """'page: target (why)' for every relative link that does not resolve."""
    bad = []
    for page in page_list:
        for target in links(page.read_text()):
            if is_external(target):
                continue
            path, anchor = resolve(page, target)
            if not path.exists():
                bad.append(f"{rel(page)}: {target} (no such file)")
                continue
            if not path.is_relative_to(REPO):
                bad.append(f"{rel(page)}: {target} (outside the repository)")
            elif anchor and path.suffix == ".md" and anchor not in anchors(path):
                bad.append(f"{rel(page)}: {target} (no heading #{anchor} in {rel(path)})")
    return bad


def reachable(start: Path) -> set[Path]:
    """The markdown files reachable from ``start`` by relative links."""
    seen, todo = set(), [start.resolve()]
    while todo:
        page = todo.pop()
        if page in seen or not page.is_file():
            continue
        seen.add(page)
        for target in links(page.read_text()):
            if not is_external(target):
                path, _ = resolve(page, target)
                if path.suffix == ".md":
                    todo.append(path)
    return seen


# -- the repository's documents -----------------------------------------------------------------

def test_the_readme_is_short():
    n = len(README.read_text().splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines, at most {README_MAX_LINES}"


def test_the_readme_opens_with_the_two_commands():
    """CI (.ci/run) runs the README's test command; the first two lines are the two commands."""
    first = [line.split("#")[0].strip() for line in README.read_text().splitlines()[:2]]
    assert first == ["make run-case", "make test"]


def test_every_page_under_docs_is_reachable_from_the_readme():
    found = reachable(README)
    missing = [rel(p) for p in sorted(DOCS.rglob("*.md")) if p.resolve() not in found]
    assert not missing, f"not reachable from README.md by links: {missing}"


def test_every_relative_link_resolves():
    bad = broken_links(pages())
    assert not bad, "broken links:\n" + "\n".join(bad)


def test_no_document_points_at_a_folder_outside_the_repository():
    """A clone has no ``shared/`` folder (the development machine's notes and references)."""
    bad = [f"{rel(p)}:{i}: {line.strip()}" for p in pages()
           for i, line in enumerate(p.read_text().splitlines(), 1)
           if re.search(r"(?<![\w-])shared/|/work/", line)]
    assert not bad, "\n".join(bad)


def test_the_results_pages_are_dated():
    """Measurement records live in docs/results/YYYY-MM-DD-topic.md."""
    bad = [p.name for p in (DOCS / "results").glob("*.md")
           if not re.fullmatch(r"\d{4}-\d{2}-\d{2}-[a-z0-9-]+\.md", p.name)]
    assert not bad and any((DOCS / "results").glob("*.md"))


# -- the checkers catch what they should (made-up pages) ----------------------------------------

def test_the_checkers_catch_a_broken_link_an_anchor_and_an_orphan(tmp_path, monkeypatch):
    monkeypatch.setattr(sys.modules[__name__], "REPO", tmp_path)
    (tmp_path / "docs").mkdir()
    readme = tmp_path / "README.md"
    readme.write_text("# Top\n\n[a](docs/a.md#one) ![pic](docs/none.png) [web](https://x.org)\n"
                      "`[not a link](nowhere.md)`\n\n    [code](nowhere.md)\n")
    (tmp_path / "docs" / "a.md").write_text("# A page\n\n## Two words\n\n[back](../README.md#top)"
                                            " [b](b.md#two-words)\n")
    (tmp_path / "docs" / "b.md").write_text("# B\n")
    (tmp_path / "docs" / "orphan.md").write_text("# Orphan\n")
    bad = broken_links([readme, *sorted((tmp_path / "docs").glob("*.md"))])
    assert bad == ["README.md: docs/a.md#one (no heading #one in docs/a.md)",
                   "README.md: docs/none.png (no such file)",
                   "docs/a.md: b.md#two-words (no heading #two-words in docs/b.md)"]
    assert {p.name for p in reachable(readme)} == {"README.md", "a.md", "b.md"}


def test_slugs_follow_github():
    assert slug("The flow study (`whale-adapter study`, `make study`)") == \
        "the-flow-study-whale-adapter-study-make-study"
    assert slug("Mesh motion: `whaleBlendedDisplacement`") == "mesh-motion-whaleblendeddisplacement"


# -- the newcomer's path: the README's commands ---------------------------------------------

def readme_commands() -> list[str]:
    """The commands of the README's indented code blocks, comments dropped."""
    text = README.read_text()
    lines = text.splitlines()
    kept = prose(text, spans=False).splitlines()
    code = [a for a, b in zip(lines, kept, strict=True) if a != b]
    return [line.split("#")[0].strip() for line in code
            if line.strip() and not line.strip().startswith("#")]


def test_the_readme_make_commands_name_real_targets_and_variables():
    makefile = (REPO / "Makefile").read_text()
    targets = set(re.findall(r"^([\w-]+):", makefile, re.M))
    variables = set(re.findall(r"^(\w+) \?=", makefile, re.M))
    made = [shlex.split(c) for c in readme_commands() if c.startswith("make ")]
    assert made, "the README shows no make command"
    for words in made:
        goal = [w for w in words[1:] if "=" not in w]
        assert all(g in targets for g in goal), f"{words}: no such target in the Makefile"
        for w in words[1:]:
            if "=" in w:
                assert w.split("=")[0] in variables, f"{words}: no such variable in the Makefile"


def _whale_adapter() -> list[str]:
    """The installed ``whale-adapter`` command beside this Python (the venv's), else on PATH."""
    beside = Path(sys.executable).parent / "whale-adapter"
    found = str(beside) if beside.is_file() else shutil.which("whale-adapter")
    if found is None:
        pytest.skip("the whale-adapter command is not installed (pip install -e .)")
    return [found]


#: the README's commands a test runs as written (seconds each, no OpenFOAM); the others are
#: checked for their sub-command's --help
QUICK = ("--version", "geometry", "dry-run")


def test_the_readme_shows_the_quick_commands():
    shown = {shlex.split(c)[1] for c in readme_commands() if c.startswith("whale-adapter ")}
    assert set(QUICK) <= shown, f"the README's quick commands: {sorted(shown)}"


@pytest.mark.slow
@pytest.mark.parametrize("command", [c for c in readme_commands()
                                     if c.startswith("whale-adapter ")])
def test_a_readme_command_runs(command, tmp_path):
    """Run in an empty folder as a newcomer would; relative --out paths land there."""
    words = shlex.split(command)[1:]
    if words[0] == "COMMAND":
        words = ["run-case", "--help"]
    elif words[0] not in QUICK:
        words = [words[0], "--help"]
    extra = ["--no-progress"] if words[0] == "dry-run" else []
    out = subprocess.run([*_whale_adapter(), *words, *extra], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120)
    assert out.returncode == 0, f"{command}: exit {out.returncode}\n{out.stderr[-2000:]}"
    assert "Traceback" not in out.stderr, out.stderr
    if words[0] == "--version":
        assert out.stdout.startswith("whale-adapter ")
    for i, w in enumerate(words[:-1]):
        if w == "--out":
            written = tmp_path / words[i + 1]
            assert written.exists(), f"{command} wrote no {words[i + 1]}"
            if words[0] == "dry-run":
                assert {"whale.pvd", "summary.json", "keypoints.png", "frames.png"} <= \
                    {p.name for p in written.iterdir()}
