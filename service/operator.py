"""The operator's client of the job service: a thin httpx client of the REST API (a transport
can be passed, so that tests drive the app in-process), and the job's events followed to its end,
asking before every move in STEP mode."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from service.errors import ServiceError
from service.job_state import state_said

if TYPE_CHECKING:  # imported where used: `screwcal --help` pays for neither
    import httpx

    from service.schemas import JobResult


class Operator:
    """A thin httpx client of the REST API (a transport can be passed for tests)."""

    def __init__(self, base_url: str, token: str, transport: httpx.BaseTransport | None = None):
        import httpx

        self.http = httpx.Client(base_url=base_url, transport=transport, timeout=30.0,
                                 headers={"Authorization": f"Bearer {token}"})

    def close(self) -> None:
        self.http.close()

    def __enter__(self) -> Operator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _check(self, r: httpx.Response) -> Any:
        if r.status_code >= 400:
            try:
                detail = r.json().get("detail")
            except ValueError:
                detail = r.text
            if isinstance(detail, list):  # a validation error: the field, the value, the rule
                detail = "; ".join(_invalid(e) for e in detail if isinstance(e, dict))
            raise ServiceError(f"{r.request.method} {r.request.url.path}: {r.status_code} "
                               f"{detail}")
        return r.json() if r.content else None

    def add_robot(self, **body: Any) -> dict:
        return self._check(self.http.post("/robots", json=body))

    def start(self, **body: Any) -> dict:
        return self._check(self.http.post("/jobs", json=body))

    def robots(self) -> list[dict]:
        return self._check(self.http.get("/robots"))

    def jobs(self) -> list[dict]:
        return self._check(self.http.get("/jobs"))

    def robot_id(self, name_or_id: str) -> int:
        """A robot named by its id or its (unique) name."""
        robots = self.robots()
        for r in robots:
            if r["name"] == name_or_id:
                return int(r["id"])
        if name_or_id.isdigit() and any(r["id"] == int(name_or_id) for r in robots):
            return int(name_or_id)
        known = ", ".join(f"{r['id']} ({r['name']})" for r in robots) or "none yet"
        raise ServiceError(f"no robot {name_or_id!r} on the service; robots: {known} "
                           "(screwcal job robot-add)")

    def job(self, job_id: int) -> dict:
        return self._check(self.http.get(f"/jobs/{job_id}"))

    def history(self, robot_id: int) -> dict:
        return self._check(self.http.get(f"/robots/{robot_id}/history"))

    def go(self, job_id: int, index: int) -> None:
        self._check(self.http.post(f"/jobs/{job_id}/go",
                                   json={"index": index, "operator": _who()}))

    def measure(self, job_id: int, body: dict[str, Any]) -> dict:
        """Post another instrument's measurement of a pose the job waits for."""
        return self._check(self.http.post(f"/jobs/{job_id}/measurement", json=body))

    def abort(self, job_id: int) -> None:
        self._check(self.http.post(f"/jobs/{job_id}/abort"))

    def result(self, job_id: int) -> JobResult:
        from service.schemas import JobResult

        return JobResult.model_validate(self._check(self.http.get(f"/jobs/{job_id}/result")))

    def measurements(self, job_id: int, phase: str | None = None) -> list[dict]:
        """The job's committed poses (of one phase: cal, perf_before, ...), in order."""
        params = {} if phase is None else {"phase": phase}
        return self._check(self.http.get(f"/jobs/{job_id}/measurements", params=params))

    def model(self, job_id: int, round_: int = 1) -> dict:
        return self._check(self.http.get(f"/jobs/{job_id}/model", params={"round": round_}))

    def report(self, job_id: int) -> str:
        r = self.http.get(f"/jobs/{job_id}/report")
        if r.status_code >= 400:
            self._check(r)
        return r.text

    def watch(self, job_id: int, ask: Callable[[str], str] = input,
              out: Callable[[str], None] = print) -> str:
        """Follow the job's events to its end; in STEP mode ask before every move. Returns the
        final state (or 'waiting' when the operator declined a move: the job waits)."""
        asked: set[tuple[str, int]] = set()

        def ask_for(waiting: dict, joints: list | None, note: str = "") -> bool:
            """Prompt for the pose the job waits for now; False when the operator declines."""
            key = (waiting["phase"], waiting["index"])
            if key in asked:
                return True
            asked.add(key)
            try:
                answer = ask(step_prompt(key[0], key[1], joints, note))
            except EOFError:  # no one to answer: the robot does not move
                return False
            except KeyboardInterrupt:
                out("")
                try:
                    stop = ask(f"abort job {job_id}? [y/N] ")
                except (EOFError, KeyboardInterrupt):
                    stop = "n"
                if stop.strip().lower() == "y":
                    self.abort(job_id)
                    out(f"job {job_id}: abort requested")
                return False
            if answer.strip().lower() != "y":
                return False
            self.go(job_id, key[1])
            return True

        with self.http.stream("GET", f"/jobs/{job_id}/events", timeout=None) as r:
            for line in r.iter_lines():
                if not line.startswith("data: "):
                    continue
                event = json.loads(line[len("data: "):])
                kind = event["kind"]
                if kind == "state":  # where the job stands when we attach
                    out(f"job {job_id}: {state_said(event['state'], event.get('reason'))}")
                    waiting = event.get("waiting_for")
                    if waiting and not ask_for(waiting, None):
                        out(f"not moving; job {job_id} waits (screwcal job abort {job_id})")
                        return "waiting"
                elif kind in ("measured", "moved"):  # moved: a warm-up pose
                    bar = "#" * int(30 * event["done"] / event["total"])
                    out(f"{event['phase']:<12} [{bar:<30}] pose {event['done']} of "
                        f"{event['total']}")
                elif kind == "waiting":
                    waiting = {"phase": event["phase"], "index": event["index"]}
                    if self.job(job_id)["waiting_for"] != waiting:
                        continue  # history: the job has gone past this pose
                    if not ask_for(waiting, event["joints_deg"], event.get("note", "")):
                        out(f"not moving; job {job_id} waits (screwcal job abort {job_id})")
                        return "waiting"
                elif kind in ("phase", "paused", "resumed", "corrected", "failed", "warning",
                              "discarded", "stale"):
                    out(event_text(event))
                elif kind == "end":
                    return event["state"]
        return self.job(job_id)["state"]


