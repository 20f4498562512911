"""What a study's samples say, in words: the conclusions and notes under a study's table,
each measured from the rows (not written in advance).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np

from screwcal.studies.thesis_metrics import Row


def _stats(rows: list[Row], group: str, case: object, key: str) -> tuple[float, float, int]:
    v = np.array([float(r[key]) for r in rows if r[group] == case])
    return float(v.mean()), float(v.std()), len(v)


def design_conclusion(rows: list[Row]) -> str:
    """Does the designed set beat the Klimchik-style one on held-out error? Said from the data."""
    (kv, ks, _), (dv, ds, p) = (_stats(rows, "set", n, "val_mm")
                                for n in ("Klimchik-style", "D-optimal"))
    ke, de = ks / np.sqrt(p), ds / np.sqrt(p)
    gain = _stats(rows, "set", "D-optimal", "log_det")[0] - \
        _stats(rows, "set", "Klimchik-style", "log_det")[0]
    beats = dv + 2 * de < kv
    text = (f"\n**Result.** The D-optimal set {'beats' if beats else 'does not clearly beat'} "
            f"the Klimchik-style set on held-out error ({dv:.3f} ± {de:.3f} vs {kv:.3f} ± "
            f"{ke:.3f} mm, mean ± standard error over {p} samples). It raises log det of the "
            f"information matrix by {gain:.2f} (10 parameters: about "
            f"{100 * (1 - np.exp(-gain / 20)):.0f} % smaller parameter standard deviations on "
            "geometric average).")
    if not beats:
        text += (" Why not more: both sets are spread over the same 600 mm cube, and the "
                 "held-out poses cover the whole workspace, where the error is dominated by "
                 "extrapolating the offsets outside the cube; a larger or better-placed region "
                 "(see `quadrants`) matters more than the choice inside it.")
    return text + "\n"


def weight_conclusion(rows: list[Row]) -> str:
    """Which W is best, and what sets it: measured from the samples."""
    ws = sorted({float(r["W_mm"]) for r in rows})
    means = {w: _stats(rows, "W_mm", w, "tpo_mm")[0] for w in ws}
    best = min(means, key=means.__getitem__)
    sd_mm = float(np.mean([float(r["resid_sd_mm"]) for r in rows]))
    sd_deg = float(np.mean([float(r["resid_sd_deg"]) for r in rows]))
    return (f"\n**Result.** The lowest T_PO is at W = {best:g} mm/deg ({means[best]:.3f} mm; "
            f"W = 1: {means.get(1.0, float('nan')):.3f} mm). What sets the best W is the random "
            f"joint error, not the instrument: the measured poses scatter about the truth by "
            f"{sd_mm:.3f} mm per position axis and {sd_deg:.4f} deg per rotation axis (the "
            f"±0.05 deg joint error, carried to the flange), a ratio of {sd_mm / sd_deg:.1f} "
            "mm/deg; Eq. 2.4 weighs the two alike when W is near that ratio. The instrument "
            "alone (0.013 mm, ~0.015 deg) would give about 1 mm/deg. The default statistical "
            "weighting estimates both levels from the residuals and needs no W.\n")


def ordering_note(rows: list[Row], group: str, key: str, order: Sequence[str],
                  label: str) -> str:
    """How often the thesis's ordering of the sets holds over single samples."""
    samples = sorted({int(r["sample"]) for r in rows})
    held = 0
    for s in samples:
        v = {str(r[group]): float(r[key]) for r in rows if r["sample"] == s}
        held += all(v[a] < v[b] for a, b in itertools.pairwise(order))
    spread = "; ".join(f"{n} {m:.3f} ± {sd:.3f}" for n in order
                       for m, sd, _ in [_stats(rows, group, n, key)])
    return (f"\n**{label}.** The thesis's ordering {' < '.join(order)} (from one sample) holds in "
            f"{held} of {len(samples)} samples here ({spread} mm, mean ± std): the differences "
            "between the sets are "
            f"{'smaller than' if held < 0.9 * len(samples) else 'larger than'} the scatter of "
            "single samples, so one sample cannot rank them.\n")
