"""Where the files that are not Python modules are, in a checkout and in an installed wheel.

The repository keeps the template case at ``foam_case/`` and the plugin's build script at
``scripts/build_plugin.sh``, next to the ``adapter`` package; a wheel carries them inside the
package, as ``adapter/_foam_case/`` and ``adapter/_scripts/build_plugin.sh`` (setup.py's build
step). They are looked up with :mod:`importlib.resources` first, the repository as the
fallback (an editable install or ``PYTHONPATH``). The plugin's C++ sources are package data
(``adapter/foam/plugin``) in both layouts.
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
#: the checkout the package lies in (meaningful only when :data:`IN_REPOSITORY`)
REPO = PACKAGE_DIR.parent
IN_REPOSITORY = (REPO / "foam_case").is_dir() and (REPO / "pyproject.toml").is_file()


def _find(packaged: str, in_repo: str) -> Path:
    res = files(__package__).joinpath(packaged)
    if res.is_dir() or res.is_file():
        return Path(str(res))
    return REPO / in_repo


#: the template case
TEMPLATE_DIR = _find("_foam_case", "foam_case")
#: the script that builds the boundary condition library
BUILD_SCRIPT = _find("_scripts/build_plugin.sh", "scripts/build_plugin.sh")
#: the boundary condition's C++ sources
PLUGIN_SRC = PACKAGE_DIR / "foam" / "plugin"


def build_dir() -> Path:
    """Where build_plugin.sh builds: ``build/`` of the checkout, else (an installed wheel)
    ``$XDG_CACHE_HOME/whale-adapter/build`` (``~/.cache/...``); ``WHALE_BUILD_DIR`` overrides."""
    if os.environ.get("WHALE_BUILD_DIR"):
        return Path(os.environ["WHALE_BUILD_DIR"])
    if IN_REPOSITORY:
        return REPO / "build"
    cache = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(cache) / "whale-adapter" / "build"


#: the boundary condition library build_plugin.sh writes (``WHALE_PLUGIN_LIB`` overrides it
#: at run time: adapter.foam.dictionaries.plugin_lib)
PLUGIN_LIB = build_dir() / "lib" / "libstepServerDisplacement.so"
