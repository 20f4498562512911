"""RAPID, read once: a parser for ABB RAPID modules (`parse_module`, over its `scanner` and
`expressions`), its AST (`ast`), and the static check behind `screwcal rapid check` (`check`).
The program filter, `rapid check` and the simulators' interpreter all read RAPID through it.

May import: nothing of ours (a core layer below every other: the standard library only).
"""

from screwcal.rapid.ast import Module
from screwcal.rapid.parser import (
    RapidEncryptedError,
    RapidSyntaxError,
    parse_expression,
    parse_module,
)

__all__ = ["Module", "RapidEncryptedError", "RapidSyntaxError", "parse_expression",
           "parse_module"]
