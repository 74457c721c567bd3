"""One build step besides pyproject.toml: a wheel carries the template case (foam_case/) and
the plugin's build script (scripts/build_plugin.sh), which the repository keeps at its top
level, inside the package as ``adapter/_foam_case/`` and ``adapter/_scripts/``
(adapter/resources.py finds them there, or in the repository for an editable install)."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
#: repository path -> path inside the package
EXTRA = {"foam_case": "_foam_case", "scripts/build_plugin.sh": "_scripts/build_plugin.sh"}


class BuildPyWithCase(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return                                  # the repository's own files are used
        for src, dst in EXTRA.items():
            src, dst = HERE / src, Path(self.build_lib) / "adapter" / dst
            if src.is_dir():
                shutil.copytree(src, dst, dirs_exist_ok=True,
                                ignore=shutil.ignore_patterns("__pycache__"))
            else:
                dst.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(src, dst)


setup(cmdclass={"build_py": BuildPyWithCase})
