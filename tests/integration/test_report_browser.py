"""The report page, rendered by a real browser (Debian's headless Chromium) and checked as a
picture: the report of a real job on the emulated robot of `typical` realism, laid out by
Chromium, measured in its DOM (a script added to a copy of the page writes what it measured into
the page, which `--dump-dom` prints), and screenshotted."""

import json
import re
import shutil
import subprocess
from dataclasses import replace
from html import escape
from pathlib import Path

import pytest

from simulators.realism import TYPICAL
from tests.integration.conftest import AUTH, add_robot, start_rig, stop_rig
from tests.integration.test_jobs import wait_state

# the typical robot carrying the 5 kg the job says it carries
CARRYING = replace(TYPICAL, payload_kg=5.0, payload_cog_mm=(0.0, 0.0, 80.0))
EMULATION = ["geometric errors drawn from seed 1; realism typical", *CARRYING.describe()]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars"]
NEEDS_CHROMIUM = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed (`apt-get "
                                    "install chromium`; .ci/run installs it)")
# What the script measures in the laid-out page (CSS pixels), written into <pre id='measured'>.
MEASURE = """<script>
const box = e => e.getBoundingClientRect();
const meets = (a, b) => a.left < b.right && b.left < a.right && a.top < b.bottom &&
  b.top < a.bottom;
const width = document.documentElement.clientWidth;
const out = {width, scroll_width: document.documentElement.scrollWidth, overflowing: [],
  sections: [...document.querySelectorAll('body > section')].map(s => s.id),
  first_after_header: document.querySelector('header').nextElementSibling.id, charts: []};
for (const e of document.body.querySelectorAll('*')) {
  const r = box(e);
  if (r.width > 0 && r.right > width + 0.5)
    out.overflowing.push(e.tagName + '.' + e.getAttribute('class') + ' ' + r.right);
  if (e.scrollWidth > e.clientWidth + 1 && getComputedStyle(e).overflowX !== 'visible')
    out.overflowing.push('clipped ' + e.tagName + '.' + e.getAttribute('class'));
}
for (const svg of document.querySelectorAll('svg.chart')) {
  const legend = box(svg.querySelector('g.legend'));
  const marks = [...svg.querySelectorAll('rect.bar, circle.point')];
  const frame = box(svg);
  const pair = svg.closest('.pair');
  out.charts.push({
    title: svg.querySelector('title').textContent,
    axis_label: svg.querySelector('text.axis-label.y').textContent,
    caption: pair ? pair.querySelector('table caption').textContent : null,
    table: pair ? [...pair.querySelectorAll('table tr')].map(
      tr => [...tr.children].map(c => c.textContent)) : [],
    values: marks.map(m => [m.dataset.series, m.dataset.category || null,
                            Number(m.dataset.value)]),
    marks: marks.length,
    covered: marks.filter(m => meets(box(m), legend)).length,
    text_outside: [...svg.querySelectorAll('text')].filter(t => {
      const r = box(t);
      return r.left < frame.left - 0.5 || r.right > frame.right + 0.5; }).map(
      t => t.textContent)});
}
const pre = document.createElement('pre');
pre.id = 'measured';
pre.textContent = JSON.stringify(out);
document.body.appendChild(pre);
</script>"""


def chromium(profile: Path, *args: str) -> subprocess.CompletedProcess:
    run = subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", *args],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    return run


def measured(page: Path, profile: Path, width: int) -> dict:
    """The page laid out in a window `width` pixels wide, as the script measured it."""
    probe = page.with_name(f"probe-{width}.html")
    probe.write_text(page.read_text().replace("</body>", MEASURE + "</body>"))
    dom = chromium(profile, f"--window-size={width},1600", "--dump-dom", probe.as_uri()).stdout
    found = re.search(r"<pre id=\"measured\">(.*?)</pre>", dom, re.S)
    assert found, dom[-2000:]
    return json.loads(found.group(1).replace("&amp;", "&").replace("&lt;", "<")
                      .replace("&gt;", ">"))


