"""Builds the compiled part ricci._ricci with the project's CMake (the ricci library and the
command-line drivers it shares), for the interpreter running pip.

RICCI_BUILD_DIR=<absolute dir> reuses a build directory configured for the same interpreter (the module
target is built there; nothing is rebuilt when it is up to date); otherwise a Release build is
configured in setuptools' build_temp. RICCI_BUILD_JOBS sets the parallel jobs (default: cores)."""

import os
import pathlib
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parents[2]


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        given = os.environ.get("RICCI_BUILD_DIR")
        if given and not os.path.isabs(given):
            raise RuntimeError(f"ricci: RICCI_BUILD_DIR must be an absolute path (pip builds from {ROOT / 'lib' / 'python'}), "
                               f"not {given}")
        build = pathlib.Path(given or pathlib.Path(self.build_temp).resolve() / "cmake")
        if not (build / "CMakeCache.txt").exists():
            subprocess.check_call(["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                                   "-DRICCI_BUILD_TESTS=OFF", "-DRICCI_BUILD_TOOLS=OFF", "-DRICCI_BUILD_PYTHON=ON",
                                   f"-DRICCI_PYTHON={sys.executable}"])
        jobs = os.environ.get("RICCI_BUILD_JOBS") or str(os.cpu_count() or 1)
        subprocess.check_call(["cmake", "--build", str(build), "--target", "ricci_python", "-j", jobs])
        built = sorted((build / "python" / "ricci").glob("_ricci*.so"))
        if not built:
            raise RuntimeError(f"ricci: no _ricci module in {build / 'python' / 'ricci'}")
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[0], target)


setup(ext_modules=[CMakeExtension("ricci._ricci")], cmdclass={"build_ext": CMakeBuild})
