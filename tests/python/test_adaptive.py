"""Adaptive time steps end to end (scenes/tool_strike.yaml, a sudden push): with a fixed dt of 10 ms
the first step inverts elements and the run stops with exit 1, the message naming the time, the
residual and the likely cause, the initial state written; with solver.adaptive the same scene
completes, its rows at the requested times, with rejected steps reported in /observables; and
scenes/quasi_static_press.yaml run as adaptive static steps."""
import json

import h5py
import numpy as np

from test_run_output import check_file, run_fascia


def test_sudden_push_fails_at_fixed_dt(fascia_bin, root, tmp_path):
    scene = (root / "scenes/tool_strike.yaml").read_text()
    fixed = tmp_path / "strike_fixed.yaml"
    fixed.write_text("\n".join(l for l in scene.splitlines() if "adaptive:" not in l) + "\n")
    out = tmp_path / "fixed.h5"
    r = run_fascia(fascia_bin, root, "run", str(fixed), "-o", str(out), "--set", "run.duration=30ms", "--quiet")
    assert r.returncode == 1, r.stderr
    assert "step 1 (t = 0.01 s" in r.stderr and "relative residual" in r.stderr, r.stderr
    assert "likely cause: an element inverts" in r.stderr, r.stderr
    assert "nan" not in r.stderr.lower()
    assert check_file(out, expect_steps=1) == 1  # the initial state, nothing non-finite


def test_sudden_push_completes_with_adaptive_steps(fascia_bin, root, tmp_path):
    out = tmp_path / "adaptive.h5"
    r = run_fascia(fascia_bin, root, "run", "scenes/tool_strike.yaml", "-o", str(out), "--set",
                   "run.duration=30ms", "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["status"] == "ok"
    assert summary["rejected_steps"] >= 1  # the 10 ms first step at least
    assert summary["accepted_steps"] > 3   # more steps than the fixed run's 3
    assert check_file(out, expect_steps=4) == 4
    with h5py.File(out, "r") as f:
        times = f["observables/dt/time"][:]
        # Rows at the fixed run's times, to round-off of k * dt.
        assert np.allclose(times, [0.0, 0.01, 0.02, 0.03], rtol=0, atol=1e-15)
        accepted = f["observables/accepted_steps/value"][:]
        rejected = f["observables/rejected_steps/value"][:]
        dt = f["observables/dt/value"][:]
        assert accepted[1:].sum() == summary["accepted_steps"]
        assert rejected[1:].sum() == summary["rejected_steps"]
        assert rejected[1] >= 1 and accepted[1] > 1
        assert np.all((dt[1:] > 0) & (dt[1:] <= 0.01 + 1e-15))
        assert np.all(f["observables/converged/value"][:] == 1)
        # The jaws reached the end of their path: 2 m/s for 10 ms = 20 mm towards the clamp.
        x0 = f["particles/frames/position/value"][0]
        x1 = f["particles/frames/position/value"][-1]
        jaws = (x0[:, 0] > 0.0995) & (x0[:, 1] >= 0.01) & (x0[:, 1] <= 0.03)
        assert jaws.sum() > 0
        assert np.allclose(x1[jaws, 0] - x0[jaws, 0], -0.02, rtol=1e-9)


def test_quasi_static_press_as_adaptive_static_steps(fascia_bin, root, tmp_path):
    """scenes/quasi_static_press.yaml as static steps (solver.adaptive sizes them): rows at the
    output times 0, 1, ..., 6 s, the steps counted per row, the platen at the end of its path, and
    the hold's rows taking one step each once the steps have grown to the output interval."""
    out = tmp_path / "press.h5"
    r = run_fascia(fascia_bin, root, "run", "scenes/quasi_static_press.yaml", "-o", str(out), "--set",
                   "solver.integrator=static", "--set", "solver.rayleigh_mass=0", "--threads", "1", "--json",
                   "--quiet")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["status"] == "ok"
    assert summary["rejected_steps"] >= 1  # estimates beyond 1 mm on the ramp (the first steps, the stroke's end)
    assert check_file(out, expect_steps=7) == 7
    with h5py.File(out, "r") as f:
        times = f["observables/dt/time"][:]
        assert np.allclose(times, np.arange(7.0), rtol=0, atol=1e-12)
        accepted = f["observables/accepted_steps/value"][:]
        assert accepted[1:].sum() == summary["accepted_steps"]
        assert accepted[1:].sum() < 150  # the fixed run's steps of 40 ms
        assert np.all(accepted[3:] == 1)  # the hold: one step per row
        assert np.all(f["observables/kinetic_energy/value"][:] == 0)  # static: no velocities
        x0 = f["particles/frames/position/value"][0]
        x1 = f["particles/frames/position/value"][-1]
        platen = x0[:, 0] > 0.0395
        assert platen.sum() > 0
        assert np.allclose(x1[platen, 0] - x0[platen, 0], -0.01, rtol=1e-9)
