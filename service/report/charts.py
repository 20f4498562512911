"""The report's charts as inline SVG: bars per category, or lines over x, drawn from figures of
the result document given by the caller (never recomputed here).

Each chart is an `<svg class="chart">` whose y-axis label (`text.axis-label.y`, written
across above the axis so that a long quantity stays readable) names its quantity, the same words
as the caption of the table beside it; its legend (`g.legend`) sits in a band of its own above
the plot, so it covers no bar (`rect.bar`) and no point (`circle.point`); the browser test
measures all of them, and reads each mark's series and value (`data-series`, `data-value`) to
compare it with the table. A log scale is used when the largest
value is more than `LOG_RATIO` times the smallest, and the axis label says so.
"""

from __future__ import annotations

import html
import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

LOG_RATIO = 20.0
# The drawing in user units (the SVG scales to the page's width, keeping its proportions).
WIDTH, HEIGHT = 640, 330
LEFT, RIGHT, BOTTOM = 70, 16, 48
LEGEND_ROW = 20  # the legend's band: one row per `LEGEND_PER_ROW` series, above the plot
LEGEND_PER_ROW = 3
COLOURS = {"before": "#d95f02", "after": "#1b9e77", "round 2": "#7570b3",
           "verification": "#e7298a", "rejected": "#c00000"}
OTHER_COLOURS = ("#66a61e", "#e6ab02", "#a6761d", "#666666")


@dataclass(frozen=True)
class Axis:
    """The value axis: its range, ticks and whether it is logarithmic."""

    low: float
    high: float
    log: bool
    ticks: tuple[float, ...]

    def fraction(self, v: float) -> float:
        """0 at the bottom of the plot, 1 at the top."""
        if self.log:
            v = max(v, self.low)
            return (math.log10(v) - math.log10(self.low)) / (
                math.log10(self.high) - math.log10(self.low))
        return (v - self.low) / (self.high - self.low)


def _nice_step(span: float, count: int = 5) -> float:
    raw = span / count
    power = 10.0 ** math.floor(math.log10(raw))
    return next(m * power for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * power >= raw)


def value_axis(values: Sequence[float], zero: bool = True, log: bool = True) -> Axis:
    """A linear axis (from 0 when `zero` and no value is negative) or, when `log` allows and
    the values span more than LOG_RATIO and are all positive, a logarithmic one with a tick per
    decade."""
    finite = [v for v in values if v is not None and math.isfinite(v)]
    if not finite:
        return Axis(0.0, 1.0, False, (0.0, 0.5, 1.0))
    positive = [v for v in finite if v > 0]
    if log and len(positive) == len(finite) and max(finite) > LOG_RATIO * min(finite):
        low = 10.0 ** math.floor(math.log10(min(finite)))
        high = 10.0 ** math.ceil(math.log10(max(finite)))
        ticks = tuple(10.0 ** k for k in range(round(math.log10(low)),
                                               round(math.log10(high)) + 1))
        return Axis(low, high, True, ticks)
    low, high = min(finite), max(finite)
    if zero:
        low, high = min(low, 0.0), max(high, 0.0)
    if high == low:
        high = low + (abs(low) or 1.0)
    step = _nice_step(high - low)
    low, high = step * math.floor(low / step), step * math.ceil(high / step)
    ticks = tuple(low + k * step for k in range(round((high - low) / step) + 1))
    return Axis(low, high, False, ticks)


def _tick_text(v: float) -> str:
    return f"{v:g}" if abs(v) >= 1e-3 or v == 0 else f"{v:.0e}"


def _colour(name: str, k: int) -> str:
    """A phase's colour ("before (nominal model)" is a "before"), else one of the others."""
    key = name.split(" (")[0]
    return COLOURS.get(key, OTHER_COLOURS[k % len(OTHER_COLOURS)])


class _Frame:
    """The plot area of one chart: legend band on top, axes, ticks and labels."""

    def __init__(self, series: Sequence[str], axis: Axis, y_label: str, x_label: str):
        self.axis = axis
        rows = max(1, math.ceil(len(series) / LEGEND_PER_ROW))
        self.label_y = 10 + rows * LEGEND_ROW + 10  # the y label's baseline, under the legend
        self.top = self.label_y + 14
        self.bottom = HEIGHT - BOTTOM
        self.left, self.right = LEFT, WIDTH - RIGHT
        self.parts: list[str] = []
        self.series = list(series)
        self.y_label = y_label + (" (log scale)" if axis.log else "")
        self.x_label = x_label

    def y(self, v: float) -> float:
        return self.bottom - self.axis.fraction(v) * (self.bottom - self.top)

    def legend(self) -> str:
        items = []
        for k, name in enumerate(self.series):
            row, col = divmod(k, LEGEND_PER_ROW)
            x = self.left + col * (self.right - self.left) / LEGEND_PER_ROW
            y = 10 + row * LEGEND_ROW
            items.append(f"<rect class='swatch' x='{x:.1f}' y='{y + 2}' width='14' height='12' "
                         f"fill='{_colour(name, k)}'/><text x='{x + 20:.1f}' y='{y + 12}'>"
                         f"{html.escape(name)}</text>")
        return f"<g class='legend'>{''.join(items)}</g>"

    def axes(self) -> str:
        out = []
        for t in self.axis.ticks:
            y = self.y(t)
            out.append(f"<line class='grid' x1='{self.left}' x2='{self.right}' y1='{y:.1f}' "
                       f"y2='{y:.1f}' stroke='#ddd'/><text class='tick' x='{self.left - 6}' "
                       f"y='{y + 4:.1f}' text-anchor='end'>{_tick_text(t)}</text>")
        out.append(f"<line x1='{self.left}' x2='{self.left}' y1='{self.top}' y2='{self.bottom}' "
                   f"stroke='#444'/><line x1='{self.left}' x2='{self.right}' y1='{self.bottom}' "
                   f"y2='{self.bottom}' stroke='#444'/>")
        out.append(f"<text class='axis-label y' x='{self.left - 40}' y='{self.label_y}'>"
                   f"{html.escape(self.y_label)}</text>")
        out.append(f"<text class='axis-label x' x='{(self.left + self.right) / 2:.1f}' "
                   f"y='{HEIGHT - 8}' text-anchor='middle'>{html.escape(self.x_label)}</text>")
        return "".join(out)

    def svg(self, title: str, body: str) -> str:
        return (f"<svg class='chart' viewBox='0 0 {WIDTH} {HEIGHT}' role='img' "
                f"aria-label='{html.escape(title)}' xmlns='http://www.w3.org/2000/svg'>"
                f"<title>{html.escape(title)}</title>{self.axes()}{body}{self.legend()}</svg>")


