"""What a real robot adds to its geometry, for the emulated true robot: each effect seeded and
configurable, in presets (`--realism ideal|typical|harsh`) or a realism file.

- joint compliance under gravity: the joints bend by c_j tau_j(q) (`kinematics.compliance`),
  tau from the robot's OWN lumped masses, drawn around the nominal table (each mass within
  +-`mass_spread`, each centre moved within +-`centre_shift_mm` per axis), and its payload;
- backlash (lost motion): a joint stops `backlash_deg` / 2 short of its target on the side it
  came from, so where it stops depends on the direction of its last move;
- read-back lag: the readings returned after a move still carry part of it,
  q_read = q_true - lag_j (q_read - q_read_previous), the model of `calibration.lag`;
- thermal drift: every length of the arm grows by drift_ppm (1 - exp(-t / warmup_s)), t the
  robot's own running time (its motion at `speed_deg_s` plus `dwell_s` per stop: a time scale of
  0 still drifts);
- repeatability: each stop lands within a random joint error of `repeatability_deg` (1 sigma)
  the encoders do not see;
- and the measuring arm's own noise, as before (`simulators.arm`).

`typical` is set so that a geometric-only calibration of the emulated IRB 1600 leaves 0.2-0.4 mm
mean, the figure published laser-tracker calibrations of that robot reach: Nubiola & Bonev
(2013), IRB 1600, 0.36 mm mean after a geometric calibration (0.968 mm before); on the real
IRB 120 tracker set a geometric calibration leaves 0.18 mm held out and joint compliance brings
it to 0.10 mm (issue 25). ABB states the IRB 1600's pose repeatability RP as 0.02 mm. `harsh`
doubles every non-geometric effect of `typical`. `ideal` is the robot with its geometric errors
only.

`typical`'s read-back lag is on joints 2 and 3. With a lag on joint 1 as well (a realism file with
"lag": [0.0002, 0.0002, 0.0002, 0, 0, 0]) the identification finds it too (`screwcal demo`: J1
0.00021, J2-J3 0.00020; AP after 0.055 mm, 0.95x the oracle floor). Until issue 40 the lag was
estimated without the backlash the same move carries: joint 1's went unflagged, joints 2-3 came
out at 75 %, and AP after rose to 0.09-0.11 mm.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.compliance import LumpedMass, Payload
from screwcal.kinematics.model import SerialModel

if TYPE_CHECKING:
    from simulators.world import World

N_JOINTS = 6
_PER_JOINT = ("compliance_deg_per_knm", "backlash_deg", "lag")
# Which fields `scaled` multiplies: the non-geometric effects (not the mass draw, not the clock).
_EFFECTS = ("compliance_deg_per_knm", "backlash_deg", "lag", "drift_ppm", "repeatability_deg")


@dataclass(frozen=True)
class Realism:
    """The emulated robot's non-geometric behaviour (units in the names)."""

    name: str = "ideal"
    compliance_deg_per_knm: tuple[float, ...] = (0.0,) * N_JOINTS  # per joint
    mass_spread: float = 0.0  # each lumped mass drawn within +- this fraction of nominal
    centre_shift_mm: float = 0.0  # each centre moved within +- this, per axis
    payload_kg: float = 0.0  # what the flange carries
    payload_cog_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # in the flange frame
    backlash_deg: tuple[float, ...] = (0.0,) * N_JOINTS  # lost motion per joint
    lag: tuple[float, ...] = (0.0,) * N_JOINTS  # fraction of the previous move, per joint
    drift_ppm: float = 0.0  # link-length growth once warm, parts per million
    warmup_s: float = 1800.0  # time constant of the warm-up
    speed_deg_s: float = 60.0  # the robot's own clock: its joint speed ...
    dwell_s: float = 1.0  # ... and the time each stop lasts (settling, measuring)
    repeatability_deg: float = 0.0  # 1 sigma random joint error per stop, unseen by encoders

    def __post_init__(self) -> None:
        for name in _PER_JOINT:
            value = tuple(float(v) for v in getattr(self, name))
            if len(value) != N_JOINTS:
                raise ModelError(f"realism {self.name}, {name}: {N_JOINTS} values (one per "
                                 f"joint), got {len(value)}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "payload_cog_mm", tuple(float(v) for v in self.payload_cog_mm))
        if len(self.payload_cog_mm) != 3:
            raise ModelError(f"realism {self.name}, payload_cog_mm: x, y, z")
        for f in fields(self):
            if f.name == "name":
                continue
            values = np.atleast_1d(np.asarray(getattr(self, f.name), dtype=float))
            if not np.all(np.isfinite(values)):
                raise ModelError(f"realism {self.name}, {f.name}: finite numbers")
            if f.name != "payload_cog_mm" and np.any(values < 0):
                raise ModelError(f"realism {self.name}, {f.name}: cannot be negative, got "
                                 f"{getattr(self, f.name)}")
        if self.mass_spread >= 1.0:
            raise ModelError(f"realism {self.name}, mass_spread: below 1 (a fraction), got "
                             f"{self.mass_spread}")
        if any(v >= 1.0 for v in self.lag):
            raise ModelError(f"realism {self.name}, lag: fractions below 1, got {self.lag}")
        if self.warmup_s <= 0 or self.speed_deg_s <= 0:
            raise ModelError(f"realism {self.name}: warmup_s and speed_deg_s must be positive")

    def scaled(self, factor: float, name: str) -> Realism:
        """Every non-geometric effect times `factor` (the masses' draw and the clock kept)."""
        changes: dict[str, Any] = {"name": name}  # each field its own type: tuples or floats
        for key in _EFFECTS:
            value = getattr(self, key)
            changes[key] = tuple(factor * v for v in value) if isinstance(value, tuple) else \
                factor * value
        return replace(self, **changes)

    @property
    def payload(self) -> Payload:
        return Payload(self.payload_kg, self.payload_cog_mm)

    @property
    def is_ideal(self) -> bool:
        """Nothing but the geometry (and the arm's noise)."""
        return not (any(self.compliance_deg_per_knm) or any(self.backlash_deg)
                    or any(self.lag) or self.drift_ppm or self.repeatability_deg
                    or self.payload_kg)

    def drift_scale(self, running_s: float) -> float:
        """1 + the relative growth of every length after `running_s` of the robot's time."""
        return 1.0 + 1e-6 * self.drift_ppm * (1.0 - np.exp(-running_s / self.warmup_s))

    def to_document(self) -> dict:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    def describe(self) -> list[str]:
        """What the robot carries, one line per effect, in words with their units (the
        realism file's keys are this module's docstring's and the dataclass's fields)."""
        if self.is_ideal:
            return ["geometric errors only (realism ideal): no compliance, backlash, read-back "
                    "lag, drift or repeatability error"]

        def joints(values: tuple[float, ...], unit: str = "") -> str:
            return ", ".join(f"J{j + 1} {v:g}{unit}" for j, v in enumerate(values) if v)

        out = []
        if any(self.compliance_deg_per_knm):
            out.append(f"joint compliance under gravity: "
                       f"{joints(self.compliance_deg_per_knm, ' deg/kNm')} (its own masses up "
                       f"to {100 * self.mass_spread:g} % off the nominal table, their centres "
                       f"moved up to {self.centre_shift_mm:g} mm)")
        out.append(f"payload: {self.payload_kg:g} kg, centre of gravity at "
                   f"({', '.join(f'{v:g}' for v in self.payload_cog_mm)}) mm in the flange "
                   "frame")
        if any(self.backlash_deg):
            out.append(f"backlash (lost motion): {joints(self.backlash_deg, ' deg')}")
        if any(self.lag):
            out.append(f"read-back lag: {joints(self.lag)} (the fraction of the previous move "
                       "the joint readings trail)")
        if self.drift_ppm:
            out.append(f"thermal drift: the links grow {self.drift_ppm:g} ppm once warm, with a "
                       f"warm-up time constant of {self.warmup_s:g} s of running (emulated "
                       "time)")
        if self.repeatability_deg:
            out.append(f"repeatability error: {self.repeatability_deg:g} deg per joint and stop "
                       "(1 sigma)")
        return out


IDEAL = Realism()
TYPICAL = Realism(
    name="typical",
    compliance_deg_per_knm=(0.0, 0.12, 0.20, 0.0, 0.0, 0.0),
    mass_spread=0.25, centre_shift_mm=50.0,
    backlash_deg=(0.006, 0.006, 0.006, 0.010, 0.010, 0.010),
    lag=(0.0, 0.0002, 0.0002, 0.0, 0.0, 0.0),  # joints 2-3 (see the module's note)
    drift_ppm=40.0, warmup_s=1800.0,
    repeatability_deg=0.0003,
)
HARSH = TYPICAL.scaled(2.0, "harsh")
PRESETS = {"ideal": IDEAL, "typical": TYPICAL, "harsh": HARSH}


def realism_from_document(doc: object, where: str) -> Realism:
    """A realism file: {"preset": "typical", "backlash_deg": [...], ...}: a preset (default
    ideal) with some fields changed."""
    if not isinstance(doc, dict):
        raise ModelError(f"{where}: expected an object such as {{\"preset\": \"typical\", "
                         "\"payload_kg\": 10}")
    doc = dict(doc)
    preset = doc.pop("preset", doc.get("name", "ideal"))
    if preset not in PRESETS:
        raise ModelError(f"{where}: preset '{preset}' is not one of {', '.join(PRESETS)}")
    known = {f.name for f in fields(Realism)}
    unknown = sorted(set(doc) - known)
    if unknown:
        raise ModelError(f"{where}: unknown field(s) {', '.join(unknown)}; known: "
                         f"{', '.join(sorted(known))}")
    try:
        return replace(PRESETS[preset], **{"name": f"{preset} (changed)" if doc else preset,
                                           **doc})
    except (TypeError, ValueError) as err:
        raise ModelError(f"{where}: {err}") from None


def read_realism(path: str) -> Realism:
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:  # JSONDecodeError, UnicodeDecodeError
        raise ModelError(f"{path}: cannot read the realism file ({err})") from None
    return realism_from_document(doc, path)


def own_masses(nominal: tuple[LumpedMass, ...], realism: Realism,
               rng: np.random.Generator) -> tuple[LumpedMass, ...]:
    """The true robot's lumped masses: each nominal mass within +-mass_spread, its centre moved
    within +-centre_shift_mm per axis."""
    out = []
    for m in nominal:
        kg = m.kg * (1.0 + rng.uniform(-realism.mass_spread, realism.mass_spread))
        shift = rng.uniform(-realism.centre_shift_mm, realism.centre_shift_mm, 3)
        x, y, z = (float(v) for v in np.asarray(m.home_mm) + shift)
        out.append(LumpedMass(m.link, float(kg), (x, y, z)))
    return tuple(out)


def with_realism(truth: SerialModel, realism: Realism, rng: np.random.Generator) -> SerialModel:
    """The true robot bending under its own masses and payload (unchanged when ideal)."""
    if not any(realism.compliance_deg_per_knm):
        return truth if not realism.payload_kg else replace(truth, payload=realism.payload)
    return replace(truth, masses=own_masses(truth.masses, realism, rng),
                   compliance=np.radians(np.asarray(realism.compliance_deg_per_knm)) / 1000.0,
                   payload=realism.payload)


class ListPayloads:
    """The emulated cell's operator: mounts the payload named for each list the controller runs
    (e.g. {"CAL": 10 kg, "PERF": none}), as a job that calibrates and evaluates under different
    loads asks. A world observer (first in the list: before anything reads the holes)."""

    def __init__(self, list_name: Callable[[], str], payloads: dict[str, Payload]):
        self.list_name, self.payloads = list_name, dict(payloads)

    def __call__(self, world: World) -> None:
        payload = self.payloads.get(self.list_name())
        if payload is not None and payload != world.truth.payload:
            world.set_payload(payload)


def parse_list_payload(text: str) -> tuple[str, Payload]:
    """`CAL=10` or `CAL=10:0,0,100` (kg, and the centre of gravity in the flange frame, mm)."""
    name, sep, rest = text.partition("=")
    kg, _, cog = rest.partition(":")
    try:
        if not sep or name.strip().upper() not in ("CAL", "PERF"):
            raise ValueError
        values = [float(v) for v in cog.split(",")] if cog else [0.0, 0.0, 0.0]
        if len(values) != 3:
            raise ValueError
        xyz = (values[0], values[1], values[2])
        payload = Payload(float(kg), xyz)
        if payload.kg < 0 or not np.all(np.isfinite([payload.kg, *xyz])):
            raise ValueError
    except ValueError:
        raise ValueError(f"'{text}': give LIST=KG or LIST=KG:X,Y,Z, LIST CAL or PERF, KG >= 0, "
                         "X,Y,Z in mm") from None
    return name.strip().upper(), payload