def agrees_with_its_table(chart: dict) -> None:
    """A bar is the table's cell of its series (column) and category (row); a line whose series
    is a column of the table has that column's values; a line whose series is a row of the table
    has its largest point in the row's max (peak) and its lowest in the valley (the table shows
    4 decimals, or 2 significant digits below 0.01)."""
    header, *rows = chart["table"]

    def same(cell: str, value: float) -> None:
        assert float(cell) == pytest.approx(value, rel=0.01, abs=5e-5), (chart["title"], cell,
                                                                         value)

    checked = 0
    for series, category, value in chart["values"]:
        if category is not None:
            row = next(r for r in rows if r[0] == category)
            same(row[header.index(series)], value)
            checked += 1
    for series in {s for s, c, _ in chart["values"] if c is None}:
        values = [v for s, _, v in chart["values"] if s == series]
        if series in header:
            column = sorted(float(r[header.index(series)]) for r in rows)
            assert column == pytest.approx(sorted(values), rel=0.01, abs=5e-5), chart["title"]
            checked += 1
            continue
        row = next(r for r in rows if r[0] == series)
        for k, name in enumerate(header):
            if name.startswith(("max", "peak =")):
                same(row[k], max(values))
                checked += 1
            elif name.startswith("valley"):
                same(row[k], -min(values))
                checked += 1
    assert checked, chart


async def typical_job_report(service, tmp_path: Path) -> Path:
    """A procedure on the `typical` robot (it bends, lags, backlashes, drifts), carrying 5 kg
    with ISO 9283's warm-up, two drift reference poses re-measured every 20 poses and 5
    calibration poses approached from both sides (backlash), and its report as a file."""
    rig = await start_rig(realism=CARRYING, seed=1)
    try:
        robot = await add_robot(service, rig, emulation=EMULATION)
        r = await service.post("/jobs", headers=AUTH, json={
            "robot_id": robot, "kind": "procedure", "options": {
                "calibration_poses": 40, "cycles": 3, "warmup_cycles": 2,
                "arm_position_mm": [500.0, 0.0, 600.0], "payload_kg": 5.0,
                "payload_cog_mm": [0.0, 0.0, 80.0], "drift_poses": 2,
                "drift_period_poses": 20, "backlash_poses": 5}})
        job = await wait_state(service, r.json()["id"], timeout_s=240)
    finally:
        await stop_rig(rig)
    assert job["state"] == "done", job["reason"]
    page = tmp_path / "report.html"
    page.write_text((await service.get(f"/jobs/{job['id']}/report")).text)
    return page


@pytest.mark.slow
@NEEDS_CHROMIUM
async def test_report_of_a_typical_job_reads_right_in_chromium(tmp_path, service):
    page = await typical_job_report(service, tmp_path)
    profile = tmp_path / "profile"
    html = page.read_text()
    assert "ISO 9283" in html and "<b id='state'>done</b>" in html
    # what the emulated robot carries, the payload of each list, the ISO 9283 conditions
    for said in (*(escape(line, quote=False) for line in EMULATION),
                 "payload (calibration list)</td><td class='text'>5 kg at (0, 0, 80)",
                 "payload (performance lists)</td><td class='text'>5 kg at (0, 0, 80)",
                 "2 test cycles run unmeasured before the test", "cycles</td><td class='text'>3",
                 "These figures come from an emulated robot (geometric errors drawn from seed 1; "
                 "realism typical)",
                 "speed</td>", "compliance J2c</td>"):
        assert said in html, said
    for width in (1200, 800):  # a desktop window, and a narrow one (A4 paper is ~790 px)
        m = measured(page, profile, width)
        assert m["first_after_header"] == "summary" and m["sections"][0] == "summary", m
        assert m["scroll_width"] <= m["width"] and not m["overflowing"], m["overflowing"]
        # AP, RP, orientation, residual, straightness, drift
        assert len(m["charts"]) >= 6, m["charts"]
        assert {"summary", "robot", "accuracy", "calibration", "drift", "backlash"} <= set(
            m["sections"]), m["sections"]
        for chart in m["charts"]:
            # the axis names the quantity of the table beside the chart, in the same words
            assert chart["caption"] and chart["axis_label"].startswith(chart["caption"]), chart
            assert chart["marks"] >= 2 and chart["covered"] == 0, chart  # the legend covers none
            assert not chart["text_outside"], chart
            agrees_with_its_table(chart)
    shot = tmp_path / "report.png"
    chromium(profile, f"--screenshot={shot}", "--window-size=1200,1600", page.as_uri())
    assert shot.stat().st_size > 30_000


