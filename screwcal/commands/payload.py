"""The payload named on the command line (`--payload-kg`, `--payload-cog-mm`:
`arguments.add_payload_arguments`) put on a model: calibrate, compensate and predict take it."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from screwcal.kinematics.model import SerialModel


def with_payload(model: SerialModel, args: argparse.Namespace) -> SerialModel:
    """The model carrying the payload named on the command line (joint compliance scales
    with it); unchanged without --payload-kg."""
    if getattr(args, "payload_kg", None) is None:
        return model
    from dataclasses import replace

    from screwcal.kinematics.compliance import Payload

    return replace(model, payload=Payload(args.payload_kg, tuple(args.payload_cog_mm)))
