"""Simulated calibration studies (thesis Chapter 3, Fig. 17): `screwcal study NAME`.

Each study draws `samples` simulated calibrations from one seed (a process pool with
`--workers`), writes the raw samples as CSV, a markdown table with the thesis's figure beside ours
where the thesis gives one, and a PNG. Figures are the thesis's (mean |error| over the
calibration configurations after correction: T_PO in mm, TOr_i/j/k in degrees) and, beside them,
the error on 200 noise-free held-out configurations (`val_mm`), which is what a user gets.

The studies themselves (how a sample is drawn, the thesis's figures) are in `registry`; this
module runs them and writes their reports.
"""

from __future__ import annotations

import csv
import fnmatch
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np

from screwcal._lazy import optional_import
from screwcal.runtime.policy import for_worker
from screwcal.studies.markdown import markdown_table
from screwcal.studies.registry import STUDIES, Study
from screwcal.studies.thesis_metrics import Row

__all__ = ["STUDIES", "comparison", "plot", "run_samples", "run_study", "study_table"]


def run_samples(name: str, seed: int, samples: int, workers: int,
                scheduler: str | None = None) -> list[Row]:
    """The study's samples: in this process, a local process pool, or a Dask cluster at
    `scheduler` (an address); the same seed gives the same rows wherever they run."""
    study = STUDIES[name]
    samples = min(samples, study.max_samples or samples)
    seeds = [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(samples)]
    fn = study.sample
    if scheduler is not None:
        dask = optional_import("distributed", "cluster", "a study on a Dask cluster (--scheduler)")
        with dask.Client(scheduler) as client:
            chunks = client.gather(client.map(partial(_in_worker, fn), seeds, pure=False))
    elif workers <= 1:
        chunks = [fn(s) for s in seeds]
    else:
        with ProcessPoolExecutor(workers, initializer=for_worker) as pool:
            chunks = list(pool.map(fn, seeds))
    return [{"sample": k, **row} for k, rows in enumerate(chunks) for row in rows]


def _in_worker(fn: Callable[[int], list[Row]], seed: int) -> list[Row]:
    """A sample on a Dask worker, under the worker processes' policy (`screwcal.runtime.policy`: a
    cluster's workers start without the pool's initialiser; applied again, it changes
    nothing)."""
    for_worker()
    return fn(seed)


def _why(study: Study, key: str) -> str:
    for pattern, text in study.why.items():
        if fnmatch.fnmatchcase(key, pattern):
            return text
    return "outside the scatter of our samples: see the note"


def comparison(study: Study, key: str, sel: list[Row], thesis: float | None) -> str:
    """Why ours and the thesis's value differ, or that they agree, from the samples: within
    their scatter; or, for an 'after' figure, measured against the floor the random joint
    error alone sets at the same poses; or the study's stated reason."""
    if thesis is None:
        return ""
    values = np.array([float(r[key]) for r in sel])
    mean, sd = float(values.mean()), float(values.std())
    rel = f"{(mean - thesis) / thesis:+.0%}" if thesis else ""
    if abs(mean - thesis) <= max(2 * sd, 0.02 * abs(thesis)):
        return f"{rel} agrees: within the scatter of our samples"
    floor_key = f"floor_{key}"
    if floor_key in sel[0]:
        floor = float(np.mean([float(r[floor_key]) for r in sel]))
        unit = "mm" if key.endswith("_mm") else "deg"
        head = (f"{rel}: the ±0.05 deg joint error alone gives {floor:.3f} {unit} at our poses "
                f"(ours is {mean - floor:+.3f} from that floor)")
        if thesis < floor:
            return (f"{head}; the thesis's value is below it, so its evaluation carried less "
                    "joint error than a uniform ±0.05 deg on every joint at these poses")
        return (f"{head}; the thesis's is {thesis - floor:+.3f} above it: its one estimate "
                "left that much more in the model")
    return f"{rel} {_why(study, key)}"


def _selected(study: Study, rows: list[Row]) -> list[Row]:
    """The rows a study reads (`select`), e.g. table8's corrected=all of the shared samples."""
    if study.select is None:
        return rows
    column, value = study.select
    return [r for r in rows if r[column] == value]


def study_table(name: str, rows: list[Row]) -> str:
    """The Markdown table of a study's rows: each case's mean errors beside the thesis's."""
    study = STUDIES[name]
    rows = _selected(study, rows)
    cases = list(dict.fromkeys(r[study.group] for r in rows))
    n = len(rows) // len(cases)
    lines = [f"# Study `{name}`", "", study.note, "",
             f"`screwcal study {name}` ({n} samples; ours: mean ± std over the samples). Ours "
             "uses the thesis's metric (T_PO from the per-axis mean |error|, TOr from Euler-angle "
             "differences) with the ±0.05 deg random joint error in the evaluation, as the "
             "thesis's figures do; the next column is the same without the joint error.", ""]
    cells = []
    for case in cases:
        sel = [r for r in rows if r[study.group] == case]
        extra = study.more(str(case)) if study.more else ()
        for key, label in (*study.quantities, *extra):
            if key not in sel[0]:
                continue
            v = np.array([float(r[key]) for r in sel])
            exact = f"{key}_exact"
            plain = (f"{np.mean([float(r[exact]) for r in sel]):.3f}" if exact in sel[0] else "")
            ref = study.thesis.get(str(case), {}).get(key)
            cells.append((f"{case}", label, "" if ref is None else f"{ref:g}",
                          f"{v.mean():.3f} ± {v.std():.3f}", plain,
                          comparison(study, key, sel, ref)))
    lines += markdown_table((study.group, "quantity", "thesis", "ours", "ours, no joint error",
                             "why they differ"), cells)
    text = "\n".join(lines) + "\n"
    if study.conclusion:
        text += study.conclusion(rows)
    return text


def plot(name: str, rows: list[Row], path: Path) -> None:
    from matplotlib.figure import Figure  # its own Agg canvas: no pyplot, no global backend

    study = STUDIES[name]
    rows = _selected(study, rows)
    cases = list(dict.fromkeys(r[study.group] for r in rows))
    numeric = all(isinstance(c, int | float) for c in cases)
    panels = study.panels or (("T_PO", ("tpo_mm",), "mm"),)
    fig = Figure(figsize=(5 * len(panels), 3.6))
    ax = fig.subplots(1, len(panels), squeeze=False)
    for k, (title, keys, unit) in enumerate(panels):
        a = ax[0, k]
        for j, key in enumerate(keys):
            if key not in rows[0]:
                continue
            means = [np.mean([float(r[key]) for r in rows if r[study.group] == c]) for c in cases]
            if numeric:
                a.plot(cases, means, "o-", label=key)
            else:
                width = 0.8 / len(keys)
                a.bar(np.arange(len(cases)) + j * width, means, width, label=key)
        if not numeric:
            a.set_xticks(np.arange(len(cases)) + 0.4 - 0.4 / len(keys),
                         [str(c) for c in cases], rotation=20, fontsize=7)
        if numeric and name == "weight":
            a.set_xscale("log")
        a.set(title=title, ylabel=unit, xlabel=study.group)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def run_study(name: str, seed: int, samples: int, workers: int, out: Path,
              scheduler: str | None = None) -> str:
    """Run study `name` and write its CSV, table and plot into `out`; returns the table."""
    out.mkdir(parents=True, exist_ok=True)
    rows = run_samples(name, seed, samples, workers, scheduler)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with (out / f"{name}.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    text = study_table(name, rows)
    (out / f"{name}.md").write_text(text, encoding="utf-8")
    plot(name, rows, out / f"{name}.png")
    return text
