"""The case's own scene: ``<case>/adapter-scene.toml``, the exact scene a case was prepared
from, every value written out (:mod:`adapter.scenefile`), its paths absolute.

:func:`~adapter.foam.case.prepare_case` writes it; the case's step-server loads it
(:func:`~adapter.foam.stepserver.server_command`), so that the whale it animates is the one
the case's dictionaries and mesh were made for, whether the scene came from a file, a preset
or a scene changed in memory (the flow study's speeds, an API user's ``scene.replace``), and
whatever happens to the scene file after. It lies next to ``adapter-case.json``, not in
``adapter/`` (the server's output, which ``./Allclean`` removes). A case prepared before it
existed has none: its server loads the record's scene file or preset.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from adapter.foam.dictionaries import DECOMPOSITIONS
from adapter.motion.gait import SHIPPED_TABLES
from adapter.scene import load_scene
from adapter.scenefile import with_absolute_paths, write_scene

#: the case's own scene file, in the case folder
CASE_SCENE = "adapter-scene.toml"

#: the scene's keys that name a file relative to the scene file's folder, and their values
#: that are not files
PATH_FIELDS = {"geometry.source": ("procedural",),
               "stroke.fluke_table": tuple(SHIPPED_TABLES),
               "case.decomposition": DECOMPOSITIONS}

#: how a case runs, not what it is: run-case's --np, --launcher, --decomposition,
#: --parallel-mesh, --reconstruct set them, so a rerun's scene is not compared on them
RUN_SETTINGS = ("case.ranks", "case.launcher", "case.decomposition", "case.parallel_meshing",
                "case.reconstruct")


def case_scene_file(case: str | Path) -> Path | None:
    """``<case>/adapter-scene.toml`` when the case has it, else None (an older case)."""
    path = Path(case) / CASE_SCENE
    return path if path.is_file() else None


def portable(scene):
    """The scene with its paths absolute (:data:`PATH_FIELDS`)."""
    return with_absolute_paths(scene, PATH_FIELDS)


def write_case_scene(scene, case: str | Path, source: str) -> Path:
    """The scene into ``<case>/adapter-scene.toml``; ``source`` (the scene file or preset it
    started from) goes into its header."""
    header = ("The scene this case was prepared with, every value, written by whale-adapter:\n"
              "its step-server loads this file. Do not edit it (the case's dictionaries and\n"
              "mesh were made from these values): change a scene file, prepare a new case.\n"
              f"Started from: {source}")
    return write_scene(portable(scene), Path(case) / CASE_SCENE, header)


def load_case_scene(case: str | Path):
    """The case's own scene (SceneError when it is missing or broken)."""
    return load_scene(Path(case) / CASE_SCENE)


def _flat(scene) -> dict:
    out = {}
    for f in dataclasses.fields(scene):
        value = getattr(scene, f.name)
        if dataclasses.is_dataclass(value):
            out.update({f"{f.name}.{g.name}": getattr(value, g.name)
                        for g in dataclasses.fields(value)})
        else:
            out[f.name] = value
    return out


def scene_differences(asked, own) -> list[str]:
    """``key (asked vs the case's)`` of every value in which the scene ``asked`` differs from
    the case's own, its paths made absolute first; not the name (the preset it started from),
    its folder or the :data:`RUN_SETTINGS`."""
    a, b = _flat(portable(asked)), _flat(portable(own))
    skip = {"name", "base_dir", *RUN_SETTINGS}
    return [f"{k} ({a[k]!r} vs {b[k]!r})" for k in a if k not in skip and a[k] != b[k]]
