"""The home check (thesis Table 14): the flange at home, nominal, measured before and after."""

from __future__ import annotations

from typing import Any

from service.report.context import ReportContext
from service.report.markup import section, sentence, table
from service.result_text import home_moved


def home_section(ctx: ReportContext) -> str | None:
    """Table 14: the flange with every joint at 0, nominal, measured and the errors."""
    home = ctx.result.home_check
    if home is None:
        return None
    rows: list[list[Any]] = [["nominal", *home.nominal_mm, None]]
    for when, measured in (("before", home.before), ("after", home.after)):
        if measured is not None:
            rows.append([f"measured {when}", *measured.measured_mm, None])
            rows.append([f"error {when}", *measured.error_mm, measured.distance_mm])
    body = [table(["", "x mm", "y mm", "z mm", "|error| mm"], rows), sentence(home.note)]
    moved = home_moved(ctx.result)
    if moved:
        body.append(sentence(moved))
    return section("home", "Home position check (thesis Table 14)", "".join(body))