def step_prompt(phase: str, index: int, joints_deg: list | None, note: str = "") -> str:
    """The question STEP asks before a move: the list in words, the joints to 3 decimals, no
    -0 (it showed 15-digit joints and -0.0)."""
    where = "" if joints_deg is None else " (joints " + ", ".join(
        f"{round(float(v), 3) + 0.0:g}" for v in joints_deg) + " deg)"
    return (f"{note + '. ' if note else ''}robot will move to pose {index} of "
            f"{_phase(phase)}{where}: go? [y/N] ")


def event_text(event: dict) -> str:
    """A job's event as `job watch` prints it: 'done: calibration poses in 1.35 s', not
    'phase: phase=cal, seconds=1.3487892850002936'."""
    kind = event["kind"]
    if kind == "phase":  # a phase ended
        return f"done: {_phase(event['phase'])} in {_shown(event['seconds'])} s"
    return f"{kind}: " + ", ".join(
        _phase(v) if k == "phase" else str(v) if k in ("message", "reason", "note") else
        f"{k} {_shown(v)}" for k, v in event.items() if k not in ("kind", "seq", "time"))


def _phase(key: object) -> str:
    """A phase as the report names it: 'calibration poses', not 'cal'."""
    from service.phases import PHASE_WORDS

    return PHASE_WORDS.get(str(key), str(key))


def _shown(value: object) -> str:
    """An event's value as a person reads it: 1.35, not 1.3487892850002936."""
    if isinstance(value, float):
        return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    if isinstance(value, list):
        return "[" + ", ".join(_shown(v) for v in value) + "]"
    return str(value)


def _invalid(error: dict) -> str:
    """One pydantic error as a person reads it: `options.cycles = 1: must be >= 2`."""
    loc = ".".join(str(p) for p in error.get("loc", ()) if p != "body")
    value = f" = {error['input']!r}" if "input" in error and not isinstance(
        error["input"], dict) else ""
    rule = str(error.get("msg", "invalid")).removeprefix("Value error, ")
    return f"{loc}{value}: {rule}"


def _who() -> str:
    """The person at this terminal, as the go-aheads' provenance names them."""
    import getpass

    try:
        return getpass.getuser()
    except (KeyError, OSError):
        return "unknown"
