"""A routine's activation: its routine, its local data and parameters, and whether its ERROR
handler runs (with the error it handles)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from screwcal.rapid import ast as A  # noqa: N812 - the node classes
from simulators.rapid.errors import RapidError


@dataclass
class Frame:
    routine: A.Routine
    vars: dict[str, Any]
    in_handler: bool = False
    error: RapidError | None = None