def bar_chart(title: str, categories: Sequence[str],
              series: Mapping[str, Sequence[float | None]], y_label: str, x_label: str) -> str:
    """Grouped bars: per category one bar per series (None: no bar)."""
    axis = value_axis([v for vs in series.values() for v in vs if v is not None])
    frame = _Frame(list(series), axis, y_label, x_label)
    group = (frame.right - frame.left) / max(1, len(categories))
    width = 0.8 * group / max(1, len(series))
    parts = []
    base = frame.y(axis.low if axis.log else max(axis.low, 0.0))
    for i, category in enumerate(categories):
        x0 = frame.left + i * group + 0.1 * group
        parts.append(f"<text class='tick' x='{x0 + 0.4 * group:.1f}' y='{frame.bottom + 16}' "
                     f"text-anchor='middle'>{html.escape(category)}</text>")
        for k, (name, values) in enumerate(series.items()):
            v = values[i]
            if v is None:
                continue
            top = frame.y(v)
            y, h = min(top, base), abs(base - top)
            parts.append(f"<rect class='bar' data-series='{html.escape(name)}' "
                         f"data-category='{html.escape(category)}' data-value='{v!r}' "
                         f"x='{x0 + k * width:.1f}' y='{y:.1f}' "
                         f"width='{width:.1f}' height='{max(h, 0.5):.1f}' "
                         f"fill='{_colour(name, k)}'><title>{html.escape(name)} "
                         f"{html.escape(category)}: {v:.4g}</title></rect>")
    return frame.svg(title, "".join(parts))


def line_chart(title: str, x: Mapping[str, Sequence[float]],
               series: Mapping[str, Sequence[float]], y_label: str, x_label: str,
               zero_line: bool = False, marked: Collection[str] = ()) -> str:
    """Lines through points, one per series, against their own x (`x[name]`); the series
    named in `marked` are points set apart (larger, ringed, no line): e.g. the poses a fit
    left out."""
    axis = value_axis([v for vs in series.values() for v in vs], zero=False)
    xs = [v for vs in x.values() for v in vs]
    x_axis = value_axis(xs, zero=False, log=False) if xs else Axis(0.0, 1.0, False, (0.0, 1.0))
    frame = _Frame(list(series), axis, y_label, x_label)

    def px(v: float) -> float:
        return frame.left + x_axis.fraction(v) * (frame.right - frame.left)

    parts = [f"<text class='tick' x='{px(t):.1f}' y='{frame.bottom + 16}' "
             f"text-anchor='middle'>{_tick_text(t)}</text>" for t in x_axis.ticks]
    if zero_line and not axis.log and axis.low < 0 < axis.high:
        parts.append(f"<line x1='{frame.left}' x2='{frame.right}' y1='{frame.y(0):.1f}' "
                     f"y2='{frame.y(0):.1f}' stroke='#000'/>")
    for k, (name, values) in enumerate(series.items()):
        colour = _colour(name, k)
        pts = sorted(zip(x[name], values, strict=True))
        ring = name in marked
        if not ring:
            path = " ".join(f"{px(a):.1f},{frame.y(b):.1f}" for a, b in pts)
            parts.append(f"<polyline class='line' points='{path}' fill='none' "
                         f"stroke='{colour}' stroke-width='1.5'/>")
        look = (f"r='5' fill='{colour}' fill-opacity='0.35' stroke='{colour}' "
                "stroke-width='2'") if ring else f"r='2.5' fill='{colour}'"
        parts += [f"<circle class='point{' marked' if ring else ''}' "
                  f"data-series='{html.escape(name)}' data-value='{b!r}' "
                  f"cx='{px(a):.1f}' cy='{frame.y(b):.1f}' {look}>"
                  f"<title>{html.escape(name)}: {b:.4g}</title></circle>" for a, b in pts]
    return frame.svg(title, "".join(parts))
