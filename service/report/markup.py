"""HTML pieces the report's sections share: a section, a paragraph, a table, a table with
its chart beside it, a number as a person reads it."""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from typing import Any

CSS = """
body{font-family:sans-serif;max-width:1100px;margin:1.5em auto;padding:0 1em;color:#222;
 line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #bbb;padding:3px 7px;
 text-align:right;vertical-align:top}th{background:#eee}td:first-child,th:first-child{
 text-align:left}td.text,th.text{text-align:left;max-width:32em}
caption{text-align:left;font-weight:bold;padding:.2em 0}
.warning{background:#fff3cd;border:1px solid #e0b000;padding:6px}
.verdict{font-size:1.15em;border-left:4px solid #2a7d4f;padding:4px 10px}
.pair{display:flex;flex-wrap:wrap;gap:1em 2em;align-items:flex-start;margin:.8em 0}
.pair>.table{flex:0 1 auto;min-width:16em;max-width:100%;overflow-x:auto}
.pair>.table>table{width:100%}
.pair>.chart-box{flex:1 1 540px;max-width:640px;min-width:0}
svg.chart{width:100%;height:auto;font-size:14px;font-family:sans-serif}
dl.symbols{display:grid;grid-template-columns:max-content 1fr;gap:.1em 1em}
dl.symbols dt{font-family:monospace;font-weight:bold}dl.symbols dd{margin:0}
.wide{max-width:100%;overflow-x:auto}
@media print{body{max-width:none}.pair{break-inside:avoid}}
"""


def esc(text: Any) -> str:
    return html.escape(str(text))


def sentence(text: str) -> str:
    """A paragraph: first letter capital, a full stop at the end."""
    text = text.strip()
    if not text:
        return ""
    text = text[0].upper() + text[1:]
    return f"<p>{esc(text if text.endswith(('.', ':', '?', '!')) else text + '.')}</p>"


def number(v: Any, digits: int = 3) -> str:
    """A figure with `digits` decimals, more for a small one (0.0006 and 0.000055 stay
    readable, never 5.5e-05); '-' for a missing one; other values as text."""
    if v is None:
        return "-"
    if isinstance(v, bool) or not isinstance(v, int | float):
        return esc(v)
    if isinstance(v, int):
        return str(v)
    if v != 0 and abs(v) < 10.0 ** -digits * 10:  # fixed notation: two figures shown
        return f"{v:.{max(digits + 1, 1 - math.floor(math.log10(abs(v))))}f}"
    return f"{v:.{digits}f}"


def table(header: Sequence[str], rows: Sequence[Sequence[Any]], caption: str | None = None,
          text_columns: Sequence[int] = (), digits: int = 3, cls: str = "") -> str:
    """A table; floats with `digits` decimals; `text_columns` left-aligned (prose)."""
    def cell(k: int, v: Any, tag: str = "td") -> str:
        klass = " class='text'" if k in text_columns else ""
        return f"<{tag}{klass}>{number(v, digits) if tag == 'td' else esc(v)}</{tag}>"

    head = "".join(cell(k, h, "th") for k, h in enumerate(header))
    body = "".join("<tr>" + "".join(cell(k, v) for k, v in enumerate(r)) + "</tr>"
                   for r in rows)
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    klass = f" class='{cls}'" if cls else ""
    return f"<table{klass}>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def pair(table_html: str, chart_svg: str) -> str:
    """A table and the chart of the same quantity, side by side (stacked on a narrow page)."""
    return (f"<div class='pair'><div class='table'>{table_html}</div>"
            f"<div class='chart-box'>{chart_svg}</div></div>")


def section(key: str, title: str, body: str) -> str:
    """A section of the report: `key` its id (the page's anchors), `title` its heading."""
    return f"<section id='{esc(key)}'><h2>{esc(title)}</h2>{body}</section>"
