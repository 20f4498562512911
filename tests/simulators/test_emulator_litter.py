"""Issue 38: an emulator stopped by a signal leaves no private folder in the temporary
directory (each run keeps its world file in a `screwcal-world-*` folder of its own)."""

import os
import signal
import subprocess
import sys

import pytest


@pytest.mark.slow
def test_no_world_folder_is_left_after_20_emulators_stopped_by_signals(tmp_path):
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    runs = []
    for k in range(20):
        device = ["irc5", "--port", "0", "--arm-port", "0"] if k % 4 else ["arm", "--port", "0"]
        runs.append(subprocess.Popen([sys.executable, "-m", "screwcal", "emulator", *device],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env=env))
    for k, proc in enumerate(runs):
        starting = k % 5 == 4  # every fifth while it starts (SIGINT then is Python's own)
        if not starting:
            assert proc.stdout is not None and " on " in proc.stdout.readline()
        proc.send_signal(signal.SIGTERM if k % 2 or starting else signal.SIGINT)
    for proc in runs:
        _, err = proc.communicate(timeout=120)
        assert proc.returncode in (0, -signal.SIGINT, -signal.SIGTERM), err
        assert "Traceback" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []
