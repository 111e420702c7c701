"""Checkpoints and `fascia run --resume`: a run stopped by a signal (inside a step, or between
steps), by --max-wall or killed with SIGKILL continues from its checkpoint into the same file and
ends bitwise identical to an uninterrupted run (same build, backend, precision and threads);
refusals of checkpoints from another scene; SIGHUP and SIGUSR2 do not stop a run."""
import os
import pathlib
import signal
import subprocess
import time

import h5py
import numpy as np
import pytest

from trajectory_rows import rows

STOPPED = 75
DATA_ERROR = 65

# tool_pull for 1 s: 100 backward-Euler steps with a prescribed motion, on one thread, with the
# default linear solver (PCG preconditioned by a CHOLMOD factorisation reused across Newton
# iterations and steps, which the checkpoint records where it was computed). The tests stop it
# after at most 12 rows: the steps left (about 2 s on one thread of a 2-core machine) leave the
# poller time to see the rows and signal the run before it ends, also on a loaded machine.
SCENE = ["scenes/tool_pull.yaml", "--set", "run.duration=1 s", "--threads", "1"]


def run(fascia_bin, root, *args):
    return subprocess.run([fascia_bin, "run", *args], cwd=root, capture_output=True, text=True, timeout=600)


def start(fascia_bin, root, *args):
    return subprocess.Popen([fascia_bin, "run", *args], cwd=root, stderr=subprocess.PIPE, text=True)


def assert_bitwise_equal(a, b):
    ra, rb = rows(a), rows(b)
    assert ra.keys() == rb.keys()
    for key in ra:
        assert ra[key].shape == rb[key].shape, key
        assert ra[key].tobytes() == rb[key].tobytes(), key  # bitwise, not within a tolerance


def wait_for_rows(path, n, process, timeout=300):
    start_time = time.time()
    while time.time() - start_time < timeout:
        assert process.poll() is None, "fascia ended early"
        try:
            with h5py.File(path, "r", locking=False) as f:
                steps = f["particles/frames/position/step"][()]
                if np.sum(steps >= 0) >= n:
                    return
        except (OSError, KeyError):
            pass
        time.sleep(0.05)
    raise AssertionError("no progress")


@pytest.fixture(scope="module")
def reference(fascia_bin, root, tmp_path_factory):
    out = tmp_path_factory.mktemp("reference") / "full.h5"
    r = run(fascia_bin, root, *SCENE, "-o", str(out), "-q")
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGUSR1, signal.SIGINT])
def test_a_stopped_run_resumes_to_the_same_bits(fascia_bin, root, tmp_path, reference, stop):
    out = tmp_path / "part.h5"
    p = start(fascia_bin, root, *SCENE, "-o", str(out), "-q")
    wait_for_rows(out, 5, p)
    p.send_signal(stop)
    _, err = p.communicate(timeout=300)
    assert p.returncode == STOPPED, err
    assert f"stopped by {stop.name}" in err and "--resume" in err
    with h5py.File(out, "r") as f:
        assert "checkpoint" in f and f["checkpoint/commit"][0] > 0
        assert 5 <= f["particles/frames/position/value"].shape[0] < 101
    r = run(fascia_bin, root, *SCENE, "-o", str(out), "--resume", "-q")
    assert r.returncode == 0, r.stderr
    assert_bitwise_equal(out, reference)
    # The velocities are recorded with the positions.
    with h5py.File(out, "r") as f:
        assert f["particles/frames/velocity/value"].shape == f["particles/frames/position/value"].shape
        assert np.abs(f["particles/frames/velocity/value"][-1]).max() > 0
    # A finished run resumed does nothing and says so.
    before = out.read_bytes()
    r = run(fascia_bin, root, *SCENE, "-o", str(out), "--resume", "-q")
    assert r.returncode == 0 and "nothing to resume" in r.stderr
    assert out.read_bytes() == before


