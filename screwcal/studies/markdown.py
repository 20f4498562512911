"""The studies' Markdown tables: a header, its separator, a row per line."""

from __future__ import annotations

from collections.abc import Iterable, Sequence


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    """The table's lines: the header, as many `---` as it has columns, then the rows (cells
    already formatted; each row as many as the header)."""
    lines = [_row(header), "|" + "---|" * len(header)]
    for cells in rows:
        if len(cells) != len(header):
            raise ValueError(f"a row of {len(cells)} cells under {len(header)} columns: {cells}")
        lines.append(_row(cells))
    return lines


def _row(cells: Sequence[str]) -> str:
    """One line; a `|` inside a cell (|error|) is escaped, or it would split the cell."""
    return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"
