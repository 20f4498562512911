"""PNG plots of performance results and pose plans (matplotlib, no display needed).

- `accuracy_per_point`: AP and orientation accuracy per point, before/after (thesis Fig. 43).
- `straightness_along_path`: signed deviation from the LS line along the path (Fig. 44).
- `attained_vs_commanded`: attained positions against commanded ones (Fig. 38).
- `test_cube`: the ISO 9283 cube, its inclined plane, P1-P5, return points, the robot at P1 and
  the measuring arm's reach, in three views a person can check.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from numpy.typing import ArrayLike

from screwcal.kinematics.forward import joint_positions
from screwcal.kinematics.model import SerialModel
from screwcal.performance.iso9283 import PoseMetrics
from screwcal.performance.straightness import Straightness
from screwcal.performance.testcube import ArmSphere, TestCube

_COLOURS = {"before": "#d95f02", "after": "#1b9e77"}


def _save(fig: Figure, path: str | Path) -> Path:
    """PNG through the figure's own Agg canvas: no pyplot, no process-wide backend set."""
    path = Path(path)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path


def _legend_above(ax: Axes) -> None:
    """The legend in a row above the plot, where it covers no bar and no point."""
    ax.legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=3, frameon=False,
              fontsize="small")


def accuracy_per_point(results: Mapping[str, Mapping[str, PoseMetrics]], path: str | Path
                       ) -> Path:
    """Grouped bars of AP (mm) and max(|AP_a|, |AP_b|, |AP_c|) (deg) per point, one bar per
    result: the figures of the evaluate report's tables (`ap_abc_deg_max` is their maximum)."""
    labels = list(next(iter(results.values())))
    has_orientation = all(m.ap_abc_deg is not None for r in results.values() for m in r.values())
    ncols = 2 if has_orientation else 1
    fig = Figure(figsize=(6 * ncols, 4))
    axes = fig.subplots(1, ncols, squeeze=False)
    width = 0.8 / len(results)
    x = np.arange(len(labels))
    for k, (name, metrics) in enumerate(results.items()):
        colour = _COLOURS.get(name)
        ap = [metrics[lbl].ap_mm for lbl in labels]
        axes[0, 0].bar(x + k * width, ap, width, label=name, color=colour)
        if has_orientation:
            largest = [metrics[lbl].ap_abc_max_abs_deg for lbl in labels]
            axes[0, 1].bar(x + k * width, largest, width, label=name, color=colour)
    axes[0, 0].set_title("(a) position accuracy (ISO 9283, Eq. 2.5)", pad=24)
    axes[0, 0].set_ylabel("AP = |mean reached - commanded| [mm]")
    if has_orientation:
        axes[0, 1].set_title("(b) orientation accuracy (Eq. 2.9)", pad=24)
        axes[0, 1].set_ylabel("max(|APa|, |APb|, |APc|) [deg]")
    for ax in axes[0]:
        ax.set_xticks(x + width * (len(results) - 1) / 2, labels)
        _readable_scale(ax)
        ax.grid(axis="y", alpha=0.3)
        _legend_above(ax)
    return _save(fig, path)


def _readable_scale(ax: Axes, ratio: float = 20.0) -> None:
    """A log scale when the tallest bar is `ratio` times the shortest: an "after" 100x smaller
    than "before" stays visible."""
    heights = np.array([b.get_height() for b in ax.patches if isinstance(b, Rectangle)],
                       dtype=np.float64)
    heights = heights[heights > 0]
    if heights.size and heights.max() > ratio * heights.min():
        ax.set_yscale("log")
        ax.set_ylabel(ax.get_ylabel() + " (log scale)")


def straightness_along_path(results: Mapping[str, Straightness], path: str | Path) -> Path:
    """Signed deviation (u) from the least-squares line against the position along it."""
    fig = Figure(figsize=(7, 4))
    ax = fig.subplots()
    for name, s in results.items():
        order = np.argsort(s.along_mm)
        ax.plot(s.along_mm[order], s.deviation_u_mm[order], "o-", color=_COLOURS.get(name),
                label=f"{name}: peak + valley {s.peak_to_valley_mm:.3f} mm")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_title("Straightness (ISO 12780-1, least-squares line)", pad=24)
    ax.set(xlabel="position along the line [mm]", ylabel="signed deviation u [mm]")
    ax.grid(alpha=0.3)
    _legend_above(ax)
    return _save(fig, path)


def attained_vs_commanded(commanded_mm: ArrayLike, attained_mm: ArrayLike, path: str | Path
                          ) -> Path:
    """Per axis, attained against commanded position, and the error vectors in 3-D."""
    c = np.asarray(commanded_mm, dtype=float)
    a = np.asarray(attained_mm, dtype=float)
    fig = Figure(figsize=(13, 4))
    for i, axis in enumerate("xyz"):
        ax = fig.add_subplot(1, 4, i + 1)
        ax.scatter(c[:, i], a[:, i] - c[:, i], s=8)
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set(title=f"{axis}: attained - commanded", xlabel=f"commanded {axis} [mm]",
               ylabel="[mm]")
        ax.grid(alpha=0.3)
    ax3 = fig.add_subplot(1, 4, 4, projection="3d")
    ax3.scatter(*c.T, s=10, label="commanded")
    ax3.scatter(*a.T, s=10, label="attained")
    ax3.set(title="positions [mm]", xlabel="x", ylabel="y", zlabel="z")
    ax3.legend()
    fig.tight_layout()
    return _save(fig, path)


def test_cube(model: SerialModel, cube: TestCube, q_p1_rad: ArrayLike, path: str | Path,
              arm: ArmSphere | None = None) -> Path:
    """Three views (3-D, side x-z, top x-y) of the cube, plane, points and robot at P1."""
    corners = cube.corners_mm
    edges = [(i, j) for i in range(8) for j in range(i + 1, 8)
             if np.isclose(np.linalg.norm(corners[i] - corners[j]), cube.edge_mm)]
    plane = np.vstack([cube.plane_corners_mm, cube.plane_corners_mm[:1]])
    pts = cube.points_mm
    skeleton = np.vstack([[0.0, 0.0, 0.0],
                          joint_positions(model, np.atleast_2d(q_p1_rad))[0]])
    fig = Figure(figsize=(15, 5))
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    views = [(ax3, (0, 1, 2)), (fig.add_subplot(1, 3, 2), (0, 2)),
             (fig.add_subplot(1, 3, 3), (0, 1))]
    for ax, dims in views:
        def draw(xyz: np.ndarray, *args: str, ax: Axes = ax, dims: tuple[int, ...] = dims,
                 **kw: Any) -> None:
            ax.plot(*[xyz[:, d] for d in dims], *args, **kw)

        for i, j in edges:
            draw(corners[[i, j]], color="0.6", lw=0.8)
        draw(plane, color="tab:blue", lw=1.5)
        draw(skeleton, "o-", color="k", lw=2, ms=3)
        for label, p in pts.items():
            draw(p[None], "o", color="tab:red", ms=5)
            draw(np.vstack([p + cube.approach_mm, p]), "--", color="tab:orange", lw=1)
            ax.text(*[p[d] for d in dims], f" {label}", color="tab:red")
        if arm is not None and len(dims) == 2:
            t = np.linspace(0, 2 * np.pi, 200)
            c = np.asarray(arm.centre_mm)
            ax.plot(c[dims[0]] + arm.radius_mm * np.cos(t), c[dims[1]] + arm.radius_mm * np.sin(t),
                    ":", color="tab:purple", label="arm reach (section)")
            ax.legend(loc="lower right")
        names = "xyz"
        if len(dims) == 2:
            ax.set_aspect("equal")
            ax.grid(alpha=0.3)
            ax.set(xlabel=f"{names[dims[0]]} [mm]", ylabel=f"{names[dims[1]]} [mm]")
    ax3.set(xlabel="x", ylabel="y", zlabel="z", title=f"ISO 9283 cube, edge {cube.edge_mm:.0f} mm")
    views[1][0].set_title("side view (x-z): plane, P1-P5, return points, robot at P1")
    views[2][0].set_title("top view (x-y)")
    fig.tight_layout()
    return _save(fig, path)

