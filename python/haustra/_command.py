"""The `haustra` command line of an installed package: the console script runs the program built
with the module (bin/haustra inside the package, decision 0101)."""
import os
import pathlib
import sys

PACKAGE = pathlib.Path(__file__).resolve().parent
# Installed: bin/ inside the package; in a CMake build tree (build/release/python/haustra): its bin/.
PLACES = [PACKAGE / "bin", PACKAGE.parent.parent / "bin"]


def program(name="haustra"):
    """The path of a program built with the package (haustra, haustra-view), or None."""
    for place in PLACES:
        path = place / name
        if path.is_file() and os.access(path, os.X_OK):
            return str(path)
    return None


def main():
    found = program()
    if found is None:
        sys.stderr.write("haustra: this installation has no command line (the package's bin/haustra is missing): "
                         "install the package with pip from the source tree, or build it with CMake "
                         "(build/release/bin/haustra)\n")
        return 2
    os.execv(found, [found, *sys.argv[1:]])
    return 0  # not reached


if __name__ == "__main__":
    sys.exit(main())