@pytest.mark.parametrize("scene,stops", [
    # bone: from step 47 on a solve takes at most 10 PCG iterations, so one factorisation serves
    # several steps and the resumed run must start with the one the stopped run held. Run for 2 s
    # (200 steps, not the scene's 60): the signal must land before the run ends, and the rows
    # reach the file some steps after those steps are taken.
    (["scenes/bone.yaml", "--set", "run.duration=2 s"], [50, 53, 56, 59]),
    # The variational integrator's iteration matrix (start and end states of the step). Steps of
    # 5 ms: undamped, with steps of 10 ms, the pulled tissue's Newton stops converging between 0.4
    # and 0.5 s (where depends on rounding), with 5 ms it runs past 0.6 s. About one step in six
    # holds no factorisation, and the rows reach the file in bursts (on a 2-core VM the stops
    # after 10 and 12 rows both landed after row 12, a step that holds none), so the stops are
    # spread over 30 rows. 120 steps: at least 88 (about 1.5 s on one thread of that VM) are left
    # after the last stop's rows for the signal to land before the run ends.
    (["scenes/tool_pull.yaml", "--set", "run.duration=0.6 s", "--set", "solver.dt=5 ms", "--set",
      "solver.integrator=variational", "--set", "solver.rayleigh_mass=0"], [8, 14, 20, 26, 32]),
])
def test_the_reused_factorisation_is_resumed(fascia_bin, root, tmp_path, scene, stops):
    """Default solver settings: the resumed run re-assembles and re-factorises the tangent the
    stopped run's preconditioner was computed from, and repeats every PCG iteration. A step whose
    last solve found the kept factorisation no longer paying leaves none held (the next solve
    factorises anew: solve/kept_factorisation.hpp); where the stop lands on such a step, the run
    is stopped again after the next count of rows in `stops`, until its committed checkpoint
    holds one."""
    args = [*scene, "--threads", "1", "-q"]
    full = tmp_path / "full.h5"
    r = run(fascia_bin, root, *args, "-o", str(full))
    assert r.returncode == 0, r.stderr
    held = False
    for attempt, stop_after_rows in enumerate(stops):
        out = tmp_path / f"part{attempt}.h5"
        p = start(fascia_bin, root, *args, "-o", str(out))
        wait_for_rows(out, stop_after_rows, p)
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=300)
        assert p.returncode == STOPPED, err
        with h5py.File(out, "r") as f:
            slot = f["checkpoint/commit"][0] % 2  # checkpoint n is written to slot n % 2
            held = f[f"checkpoint/slot_{slot}/tangent"][0] > 0
        if held:
            break
    assert held, "no stop landed on a step that holds a factorisation"
    r = run(fascia_bin, root, *args, "-o", str(out), "--resume")
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr
    assert_bitwise_equal(out, full)  # positions, velocities, fields, and the PCG iteration counts


ADAPTIVE = ["scenes/tool_strike.yaml", "--threads", "1", "-q"]  # solver.adaptive: steps of its own


def test_an_adaptive_run_stopped_by_a_signal_resumes_to_the_same_bits(fascia_bin, root, tmp_path):
    full = tmp_path / "full.h5"
    assert run(fascia_bin, root, *ADAPTIVE, "-o", str(full)).returncode == 0
    out = tmp_path / "part.h5"
    p = start(fascia_bin, root, *ADAPTIVE, "-o", str(out))
    wait_for_rows(out, 8, p)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=300)
    assert p.returncode == STOPPED, err
    assert "continue with --resume" in err
    r = run(fascia_bin, root, *ADAPTIVE, "-o", str(out), "--resume")
    assert r.returncode == 0, r.stderr
    # Rows, the step sizes, the accepted and rejected counts and the iterations of every row.
    assert_bitwise_equal(out, full)


def test_an_adaptive_run_stopped_between_its_rows_resumes_to_the_same_bits(fascia_bin, root, tmp_path):
    """One row at the end (output.every = 30): every stop by --max-wall falls between two rows,
    inside the controller's sequence of steps, and the last row sums the attempts made before and
    after each stop."""
    args = [*ADAPTIVE, "--set", "output.every=30"]
    full = tmp_path / "full.h5"
    began = time.monotonic()
    assert run(fascia_bin, root, *args, "-o", str(full)).returncode == 0
    # A fifth of the uninterrupted run's wall time per run: the run is stopped about four times
    # between its rows whatever the machine's speed (its setup is a few percent of its wall time).
    wall = f"{(time.monotonic() - began) / 5:.3f} s"
    out = tmp_path / "part.h5"
    stops, between = 0, 0
    r = run(fascia_bin, root, *args, "-o", str(out), "--max-wall", wall)
    while r.returncode == STOPPED and stops < 50:
        stops += 1
        with h5py.File(out, "r") as f:
            slot = f"checkpoint/slot_{f['checkpoint/commit'][0] % 2}"
            t = f[slot]["clock"][0]
            assert 0 <= t < 0.3  # the rows are at 0 and 0.3 s (t = 0: stopped during the setup)
            assert f[slot]["controller"][0] > 0  # the controller's next step size
            between += 0 < t
        r = run(fascia_bin, root, *args, "-o", str(out), "--resume", "--max-wall", wall)
    assert r.returncode == 0, r.stderr
    assert between >= 2, "the run was not stopped twice between its rows; lengthen it"
    assert_bitwise_equal(out, full)
    with h5py.File(out, "r") as f:
        assert f["observables/rejected_steps/value"][-1] > 0  # the controller rejected steps


def test_a_stop_row_off_the_output_cadence_is_dropped_on_resume(fascia_bin, root, tmp_path):
    """With output.every = 4 a stop writes its last step as an extra row; the resumed file has
    exactly the rows of an uninterrupted run."""
    every = ["--set", "output.every=4"]
    full = tmp_path / "full.h5"
    assert run(fascia_bin, root, *SCENE, *every, "-o", str(full), "-q").returncode == 0
    out = tmp_path / "part.h5"
    # --max-wall stops the run in the same way as a signal.
    r = run(fascia_bin, root, *SCENE, *every, "--set", "run.duration=100 s", "-o", str(tmp_path / "long.h5"),
            "--max-wall", "1.5 s", "-q")
    assert r.returncode == STOPPED and "stopped by --max-wall" in r.stderr
    p = start(fascia_bin, root, *SCENE, *every, "-o", str(out), "-q")
    wait_for_rows(out, 3, p)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=300)
    assert p.returncode == STOPPED, err
    r = run(fascia_bin, root, *SCENE, *every, "-o", str(out), "--resume", "-q")
    assert r.returncode == 0, r.stderr
    assert_bitwise_equal(out, full)


def test_a_stop_inside_a_step_abandons_it(fascia_bin, root, tmp_path):
    """One step that would take hours (CG without a tolerance, 10^8 iterations): a stop is seen
    inside the linear solve, the run keeps step 0 and its checkpoint and exits 75."""
    out = tmp_path / "slow.h5"
    p = start(fascia_bin, root, "scenes/tool_pull.yaml", "-o", str(out), "--set", "solver.linear.method=cg",
              "--set", "solver.linear.fixed_iterations=true", "--set", "solver.linear.max_iterations=100000000")
    wait_for_rows(out, 1, p)
    time.sleep(0.5)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == STOPPED, err
    assert "stopped by SIGTERM after step 0" in err
    with h5py.File(out, "r") as f:
        assert list(f["particles/frames/position/step"][()]) == [0]
        assert f["checkpoint/commit"][1] == 0


def test_sighup_and_sigusr2_do_not_stop_a_run(fascia_bin, root, tmp_path):
    out = tmp_path / "hup.h5"
    p = start(fascia_bin, root, *SCENE, "--set", "run.duration=100 s", "-o", str(out), "--checkpoint-interval", "0")
    wait_for_rows(out, 2, p)
    with h5py.File(out, "r", locking=False) as f:
        sequence = f["checkpoint/commit"][0]
    p.send_signal(signal.SIGHUP)
    p.send_signal(signal.SIGUSR2)  # a checkpoint now, and go on
    n = 0
    with h5py.File(out, "r", locking=False) as f:
        n = int(np.sum(f["particles/frames/position/step"][()] >= 0))
    wait_for_rows(out, n + 3, p)
    assert p.poll() is None
    with h5py.File(out, "r", locking=False) as f:
        assert f["checkpoint/commit"][0] > sequence
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=300)
    assert p.returncode == STOPPED, err
    assert "SIGHUP ignored" in err


def test_a_run_killed_with_sigkill_resumes_to_the_same_bits(fascia_bin, root, tmp_path, reference):
    out = tmp_path / "killed.h5"
    for kill_after_rows in (4, 12):
        args = [*SCENE, "-o", str(out), "--checkpoint-every", "1", "-q"]
        p = start(fascia_bin, root, *args, *(["--resume"] if out.exists() else []))
        wait_for_rows(out, kill_after_rows, p)
        p.kill()
        p.wait(timeout=60)
    r = run(fascia_bin, root, *SCENE, "-o", str(out), "--resume", "-q")
    assert r.returncode == 0, r.stderr
    assert_bitwise_equal(out, reference)


def test_a_checkpoint_of_another_scene_is_refused(fascia_bin, root, tmp_path):
    out = tmp_path / "other.h5"
    p = start(fascia_bin, root, *SCENE, "-o", str(out), "-q")
    wait_for_rows(out, 3, p)
    p.send_signal(signal.SIGTERM)
    p.communicate(timeout=300)
    assert p.returncode == STOPPED
    before = out.read_bytes()
    r = run(fascia_bin, root, *SCENE, "--set", "materials.fascia.young=50 kPa", "-o", str(out), "--resume", "-q")
    assert r.returncode == DATA_ERROR
    assert "another scene" in r.stderr and "50000" in r.stderr
    assert out.read_bytes() == before
    # --resume and --overwrite contradict each other.
    assert run(fascia_bin, root, *SCENE, "-o", str(out), "--resume", "--overwrite").returncode == 64


def test_a_checkpoint_is_refused_with_another_voxelisation_module(fascia_bin, root, tmp_path):
    """The build identity covers the voxelisation module the run loads: a stopped meshless run
    resumed with a module of other bytes is refused (exit 65) and its file is left as it was."""
    scene = ["scenes/meshless_slab.yaml", "--threads", "1"]
    out = tmp_path / "slab.h5"
    r = run(fascia_bin, root, *scene, "--set", "run.duration=100 s", "-o", str(out), "--max-wall", "1 s", "-q")
    assert r.returncode == STOPPED, r.stderr
    before = out.read_bytes()
    module_dir = tmp_path / "module"
    module_dir.mkdir()
    program = pathlib.Path(fascia_bin).resolve()
    module = (program.parent.parent / "lib" / "libfascia_openvdb.so").read_bytes()
    (module_dir / "libfascia_openvdb.so").write_bytes(module + b"\0")  # still loadable, other bytes
    other = subprocess.run([fascia_bin, "run", *scene, "--set", "run.duration=100 s", "-o", str(out), "--resume", "-q"],
                           cwd=root, capture_output=True, text=True, timeout=600,
                           env={**os.environ, "FASCIA_MODULE_DIR": str(module_dir)})
    assert other.returncode == DATA_ERROR, other.stderr
    assert "written by another build" in other.stderr and "voxel module" in other.stderr
    assert out.read_bytes() == before
