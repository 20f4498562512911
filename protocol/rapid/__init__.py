"""The RAPID server module for a real IRC5, shipped as package data."""

from importlib.resources import files

MODULE_NAME = "ScrewcalServer.mod"


def module_text() -> str:
    """The text of the RAPID module, to copy onto the controller."""
    return files(__name__).joinpath(MODULE_NAME).read_text(encoding="ascii")
