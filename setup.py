"""Builds the extension haustra._haustra through the project's CMake for `pip install .` (decision 0059).

HAUSTRA_CMAKE_BUILD_DIR: an already configured build tree (with HAUSTRA_PYTHON=ON) to build the
module in, e.g. build/release, which `make test` has just built; otherwise a tree of its own,
build/pip, configured in Release with the Python module.
"""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    return re.search(r"project\(haustra VERSION ([0-9.]+)", text).group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        given = os.environ.get("HAUSTRA_CMAKE_BUILD_DIR")
        tree = Path(given).resolve() if given else ROOT / "build" / "pip"
        if not given:
            subprocess.run(["cmake", "-S", str(ROOT), "-B", str(tree), "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
                            "-DHAUSTRA_PYTHON=ON", f"-DPython3_EXECUTABLE={sys.executable}"], check=True)
        elif not (tree / "CMakeCache.txt").exists():
            raise RuntimeError(f"HAUSTRA_CMAKE_BUILD_DIR={given}: not a configured CMake build tree")
        subprocess.run(["cmake", "--build", str(tree), "--target", "haustra_python", "haustra_python_stubs"], check=True)
        built = sorted((tree / "python" / "haustra").glob("_haustra*.so"))
        if not built:
            raise RuntimeError(f"{tree}: the build made no python/haustra/_haustra*.so")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[0], target)
        stubs = tree / "python" / "haustra" / "_haustra.pyi"  # generated from the module by the build
        if not stubs.exists():
            raise RuntimeError(f"{tree}: the build made no python/haustra/_haustra.pyi")
        shutil.copyfile(stubs, target.parent / "_haustra.pyi")


setup(version=project_version(), ext_modules=[Extension("haustra._haustra", sources=[])],
      cmdclass={"build_ext": CMakeBuild})
