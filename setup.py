"""pip install . — builds the Python module `crowdhealth` with CMake (docs/python.md).

Offline with Debian 12's packages (python3-setuptools, python3-wheel, pybind11-dev, python3-dev,
python3-numpy and the libraries of scripts/setup.sh):
    pip install --no-build-isolation .
(pip's default build isolation would download setuptools into a fresh environment first.)
The extension is the CMake target crowdhealth_python, built in setuptools' build folder with the
project's own CMakeLists.txt; no source is compiled twice by different rules.
"""
import os
import pathlib
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


def version():
    for line in (ROOT / "CMakeLists.txt").read_text().splitlines():
        if line.startswith("project(CrowdHealth VERSION"):
            return line.split()[2]
    return "0.0.0"


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = pathlib.Path(self.build_temp).resolve() / "cmake"
        build.mkdir(parents=True, exist_ok=True)
        config = ["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                  "-DCROWDHEALTH_BUILD_TESTS=OFF", "-DCROWDHEALTH_BUILD_BENCHMARKS=OFF",
                  "-DPython3_EXECUTABLE=" + sys.executable]
        if shutil.which("ccache"):
            config.append("-DCMAKE_CXX_COMPILER_LAUNCHER=ccache")
        subprocess.run(config, check=True)
        jobs = os.environ.get("JOBS", str(os.cpu_count() or 1))
        subprocess.run(["cmake", "--build", str(build), "--target", "crowdhealth_python", "-j", jobs], check=True)
        built = next((build / "python" / "crowdhealth").glob("_crowdhealth*.so"))
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, target)


setup(
    name="crowdhealth",
    version=version(),
    description="CrowdHealth crowd simulator: load, run and analyse scenarios from Python",
    packages=["crowdhealth"],
    package_dir={"crowdhealth": "Engine/python/crowdhealth"},
    ext_modules=[Extension("crowdhealth._crowdhealth", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    python_requires=">=3.9",
    install_requires=["numpy"],
    zip_safe=False,
)
