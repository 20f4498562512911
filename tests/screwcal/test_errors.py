"""The core's exception tree: every subclass beside its root, all drawn in its docstring."""

import importlib
import pkgutil

import screwcal
import screwcal.errors as errors_module
from screwcal.errors import (
    CorrectionRefusedError,
    InputError,
    JointLimitError,
    ScrewcalError,
    TargetRefusedError,
    UnreachableError,
)


def _all_subclasses(cls: type) -> set[type]:
    out = set()
    for sub in cls.__subclasses__():
        out |= {sub} | _all_subclasses(sub)
    return out


def _import_every_module() -> None:
    for info in pkgutil.walk_packages(screwcal.__path__, "screwcal."):
        if not info.name.endswith("__main__"):  # running it is the CLI
            importlib.import_module(info.name)


def test_every_core_error_is_defined_in_errors_py():
    _import_every_module()
    outside = {c.__qualname__: c.__module__ for c in _all_subclasses(ScrewcalError)
               if c.__module__ != errors_module.__name__}
    assert not outside, f"define these in screwcal/errors.py: {outside}"


def test_the_docstring_draws_the_whole_tree():
    _import_every_module()
    doc = errors_module.__doc__ or ""
    missing = [c.__name__ for c in _all_subclasses(ScrewcalError) if c.__name__ not in doc]
    assert not missing


def test_families_callers_catch_as_one():
    for refused in (UnreachableError, JointLimitError, CorrectionRefusedError):
        err = refused("target 3: why", index=3)
        assert isinstance(err, TargetRefusedError) and err.index == 3
    assert not issubclass(TargetRefusedError, InputError)
