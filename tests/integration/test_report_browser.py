"""The report page, rendered by a real browser (Debian's headless Chromium)."""

import shutil
import subprocess

import pytest

from tests.integration.conftest import AUTH, FAST, add_robot
from tests.integration.test_jobs import wait_state

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars"]


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed (`apt-get install "
                    "chromium`; .ci/run installs it)")
async def test_report_renders_in_headless_chromium(tmp_path, service, rig):
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", headers=AUTH, json={"robot_id": robot, "kind": "procedure",
                                                       "options": FAST})
    job = await wait_state(service, r.json()["id"])
    assert job["state"] == "done"
    page = tmp_path / "report.html"
    page.write_text((await service.get(f"/jobs/{job['id']}/report")).text)
    profile = tmp_path / "profile"
    common = [CHROMIUM, *FLAGS, f"--user-data-dir={profile}"]
    dom = subprocess.run([*common, "--dump-dom", page.as_uri()], capture_output=True,
                         text=True, timeout=120)
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert '<b id="state">done</b>' in dom.stdout
    assert dom.stdout.count("<img") >= 2 and "ISO 9283" in dom.stdout
    shot = tmp_path / "report.png"
    run = subprocess.run([*common, f"--screenshot={shot}", "--window-size=1200,1600",
                          page.as_uri()], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and shot.stat().st_size > 30_000, run.stderr[-2000:]


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed (`apt-get install "
                    "chromium`; .ci/run installs it)")
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