@NEEDS_CHROMIUM
def test_docs_render_without_internet(tmp_path):
    """/docs loads Swagger UI from the package, not a CDN (Chromium here has no network but
    loopback): the operations are drawn, and "Authorize" knows the bearer scheme."""
    import httpx

    from service.demo import service
    from service.settings import ServiceSettings

    settings = ServiceSettings(db_path=tmp_path / "jobs.db", token="t", port=0)
    with service(settings) as url:
        spec = httpx.get(f"{url}/openapi.json").json()
        assert spec["components"]["securitySchemes"]["HTTPBearer"]["scheme"] == "bearer"
        page = httpx.get(f"{url}/docs").text
        assert "cdn" not in page.lower() and "/static/swagger/swagger-ui-bundle.js" in page
        dom = subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={tmp_path / 'p'}",
                              "--virtual-time-budget=15000", "--dump-dom", f"{url}/docs"],
                             capture_output=True, text=True, timeout=120)
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert "opblock" in dom.stdout and "/jobs/{job_id}/model" in dom.stdout
    assert "authorize" in dom.stdout.lower()


@NEEDS_CHROMIUM
def test_a_rejected_pose_is_ringed_on_the_residual_chart_at_both_widths(tmp_path):
    """The residual chart of a calibration whose pose 12 the fit rejected (moved 3 mm): ringed
    at its place and residual, the legend covering no mark, the chart equal to its table, at
    1280 and 800 px (tests/service/test_report.py checks the figures themselves)."""
    import numpy as np

    from screwcal.calibration.posesets import random_configurations
    from screwcal.commands.main import main
    from screwcal.kinematics.robots import irb1600
    from screwcal.studies.simulated_measurements import simulate_measurements
    from service.document import EstimationSummary
    from service.report.calibration import REJECTED, residual_pair
    from service.report.markup import CSS, section
    from tests.screwcal.calibration.test_identify import BASE, TOOL
    from tests.screwcal.commands.test_calibrate_cli import _write_measurements

    rng = np.random.default_rng(12)
    data = simulate_measurements(irb1600().with_frames(BASE, TOOL),
                                 random_configurations(30, rng), rng, full_pose=False)
    data.positions_mm[11] += [3.0, 0.0, 0.0]
    path = _write_measurements(tmp_path / "m.csv", data, full_pose=False)
    out = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(path), "--out", str(out)]) == 0
    est = EstimationSummary(parameters=[], rank=1, condition_number=1.0, chi2_reduced=1.0,
                            converged=True, residual_before_mm=1.0, residual_after_mm=0.1)
    page = tmp_path / "page.html"
    page.write_text(
        "<!doctype html><html lang='en'><head><meta charset='utf-8'><meta name='viewport' "
        f"content='width=device-width, initial-scale=1'><style>{CSS}</style></head><body>"
        "<header><h1>residual</h1></header>" + section(
            "calibration", "What the calibration identified",
            residual_pair(json.loads(out.read_text()), est)) + "</body></html>")
    for width in (1280, 800):
        m = measured(page, tmp_path / "profile", width)
        assert m["scroll_width"] <= m["width"] and not m["overflowing"], m["overflowing"]
        (chart,) = m["charts"]
        assert chart["caption"] and chart["axis_label"].startswith(chart["caption"]), chart
        assert chart["covered"] == 0 and not chart["text_outside"], chart
        assert [v for s, _, v in chart["values"] if s == REJECTED] and \
            [r for r in chart["table"] if r[0] == REJECTED], chart
        agrees_with_its_table(chart)
