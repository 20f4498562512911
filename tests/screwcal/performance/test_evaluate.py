import csv
import json
import re

import numpy as np
import pytest

from screwcal.commands.main import main
from screwcal.performance.evaluate import read_performance_csv

HEADER = ["cycle", "point", "q1", "q2", "q3", "q4", "q5", "q6", "x_cmd", "y_cmd", "z_cmd",
          "rx_cmd", "ry_cmd", "rz_cmd", "x", "y", "z", "rx", "ry", "rz"]
CMD = {"P1": [900, 0, 500], "P2": [800, -100, 400], "P3": [800, 100, 400],
       "P4": [1000, 100, 600], "P5": [1000, -100, 600]}


def _write(path, rng, bias, noise, cycles=30, orientation=True):
    header = HEADER if orientation else HEADER[:-3]
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for c in range(1, cycles + 1):
            for label, p in CMD.items():
                att = np.array(p) + bias + rng.normal(0, noise, 3)
                row = [c, label, 0, 10, 20, 0, 30, 0, *p, 0, 180, 0, *att]
                if orientation:
                    row += [0.01, 179.98, -0.02]
                w.writerow(row)
    return path


def test_evaluate_report_and_plots(tmp_path, rng):
    after = _write(tmp_path / "after.csv", rng, np.array([0.1, 0, 0]), 0.01)
    before = _write(tmp_path / "before.csv", rng, np.array([3.0, 4.0, 0]), 0.01)
    line = tmp_path / "line.csv"
    t = np.linspace(0, 400, 21)
    pts = np.column_stack([700 + t, 0.05 * np.sin(t / 40), 400 + 0 * t])
    line.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.5f}" for v in p) for p in pts))
    out = tmp_path / "report.json"
    assert main(["evaluate", "--data", str(after), "--before", str(before), "--path", str(line),
                 "--out", str(out), "--plots", str(tmp_path / "plots")]) == 0
    report = json.loads(out.read_text())
    assert report["units"] == {"length": "mm", "angle": "deg"}
    assert set(report["result"]["points"]) == set(CMD)
    assert report["result"]["overall"]["ap_mm_mean"] == pytest.approx(0.1, abs=0.01)
    assert report["before"]["overall"]["ap_mm_mean"] == pytest.approx(5.0, abs=0.01)
    p1 = report["result"]["points"]["P1"]
    assert p1["n_cycles"] == 30 and p1["ap_abc_deg"][1] == pytest.approx(-0.02, abs=1e-9)
    assert report["result"]["straightness"]["peak_to_valley_mm"] == pytest.approx(0.1, abs=0.01)
    assert len(report["plots"]) == 3
    assert all((tmp_path / "plots" / n).stat().st_size > 5000 for n in
               ("accuracy_per_point.png", "straightness.png", "attained_vs_commanded.png"))


def test_position_only_data(tmp_path, rng):
    data = read_performance_csv(_write(tmp_path / "p.csv", rng, np.zeros(3), 0.01,
                                       orientation=False))
    assert not data.full_pose and len(data.points) == 5


@pytest.mark.parametrize(("edit", "message"), [
    # rows[0] is the header (line 1); rows[1..5] are cycle 1 of P1..P5, rows[6..10] cycle 2.
    (lambda rows: rows[8].__setitem__(0, "1"),
     r"line 9, column 'cycle': point P3 has cycle 1 twice \(also line 4\)"),
    (lambda rows: rows[7].__setitem__(8, "801"), r"line 8: point P2's commanded pose differs"),
    (lambda rows: rows[2].__setitem__(15, "x"), r"line 3, column 'y': 'x' is not a number"),
    (lambda rows: rows[4].__setitem__(1, ""), r"line 5, column 'point': is empty"),
    (lambda rows: [r.pop(1) for r in rows], r"missing column\(s\) point"),
    (lambda rows: [r.pop() for r in rows], r"rx, ry, rz go together; rz missing"),
])
def test_bad_performance_files_are_refused(tmp_path, rng, capsys, edit, message):
    path = _write(tmp_path / "bad.csv", rng, np.zeros(3), 0.01, cycles=3)
    with path.open() as f:
        rows = list(csv.reader(f))
    edit(rows)
    with path.open("w", newline="") as f:
        csv.writer(f).writerows(rows)
    out = tmp_path / "r.json"
    assert main(["evaluate", "--data", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert re.search(message, err), err
    assert not out.exists()
