"""Who may do what: roles as sets of grants, and the grant each route needs, declared once.

A person (or an instrument's script) signs in as a user with one role; each route of the API
declares the grant it needs in `ROUTES`, and the service refuses (403) a request whose user's
role lacks it. The roles follow OPC UA's well-known roles (Observer, Operator, Engineer,
SecurityAdmin) and the grants ABB's User Authorization System gives groups on the controller
(`UAS` names the nearest UAS grant of each), so that a plant can give the same people the same
rights on the service as on the robot:

| role | may |
|---|---|
| viewer | read robots, jobs, measurements, results, reports |
| operator | viewer's, and run performance and verify jobs, give the STEP go-ahead, abort |
| engineer | operator's, and calibration and procedure jobs, a ZERO, robot records |
| instrument | post the measurement of the pose a job waits for (and read) |
| administrator | everything, and manage users, tokens and the audit trail |
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class Role(StrEnum):
    VIEWER = "viewer"
    OPERATOR = "operator"
    ENGINEER = "engineer"
    INSTRUMENT = "instrument"
    ADMINISTRATOR = "administrator"


class Grant(StrEnum):
    READ = "read"
    RUN_TESTS = "run tests"  # performance and verify jobs
    GO_AHEAD = "go-ahead"  # the STEP mode's go-ahead for a move
    ABORT = "abort"
    CALIBRATE = "calibrate"  # calibration and procedure jobs, their corrections
    ZERO = "zero"  # confirm a ZERO: the robot's joint zeros change
    EDIT_ROBOTS = "edit robots"  # robot records and identities
    MEASURE = "measure"  # post a measurement for the pose a job waits for
    ADMINISTER = "administer"  # users, tokens, the audit trail


# The nearest grant of ABB's User Authorization System (RobotWare 6/7) to each of ours.
UAS = {
    Grant.READ: "none needed (read access)",
    Grant.RUN_TESTS: "Execute program",
    Grant.GO_AHEAD: "Execute program (and, in manual mode, the operator's consent)",
    Grant.ABORT: "Execute program",
    Grant.CALIBRATE: "Modify current value / Execute program",
    Grant.ZERO: "Calibration (fine calibration, revolution counters)",
    Grant.EDIT_ROBOTS: "Modify configuration",
    Grant.MEASURE: "none (a measuring system's account)",
    Grant.ADMINISTER: "UAS administration",
}
_OPERATOR = {Grant.READ, Grant.RUN_TESTS, Grant.GO_AHEAD, Grant.ABORT}
ROLE_GRANTS: dict[Role, frozenset[Grant]] = {
    Role.VIEWER: frozenset({Grant.READ}),
    Role.OPERATOR: frozenset(_OPERATOR),
    Role.ENGINEER: frozenset(_OPERATOR | {Grant.CALIBRATE, Grant.ZERO, Grant.EDIT_ROBOTS}),
    Role.INSTRUMENT: frozenset({Grant.READ, Grant.MEASURE}),
    Role.ADMINISTRATOR: frozenset(Grant),
}
# The job kinds an operator may start; every other kind needs CALIBRATE.
OPERATOR_JOB_KINDS = frozenset({"performance", "verify"})


@dataclass(frozen=True)
class Route:
    method: str
    path: str
    grant: Grant | None  # None: open to anyone (signing in)
    note: str = ""


# Every route of the API and the grant it needs: the one table (a test holds the app to it,
# and docs/service.md prints it).
ROUTES: tuple[Route, ...] = (
    Route("GET", "/robots", Grant.READ),
    Route("GET", "/robots/{robot_id}", Grant.READ),
    Route("POST", "/robots", Grant.EDIT_ROBOTS),
    Route("GET", "/robots/{robot_id}/history", Grant.READ),
    Route("PUT", "/robots/{robot_id}/identity", Grant.EDIT_ROBOTS),
    Route("GET", "/jobs", Grant.READ),
    Route("POST", "/jobs", Grant.RUN_TESTS, "calibration and procedure jobs: calibrate"),
    Route("GET", "/jobs/{job_id}", Grant.READ),
    Route("POST", "/jobs/{job_id}/go", Grant.GO_AHEAD, "the go-ahead of a ZERO: zero"),
    Route("POST", "/jobs/{job_id}/abort", Grant.ABORT),
    Route("GET", "/jobs/{job_id}/measurements", Grant.READ),
    Route("POST", "/jobs/{job_id}/measurement", Grant.MEASURE),
    Route("GET", "/jobs/{job_id}/result", Grant.READ),
    Route("GET", "/jobs/{job_id}/model", Grant.READ),
    Route("GET", "/jobs/{job_id}/report", Grant.READ),
    Route("GET", "/jobs/{job_id}/events", Grant.READ),
    Route("POST", "/session", None, "signing in: a name and a password"),
    Route("GET", "/users", Grant.ADMINISTER),
    Route("POST", "/users", Grant.ADMINISTER),
    Route("PUT", "/users/{name}/role", Grant.ADMINISTER),
    Route("POST", "/users/{name}/tokens", Grant.READ, "a user's own; anyone's: administer"),
    Route("DELETE", "/tokens/{token_id}", Grant.READ, "a user's own; anyone's: administer"),
    Route("GET", "/audit", Grant.ADMINISTER),
    Route("GET", "/audit/check", Grant.ADMINISTER),
)
GRANT_OF = {(r.method, r.path): r.grant for r in ROUTES}


def may(role: Role, grant: Grant | None) -> bool:
    return grant is None or grant in ROLE_GRANTS[role]


def routes_table() -> str:
    """The table for docs/service.md: route, grant, roles that have it, ABB UAS grant."""
    lines = ["| route | grant | roles | ABB UAS grant |", "|---|---|---|---|"]
    for r in ROUTES:
        roles = ", ".join(role.value for role in Role if may(role, r.grant))
        note = f" ({r.note})" if r.note else ""
        grant = r.grant.value if r.grant is not None else "none"
        uas = UAS[r.grant] if r.grant is not None else "none"
        lines.append(f"| `{r.method} {r.path}` | {grant}{note} | {roles} | {uas} |")
    return "\n".join(lines)
