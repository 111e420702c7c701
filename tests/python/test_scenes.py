"""Every shipped scene (scenes/*.yaml) runs to its end on the CPU as `fascia run` does it: exit 0,
its rows written up to the end time, every position finite. About 30 s on one thread of a 2-core machine."""
import json
import math
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SCENES = sorted((ROOT / "scenes").glob("*.yaml"))


def test_the_shipped_scenes_are_found():
    assert len(SCENES) >= 10, SCENES


@pytest.mark.parametrize("scene", SCENES, ids=lambda p: p.stem)
def test_shipped_scene_runs_to_its_end(fascia_bin, tmp_path, scene):
    out = tmp_path / f"{scene.stem}.h5"
    r = subprocess.run([fascia_bin, "run", str(scene), "--threads", "1", "-o", str(out), "--json", "-q"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    summary = json.loads(r.stdout)
    assert summary["status"] == "ok" and summary["time"] > 0, summary
    assert all(math.isfinite(v) for v in summary["final"].values()), summary["final"]
    with h5py.File(out, "r") as f:
        positions = f["particles/frames/position/value"][()]
        times = f["particles/frames/position/time"][()]
    # Row 0 is the initial state; the last row is the end of the run.
    assert positions.shape[0] == summary["steps_written"] >= 2
    assert times[-1] == pytest.approx(summary["time"], rel=1e-12)
    assert np.isfinite(positions).all()


def test_bench_scenes_reports_each_scene_with_the_overrides_it_ran(fascia_bin):
    r = subprocess.run([fascia_bin, "bench", "scenes", "--only", "block_mesh", "--no-fine", "--steps", "2",
                        "--threads", "1", "--json", "--set", "output.samples=false"],
                       cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    rows = [json.loads(line) for line in r.stdout.splitlines()]
    assert [row["scene"] for row in rows] == ["block_mesh"]
    assert rows[0]["overrides"] == ["output.samples=false"]
    assert rows[0]["exit_code"] == 0 and rows[0]["steps"] == 2 and rows[0]["ms_per_step"] > 0


def test_bench_scenes_reports_a_scene_that_refuses_an_override(fascia_bin):
    r = subprocess.run([fascia_bin, "bench", "scenes", "--only", "block_mesh", "--no-fine", "--steps", "1",
                        "--json", "--set", "solver.dt=-1ms"],
                       cwd=ROOT, capture_output=True, text=True, timeout=300)
    rows = [json.loads(line) for line in r.stdout.splitlines()]
    assert len(rows) == 1 and rows[0]["exit_code"] != 0 and rows[0]["steps"] == 0
    assert r.returncode == rows[0]["exit_code"]
    assert "--set" in r.stderr and "dt must be > 0" in r.stderr
