"""Writes haustra/_haustra.pyi from the built extension: pybind11's typed signatures and the docstrings.

Run at build time (python/CMakeLists.txt) with the package folder's parent on sys.path:
    python3 tools/stubgen.py BUILD/python/haustra/_haustra.pyi
The signatures are pybind11's own (the binding's C++ types and the names typed.hpp gives them), so
the stub says what the module accepts; python/tests/test_types.py checks stub and module agree.
"""

import inspect
import re
import sys

import haustra._haustra as module

HEADER = '''"""Type stubs of haustra._haustra, generated from the module by python/tools/stubgen.py. Do not edit."""

import os
import typing
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy
import numpy.typing

import haustra.types
'''


def clean_type(text):
    text = text.replace("haustra._haustra.", "")
    text = re.sub(r"\bos\.PathLike\b", "Union[str, os.PathLike[str]]", text)
    text = re.sub(r"^buffer$", "Union[bytes, bytearray, memoryview]", text)  # py::buffer: any bytes-like
    return text


def split_top(text):
    parts, depth, current = [], 0, ""
    for c in text:
        if c == "," and depth == 0:
            parts.append(current.strip())
            current = ""
            continue
        depth += c in "([{"
        depth -= c in ")]}"
        current += c
    if current.strip():
        parts.append(current.strip())
    return parts


def typed_signature(doc):
    """pybind11's first docstring line, 'name(a: T, b: U = x) -> R', as (parameters, return, rest of doc)."""
    first, _, rest = doc.partition("\n")
    match = re.match(r"^\w*\((.*)\) -> (.+)$", first)
    if not match:
        raise SystemExit(f"stubgen: no pybind11 signature in {first!r}")
    parameters = []
    for p in split_top(match.group(1)):
        name, _, annotation = p.partition(": ")
        annotation, has_default, default = annotation.partition(" = ")
        annotation = clean_type(annotation) if annotation else ""
        if has_default and default == "None" and not annotation.startswith("Optional["):
            annotation = f"Optional[{annotation}]"
        parameters.append(name + (f": {annotation}" if annotation and name != "self" else "") +
                          (" = ..." if has_default else ""))
    return parameters, clean_type(match.group(2)), rest.strip()


def docstring(text, indent):
    text = text.strip().replace('"""', "'''").replace("\\", "\\\\")
    return f'{indent}"""{text}"""\n' if text else ""


def function(name, doc, indent="", decorator=None):
    parameters, returns, rest = typed_signature(doc)
    if decorator == "staticmethod":
        out = f"{indent}@staticmethod\n"
    else:
        out = ""
    out += f"{indent}def {name}({', '.join(parameters)}) -> {returns}:\n"
    return out + (docstring(rest, indent + "    ") or f"{indent}    ...\n")


def prop(name, value, indent):
    _, returns, _ = typed_signature(value.fget.__doc__.replace("(", "getter(", 1))
    out = f"{indent}@property\n{indent}def {name}(self) -> {returns}:\n"
    out += docstring(value.__doc__ or "", indent + "    ") or f"{indent}    ...\n"
    if value.fset is not None:
        parameters, _, _ = typed_signature(value.fset.__doc__.replace("(", "setter(", 1))
        out += f"{indent}@{name}.setter\n{indent}def {name}(self, {parameters[1].split(':')[0]}: " \
               f"{parameters[1].partition(': ')[2]}) -> None: ...\n"
    return out


# Methods whose result type depends on an argument: their overloads, written here because pybind11's
# single signature cannot say it (step() returns the recording only when record= names quantities).
RECORDING = "dict[str, numpy.typing.NDArray[typing.Any]]"
OVERLOADS = {
    ("World", "step"): [
        "(self, n: int = ..., record: None = ...) -> None",
        f"(self, n: int, record: List[str]) -> {RECORDING}",
        f"(self, *, record: List[str]) -> {RECORDING}",
    ],
}


def overloaded(cls_name, name, doc, indent):
    _, _, rest = typed_signature(doc)
    out = ""
    for i, signature in enumerate(OVERLOADS[(cls_name, name)]):
        out += f"{indent}@typing.overload\n{indent}def {name}{signature}:\n"
        out += (docstring(rest, indent + "    ") if i == 0 else "") or f"{indent}    ...\n"
    return out


def class_stub(cls):
    bases = [b.__name__ if b.__module__ in ("haustra", module.__name__) else b.__name__ for b in cls.__bases__
             if b is not object and b.__name__ != "pybind11_object"]
    out = f"class {cls.__name__}({', '.join(bases)}):\n" if bases else f"class {cls.__name__}:\n"
    out += docstring(cls.__doc__ or "", "    ")
    members = [(n, v) for n, v in sorted(cls.__dict__.items()) if not n.startswith("_") or n in
               ("__init__", "__getstate__", "__setstate__", "__repr__", "__len__")]
    for name, value in members:
        if isinstance(value, property):
            out += prop(name, value, "    ")
        elif isinstance(value, staticmethod):
            out += function(name, value.__func__.__doc__, "    ", "staticmethod")
        elif (cls.__name__, name) in OVERLOADS:
            out += overloaded(cls.__name__, name, value.__doc__, "    ")
        elif callable(value) and getattr(value, "__doc__", None):
            out += function(name, value.__doc__, "    ")
    return out if members or cls.__doc__ else out + "    ...\n"


ERROR_ATTRIBUTES = """    code: str  # the kind: 'invalid_argument', 'io', 'parse', 'invalid_geometry', 'unstable', 'internal'
    field: Optional[str]  # the scene field it is about
    recording: Dict[str, numpy.typing.NDArray[Any]]  # raised by step(n, record=...): the frames before it
"""


def exception_stub(cls):
    bases = ", ".join(b.__name__ for b in cls.__bases__)
    out = f"class {cls.__name__}({bases}):\n" + (docstring(cls.__doc__ or "", "    ") or "    ...\n")
    return out + (ERROR_ATTRIBUTES if cls is module.Error else "")


def main(path):
    parts = [HEADER]
    names = sorted(n for n in dir(module) if not n.startswith("_"))
    errors = [module.Error] + [getattr(module, n) for n in names if inspect.isclass(getattr(module, n)) and
                               issubclass(getattr(module, n), BaseException) and n != "Error"]
    for cls in errors:
        parts.append(exception_stub(cls))
    for name in names:
        value = getattr(module, name)
        if inspect.isclass(value):
            if not issubclass(value, BaseException):
                parts.append(class_stub(value))
        elif callable(value):
            parts.append(function(name, value.__doc__))
    parts.append("__version__: str\n")
    for name in names:
        value = getattr(module, name)
        if isinstance(value, tuple):
            parts.append(f"{name}: Tuple[str, ...]\n")
    with open(path, "w", encoding="utf-8") as out:
        out.write("\n\n".join(p.rstrip("\n") + "\n" for p in parts))


if __name__ == "__main__":
    main(sys.argv[1])
