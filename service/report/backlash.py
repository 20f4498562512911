"""Lost motion (backlash) per joint (screwcal.calibration.backlash), its standard error, and
what the compensation can and cannot do about it."""

from __future__ import annotations

from service.report.context import ReportContext
from service.report.markup import section, sentence, table


def backlash_section(ctx: ReportContext) -> str | None:
    """The identified lost motion per joint, in a table, then what compensation cannot do."""
    backlash = ctx.result.backlash
    if not backlash:
        return None
    rows = [[j["joint"], j["backlash_deg"], j["std_deg"],
             "yes" if j["identified"] else "no (no pair flipped it)"]
            for j in backlash["joints"]]
    return section("backlash", "Lost motion (backlash) per joint", "".join([
        sentence(f"{backlash['meaning']}; {backlash['pairs']} pairs"),
        table(["joint", "backlash deg", "std error deg", "identified"], rows, digits=4,
              text_columns=(3,)),
        sentence(backlash["compensation"])]))
