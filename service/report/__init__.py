"""The report page of a job: one self-contained HTML page (charts as inline SVG) that an engineer
reads in any browser and forwards without the service.

The page (`page.report_html`) is a title and then sections in the order of `page.SECTIONS`,
the summary first. A section is a function `(ReportContext) -> str | None` in a module of its
own, one concept each:

    summary        the figures that belong together, what each measures, the warnings
    conditions     the robot (and what an emulated one carries), payloads, compliance and lag
                   identified, the ISO 9283 test conditions
    accuracy       ISO 9283 AP, RP and orientation accuracy per point: tables and their charts
    home           the home check (thesis Table 14)
    calibration    what the data could not separate in plain words, the fit, the residual
                   table and chart, the symbols, the parameter table
    residual       the residual model over joint space: kept or declined, the physical and the
                   residual model's out-of-fold figures side by side, its uncertainty
    backlash       lost motion per joint, its std error, what compensation cannot do
    correction     what the route did, left in the robot, and what nothing corrects
    straightness   ISO 12780-1 along the line: table and chart
    drift          the reference poses' drift against time: table and chart, the verdict
    timing         seconds per phase

Shared pieces: `markup` (section, table, a table with its chart beside it, numbers), `charts`
(bar and line charts as SVG whose axis label names the quantity of the table beside them and
whose legend sits above the plot), `symbols` (parameter names in words). Every figure shown is
one of the result document's (service/document.py); a section never recomputes one.

To add a section: write `def my_section(ctx: ReportContext) -> str | None` returning
`markup.section("my-id", "Title", body)` (a table and its chart: `markup.pair(table(...),
charts.bar_chart(...))`, the chart's y label the table's caption), and add it to
`page.SECTIONS`.
"""

from service.report.page import SECTIONS, report_html

__all__ = ["SECTIONS", "report_html"]
