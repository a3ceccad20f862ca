"""Builds haustra for `pip install .` through the project's CMake (decisions 0059, 0101).

    /usr/bin/python3 -m venv --system-site-packages .venv && .venv/bin/pip install --no-build-isolation .

The build tree, in this order: HAUSTRA_CMAKE_BUILD_DIR when given (an already configured tree with
HAUSTRA_PYTHON=ON); build/release when it is configured with the Python module for this interpreter
(`make` made it: the install then compiles nothing new); otherwise build/pip, configured as the
release preset (Release, unity build) and built for the targets the package needs only.

The package carries the extension, its stubs, and the `haustra` command line (bin/haustra, and
bin/haustra-view when it was built), run by the console script `haustra` (haustra/_command.py).
"""
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent
# What the package is built from: the module, its stubs, the command line and its viewer.
TARGETS = ["haustra_python", "haustra_python_stubs", "haustra"]
OPTIONAL_TARGETS = ["haustra-view"]


def refuse(paragraph, details=""):
    """One paragraph (and lines of details as they are) on stderr, then exit 1: pip shows it as the
    build's output, without a traceback."""
    width, words, line, lines = 100, paragraph.split(), "", []
    for w in words:
        if line and len(line) + 1 + len(w) > width:
            lines.append(line)
            line = w
        else:
            line = f"{line} {w}" if line else w
    lines.append(line)
    sys.stderr.write("\n" + (details + "\n\n" if details else "") + "\n".join(lines) + "\n\n")
    sys.stderr.flush()
    sys.exit(1)


def missing_requirements():
    """What this interpreter lacks to build haustra, each with the Debian package that brings it."""
    missing = []
    for module, package in [("setuptools", "python3-setuptools"), ("wheel", "python3-wheel"),
                            ("numpy", "python3-numpy"), ("pybind11", "python3-pybind11")]:
        try:
            __import__(module)
        except ImportError:
            missing.append(f"{module} ({package})")
    if not (Path(sysconfig.get_paths()["include"]) / "Python.h").exists():
        missing.append("Python.h (python3-dev)")
    for tool, package in [("cmake", "cmake"), ("ninja", "ninja-build"), ("g++", "g++")]:
        if shutil.which(tool) is None:
            missing.append(f"{tool} ({package})")
    return missing


def check_interpreter():
    missing = missing_requirements()
    if not missing:
        return
    refuse(f"haustra cannot be built with this Python ({sys.executable}, {sys.version.split()[0]}): it lacks "
           f"{', '.join(missing)}. haustra builds with Debian's Python, /usr/bin/python3, and Debian's packages "
           "(nothing is downloaded): run scripts/install-deps.sh once, then make the environment with Debian's "
           "interpreter, named in full (a `python3` earlier on PATH, such as pyenv's, has none of them): "
           "/usr/bin/python3 -m venv --system-site-packages .venv && .venv/bin/pip install --no-build-isolation . "
           "(docs/guide.md, Python).")


check_interpreter()

from setuptools import Extension, setup  # noqa: E402  (after the check: its message comes first)
from setuptools.command.build_ext import build_ext  # noqa: E402


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    return re.search(r"project\(haustra VERSION ([0-9.]+)", text).group(1)


def cache_value(tree, name):
    cache = tree / "CMakeCache.txt"
    if not cache.exists():
        return None
    found = re.search(rf"^{re.escape(name)}:[A-Z]+=(.*)$", cache.read_text(errors="replace"), re.MULTILINE)
    return found.group(1) if found else None


def same_interpreter(path):
    return path is not None and os.path.realpath(path) == os.path.realpath(sys.executable)


def choose_tree():
    """(tree, configure?, why): the build tree the package is built in."""
    given = os.environ.get("HAUSTRA_CMAKE_BUILD_DIR")
    if given:
        tree = Path(given).resolve()
        if cache_value(tree, "HAUSTRA_PYTHON") not in ("ON", "TRUE", "1"):
            refuse(f"HAUSTRA_CMAKE_BUILD_DIR={given}: not a CMake build tree configured with HAUSTRA_PYTHON=ON "
                   "(`cmake --preset release` makes one).")
        return tree, False, "HAUSTRA_CMAKE_BUILD_DIR"
    release = ROOT / "build" / "release"
    interpreter = cache_value(release, "Python3_EXECUTABLE") or cache_value(release, "_Python3_EXECUTABLE")
    if cache_value(release, "HAUSTRA_PYTHON") == "ON" and same_interpreter(interpreter):
        return release, False, "the release tree `make` builds, for this interpreter"
    return ROOT / "build" / "pip", True, "a tree of its own"


