"""Shared fixtures: seeded generators, random serial models for property tests, and where the
real laser-tracker data set is (it is not part of the repository)."""

from __future__ import annotations

from screwcal.runtime.policy import for_command_line

for_command_line()  # the session runs the commands in-process: their policy, before numpy loads

import os  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from screwcal.kinematics.model import SerialModel  # noqa: E402
from screwcal.kinematics.se3 import exp_twist, rotvec_from_rotation  # noqa: E402
from screwcal.studies.tracker_dataset import DATA_DIR_ENV, DATASET_NAME, WHERE_TO_GET  # noqa: E402


def _tracker_data() -> Path:
    """$SCREWCAL_DATA_DIR, else the project's shared folder when a checkout has it beside."""
    root = Path(os.environ.get(DATA_DIR_ENV) or
                Path(__file__).resolve().parents[2] / "shared" / "datasets")
    return root if root.name == DATASET_NAME else root / DATASET_NAME


TRACKER_DATA = _tracker_data()
needs_tracker_data = pytest.mark.skipif(
    not (TRACKER_DATA / "measured_joints.txt").is_file(),
    reason=f"real data set not found at {TRACKER_DATA}: {WHERE_TO_GET}")


def random_model(rng: np.random.Generator, joint_types: str = "RRRRRR",
                 frames: bool = True) -> SerialModel:
    """A serial model with random axes, points, zeros and (optionally) base and tool frames."""
    n = len(joint_types)
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    points = rng.uniform(-500, 500, (n, 3))
    home = exp_twist(np.r_[rng.normal(0, 1, 3), rng.uniform(-800, 800, 3)])

    def frame() -> np.ndarray:
        return exp_twist(np.r_[rng.normal(0, 1, 3), rng.uniform(-300, 300, 3)]) if frames \
            else np.eye(4)

    rev = np.array([t == "R" for t in joint_types])
    limits = np.where(rev[:, None], [-np.pi, np.pi], [-200.0, 200.0])
    return SerialModel(name="random", joint_types=tuple(joint_types), axis_dirs=dirs,
                       axis_points_mm=points, home_flange=home, limits=limits,
                       joint_zero=rng.normal(0, 0.05, n), base=frame(), tool=frame())


def random_q(model: SerialModel, rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(model.limits[:, 0], model.limits[:, 1], (n, model.n_joints))



def point_rates(T_plus: np.ndarray, T_minus: np.ndarray, step: float) -> np.ndarray:
    """Finite-difference rates (N, 6) of the tool point and of its rotation vector, rows as
    `ErrorModel.linearisation`'s: from poses (N, 4, 4) at the two ends of `step` (the whole
    step: 2h for central differences, h for forward ones)."""
    dR = T_plus[:, :3, :3] @ np.swapaxes(T_minus[:, :3, :3], 1, 2)
    return np.c_[(T_plus[:, :3, 3] - T_minus[:, :3, 3]) / step,
                 rotvec_from_rotation(dR) / step]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20181122)


# -- the job store's two databases ------------------------------------------------------------
@pytest.fixture(scope="session")
def postgres_server():
    """A real PostgreSQL server on a private socket for the session (tests/postgres_server.py);
    skipped, saying how to install it, where its binaries are missing."""
    from tests.postgres_server import INSTALL, PostgresServer, find_bin_dir

    bin_dir = find_bin_dir()
    if bin_dir is None:
        pytest.skip(f"no PostgreSQL server (initdb, pg_ctl, postgres): install it with "
                    f"`{INSTALL}`")
    server = PostgresServer(bin_dir)
    server.start()
    yield server
    server.stop()


@pytest.fixture(params=["sqlite", "postgresql"])
def db_target(request, tmp_path):
    """Where a job store lives, once per database: a SQLite file, or a fresh PostgreSQL
    database's URL."""
    if request.param == "sqlite":
        return tmp_path / "jobs.db"
    return request.getfixturevalue("postgres_server").new_database()


def _of_the_service(request: pytest.FixtureRequest) -> bool:
    """Whether the test is one of the service's (tests/service, tests/integration)."""
    here = Path(__file__).parent
    return str(request.path).startswith((str(here / "integration"), str(here / "service")))


@pytest.fixture(autouse=True)
def store_off_the_loop(request, monkeypatch):
    """Every test of the service: no store call of the service's code on the event loop's
    thread (tests/loop_guard.py)."""
    if not _of_the_service(request):
        yield
        return
    from tests.loop_guard import guard_store

    seen = guard_store(monkeypatch)
    yield
    assert not seen, "store calls on the event loop's thread:\n" + "\n".join(sorted(set(seen)))


_ARGON2_HASHES: dict[str, str] = {}
_ARGON2_VERDICTS: dict[tuple[str, str], bool] = {}


@pytest.fixture(autouse=True)
def argon2_once_per_password(request, monkeypatch):
    """Every test of the service: a password is hashed once per test process, and a password
    checked once against a stored hash, each by the real argon2id at the library's parameters
    (service/credentials.py; about 0.25 s a call, and a test's users, one per role, share one
    password). Users of one password share its salt here: tests/service/test_credentials.py
    holds hash_password itself to a fresh salt per call."""
    if not _of_the_service(request):
        return
    import service.people as people
    from service.credentials import hash_password, password_matches

    def hashed(password: str) -> str:
        if password not in _ARGON2_HASHES:
            _ARGON2_HASHES[password] = hash_password(password)
        return _ARGON2_HASHES[password]

    def matches(stored: str, password: str) -> bool:
        if (stored, password) not in _ARGON2_VERDICTS:
            _ARGON2_VERDICTS[stored, password] = password_matches(stored, password)
        return _ARGON2_VERDICTS[stored, password]

    monkeypatch.setattr(people, "hash_password", hashed)
    monkeypatch.setattr(people, "password_matches", matches)


@pytest.hookimpl(trylast=True)  # after any reordering plugin: the slow ones still go first
def pytest_configure(config: pytest.Config) -> None:
    """The project's bytecode compiled once, before the workers start: the suite starts the
    command line in a few hundred processes, and each would otherwise compile the ~200 modules
    it imports (0.2-0.4 s a process where PYTHONDONTWRITEBYTECODE is set). Python checks each
    cached file against its source, as on any run; __pycache__ is ignored by git."""
    if hasattr(config, "workerinput"):  # a worker of pytest-xdist: the controller did it
        return
    import compileall

    root = Path(__file__).resolve().parents[1]
    for package in ("screwcal", "protocol", "simulators", "service"):
        compileall.compile_dir(str(root / package), quiet=1)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The tests marked `slow` first (a stable sort: otherwise in collection order), so that
    under `-n` the workers start the long ones early and end together rather than one waiting
    on the other's last long test. An xdist_group stays whole: the scheduler groups by name."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
