"""Public names of a subpackage, importable from it without importing every module at start-up.

A subpackage's `__init__` lists its public names and the module that defines each; the module is
imported on first use (PEP 562), so `from screwcal.kinematics import forward_kinematics` costs
only `forward`'s imports and `screwcal --help` imports none of the numeric code.

The list is the public API: what users call (functions and types, each with a docstring). Tuning
constants and helpers stay in their modules, importable from there by those who need them.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from types import ModuleType

from screwcal.errors import ExtraMissingError


def lazy_exports(package: str, exports: dict[str, str]
                 ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """`__getattr__` and `__dir__` for `package` whose public name N lives in `exports[N]`."""

    def __getattr__(name: str) -> object:  # noqa: N807 (the module hook's required name)
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        setattr(sys.modules[package], name, value)  # the next look-up is a plain attribute
        return value

    def __dir__() -> list[str]:  # noqa: N807
        return sorted(set(exports) | set(vars(sys.modules[package])))

    return __getattr__, __dir__


def optional_import(module: str, extra: str, purpose: str) -> ModuleType:
    """`module`, which only the extra `screwcal[extra]` installs; ExtraMissingError saying what
    needs it and how to install it when it is missing."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ExtraMissingError(
            f"{purpose} needs {module.split('.')[0]}, which is not installed: install the "
            f"extra with `pip install 'screwcal[{extra}]'`") from None