class Progress:
    """The build's lines to a log; its progress where a person sees it while pip shows a spinner: the
    terminal (/dev/tty) when there is one, else stderr, which pip shows with -v."""

    def __init__(self, log_path):
        self.log = open(log_path, "w")
        self.started = time.monotonic()
        try:
            self.tty = open("/dev/tty", "w")
        except OSError:
            self.tty = None
        self.last = 0.0

    def say(self, text, final=False):
        self.log.write(text + "\n")
        self.log.flush()
        print(text, flush=True)  # pip keeps it (shown with -v, and on failure)
        if self.tty is not None:
            now = time.monotonic()
            if final or now - self.last > 0.2:
                self.last = now
                shown = text if len(text) < 110 else text[:107] + "..."
                self.tty.write(f"\r\033[K{shown}" + ("\n" if final else ""))
                self.tty.flush()

    def run(self, command, label):
        """Runs a command, its output to the log; Ninja's [n/m] lines become the progress line."""
        self.log.write("$ " + " ".join(command) + "\n")
        env = dict(os.environ, NINJA_STATUS="[%f/%t] ")
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                                   bufsize=1)
        tail = []
        for line in process.stdout:
            line = line.rstrip("\n")
            tail = (tail + [line])[-40:]
            step = re.match(r"\[(\d+)/(\d+)\] (?:Building \w+ object |Linking \w+ \w+ \w+ )?(.*)", line)
            elapsed = time.monotonic() - self.started
            if step:
                done, total, what = step.groups()
                what = re.sub(r"CMakeFiles/[^/]+\.dir/", "", what).replace(".o", "")
                self.say(f"haustra: {label} [{done}/{total}] {elapsed:.0f} s  {what}")
            else:
                self.log.write(line + "\n")
        process.wait()
        if process.returncode != 0:
            self.say(f"haustra: {label} failed (exit {process.returncode})", final=True)
            refuse(f"haustra: {label} failed (its last lines above; the whole log: {self.log.name}). A missing "
                   "library or tool: scripts/install-deps.sh installs what the build needs from Debian's packages.",
                   "\n".join(tail))

    def close(self, text):
        self.say(text, final=True)
        self.log.close()
        if self.tty is not None:
            self.tty.close()


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        tree, configure, why = choose_tree()
        tree.mkdir(parents=True, exist_ok=True)
        progress = Progress(tree / "pip-build.log")
        progress.say(f"haustra: building in {tree} ({why}); the log: {tree / 'pip-build.log'}", final=True)
        if configure:
            # As the release preset (CMakePresets.json): Release, unity build in batches of 8.
            progress.run(["cmake", "-S", str(ROOT), "-B", str(tree), "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
                          "-DCMAKE_UNITY_BUILD=ON", "-DCMAKE_UNITY_BUILD_BATCH_SIZE=8", "-DHAUSTRA_PYTHON=ON",
                          f"-DPython3_EXECUTABLE={sys.executable}"], "configuring")
        targets = TARGETS + [t for t in OPTIONAL_TARGETS if self.has_target(tree, t)]
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        progress.run(["cmake", "--build", str(tree), "-j", jobs, "--target", *targets], "compiling")
        package = Path(self.get_ext_fullpath(ext.name)).parent
        package.mkdir(parents=True, exist_ok=True)
        built = sorted((tree / "python" / "haustra").glob("_haustra*.so"))
        stubs = tree / "python" / "haustra" / "_haustra.pyi"  # generated from the module by the build
        if not built or not stubs.exists():
            refuse(f"{tree}: the build made no python/haustra/_haustra*.so or _haustra.pyi")
        shutil.copyfile(built[0], self.get_ext_fullpath(ext.name))
        shutil.copyfile(stubs, package / "_haustra.pyi")
        # The command line (and its viewer, when built) inside the package: the console script
        # `haustra` runs it (haustra/_command.py); `haustra view` finds haustra-view beside it.
        (package / "bin").mkdir(exist_ok=True)
        for program in ["haustra", "haustra-view"]:
            if (tree / "bin" / program).exists():
                shutil.copy2(tree / "bin" / program, package / "bin" / program)
        progress.close(f"haustra: built in {time.monotonic() - progress.started:.0f} s")

    @staticmethod
    def has_target(tree, target):
        listed = subprocess.run(["cmake", "--build", str(tree), "--target", "help"], capture_output=True, text=True)
        return listed.returncode == 0 and re.search(rf"^{re.escape(target)}:", listed.stdout, re.MULTILINE)


setup(version=project_version(), ext_modules=[Extension("haustra._haustra", sources=[])],
      cmdclass={"build_ext": CMakeBuild})
