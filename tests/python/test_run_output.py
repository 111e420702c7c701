"""Runs real scenes with the fascia program and checks the files with h5py: the H5MD layout, the
XDMF sidecar, SIGTERM handling and a run killed with SIGKILL mid-way."""
import json
import os
import signal
import subprocess
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest


def run_fascia(fascia_bin, root, *args, **kw):
    return subprocess.run([fascia_bin, *args], cwd=root, capture_output=True, text=True, timeout=600, **kw)


def complete_steps(f):
    import fascia_post
    return fascia_post.complete_steps(f)


def check_file(path, expect_steps=None):
    """Everything recorded reads back, is finite and consistent; returns the complete step count."""
    with h5py.File(path, "r") as f:
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        assert f["h5md/creator"].attrs["name"] in (b"fascia", "fascia")
        t = complete_steps(f)
        if expect_steps is not None:
            assert t == expect_steps
        n = f["particles/frames/position/value"].shape[1]
        assert f["particles/frames/orientation/value"].shape[1:] == (n, 4)
        for group in f["particles"].values():
            assert "box" in group and group["box"].attrs["dimension"] == 3
        clocks = set()

        def visit(name, obj):
            if isinstance(obj, h5py.Group) and "step" in obj:
                clocks.add((obj["step"].id, obj["time"].id))
                steps = obj["step"][:t]
                times = obj["time"][:t]
                values = obj["value"][:t]
                assert np.all(np.isfinite(values)), name
                assert np.all(np.isfinite(times)), name
                assert np.all(np.diff(steps) > 0), name
                assert np.all(np.diff(times) > 0), name
        f.visititems(visit)
        # Every series is written at every row: all share one step and one time dataset (hard links).
        assert len(clocks) == 1
        q = f["particles/frames/orientation/value"][:t]
        assert np.allclose(np.linalg.norm(q, axis=2), 1.0, atol=1e-9)
        for name, conn in f.get("connectivity", {}).items():
            v = f["particles"][name]["position/value"].shape[1]
            if name in ("frames", "samples"):
                assert conn.shape == (v,)
            assert conn[()].min() >= 0 and conn[()].max() < v
        scene = f["parameters/scene"][()]
        scene = scene.decode() if isinstance(scene, bytes) else scene
        assert "materials:" in scene
        return t


def check_xdmf(xmf_path, h5_path, steps):
    """Both sidecars (run.xmf, Xdmf3 selections; run.xmf2, XDMF 2 HyperSlabs) list `steps` steps and
    reference existing datasets with matching shapes; each selected row is a complete step."""
    for path in (Path(xmf_path), Path(str(xmf_path) + "2")):
        tree = ET.parse(path)
        temporal = tree.getroot().find("Domain/Grid")
        assert temporal.get("CollectionType") == "Temporal"
        grids = temporal.findall("Grid")
        assert len(grids) == steps
        with h5py.File(h5_path, "r") as f:
            for item in tree.getroot().iter("DataItem"):
                if item.get("Format") != "HDF":
                    continue
                source, _, selection = item.text.strip().partition("|")
                file_name, dataset = source.split(":")
                assert file_name == Path(h5_path).name
                dims = tuple(int(d) for d in item.get("Dimensions").split())
                if dataset.startswith("/connectivity"):
                    assert f[dataset].shape == dims, dataset
                    continue
                assert f[dataset].shape[1:] == dims[1:], dataset
                assert f[dataset].shape[0] >= dims[0]
                if selection:  # start:stride:count:dims, row k of [T][...]
                    start, stride, count, space = ([int(x) for x in part.split()] for part in selection.split(":"))
                    assert tuple(space) == f[dataset].shape and count == [1] + list(space[1:])
                    assert 0 <= start[0] < steps and stride == [1] * len(space)


def test_run_writes_a_complete_h5md_file(fascia_bin, root, tmp_path):
    out = tmp_path / "pull.h5"
    r = run_fascia(fascia_bin, root, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set", "run.duration=50ms",
                   "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    import json
    summary = json.loads(r.stdout)
    assert summary["status"] == "ok" and summary["steps"] == 5
    assert check_file(out, expect_steps=6) == 6  # the initial state and 5 steps
    check_xdmf(tmp_path / "pull.xmf", out, 6)
    with h5py.File(out, "r") as f:
        # The tool's jaws moved 20 mm/s * 50 ms = 1 mm along x.
        x0 = f["particles/frames/position/value"][0]
        x1 = f["particles/frames/position/value"][-1]
        jaws = (x0[:, 0] > 0.0995) & (x0[:, 1] >= 0.01) & (x0[:, 1] <= 0.03)
        assert jaws.sum() > 0
        assert np.allclose(x1[jaws, 0] - x0[jaws, 0], 1e-3, rtol=1e-6)
        cmd = f["parameters/command_line"][()]
        assert b"run.duration=50ms" in (cmd if isinstance(cmd, bytes) else cmd.encode())
        # Kinematics are stored in double, the strain and stress measures in single precision.
        for group in ("samples", "slab"):
            for name in ("position", "displacement", "velocity"):
                assert f[f"particles/{group}/{name}/value"].dtype == np.float64
            for name in ("green_strain", "cauchy_stress", "cauchy_principal", "cauchy_von_mises",
                         "strain_energy_density"):
                assert f[f"particles/{group}/{name}/value"].dtype == np.float32
        assert f["particles/frames/orientation/value"].dtype == np.float64


def test_info_summarises_a_run(fascia_bin, root, tmp_path):
    out = tmp_path / "pull.h5"
    assert run_fascia(fascia_bin, root, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set",
                      "run.duration=30ms", "-q").returncode == 0
    r = run_fascia(fascia_bin, root, "info", str(out), "--json")
    assert r.returncode == 0, r.stderr
    import json
    info = json.loads(r.stdout)
    assert info["steps"] == 4
    assert {g["name"] for g in info["particles"]} == {"frames", "samples", "slab"}
    fields = {g["name"]: set(g["fields"]) for g in info["particles"]}
    assert {"displacement", "velocity", "cauchy_stress", "cauchy_von_mises", "strain_energy_density"} <= fields["slab"]
    assert fields["samples"] == fields["slab"]
    assert {"orientation", "axis_x", "axis_y", "axis_z", "angular_velocity"} <= fields["frames"]
    assert "elastic_energy" in info["final"]
    # Counts are integers, energies floats (every observable is stored as a double).
    for name in ("newton_iterations", "cg_iterations", "accepted_steps", "rejected_steps", "converged"):
        assert type(info["final"][name]) is int, name
    assert type(info["solver"]["newton_iterations_total"]) is int
    assert info["solver"]["newton_iterations_total"] >= info["solver"]["newton_iterations_max"]
    assert type(info["final"]["elastic_energy"]) is float
    assert run_fascia(fascia_bin, root, "info", str(tmp_path / "missing.h5")).returncode == 66


def test_sigterm_finishes_the_step_and_exits_75(fascia_bin, root, tmp_path):
    out = tmp_path / "term.h5"
    xmf = tmp_path / "term.xmf"
    p = subprocess.Popen([fascia_bin, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set", "run.duration=1000s",
                          "-q"], cwd=root, stderr=subprocess.PIPE, text=True)
    wait_for_steps(xmf, 2, p)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 75, err
    assert "stopped by SIGTERM" in err
    t = check_file(out)
    assert t >= 2
    check_xdmf(xmf, out, t)


def wait_for_steps(xmf, steps, process, timeout=300):
    """The sidecar lists the flushed steps (rewritten about twice a second): count its time values."""
    start = time.time()
    while time.time() - start < timeout:
        assert process.poll() is None, "fascia ended early"
        try:
            if xmf.read_text().count("<Time ") >= steps:
                return
        except FileNotFoundError:
            pass
        time.sleep(0.05)
    raise AssertionError("no progress")


def test_a_run_killed_with_sigkill_leaves_readable_complete_steps(fascia_bin, root, tmp_path):
    out = tmp_path / "killed.h5"
    xmf = tmp_path / "killed.xmf"
    p = subprocess.Popen([fascia_bin, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set", "run.duration=1000s",
                          "-q"], cwd=root)
    try:
        wait_for_steps(xmf, 3, p)
        os.kill(p.pid, signal.SIGKILL)
    finally:
        p.wait(timeout=60)
    assert p.returncode == -signal.SIGKILL
    t = check_file(out)
    assert t >= 3
    with h5py.File(out, "r") as f:
        # Rows after the complete steps were preallocated and never completed: step -1. The kill may
        # land inside row t, after this series' step and before another's, so row t is either.
        steps = f["particles/frames/position/step"][()]
        assert np.all(steps[:t] == np.arange(t)) and np.all(steps[t + 1:] == -1)
        assert t == len(steps) or steps[t] in (-1, t)
        # Every complete step reads back in full.
        for k in range(t):
            assert f["particles/frames/position/value"][k].shape == f["particles/frames/position/value"].shape[1:]


def test_bad_scenes_exit_with_sysexits_codes(fascia_bin, root):
    cases = {"13_young_negative.yaml": 78, "29_missing_mesh_file.yaml": 66, "30_malformed_mesh_file.yaml": 65,
             "05_unknown_material_key.yaml": 78}
    for name, code in cases.items():
        path = f"tests/dsl/bad_scenes/{name}"
        r = run_fascia(fascia_bin, root, "check", path)
        assert r.returncode == code, (name, r.stderr)
        assert r.stderr.startswith(path + ":"), r.stderr
    r = run_fascia(fascia_bin, root, "run", "tests/dsl/bad_scenes/13_young_negative.yaml")
    assert r.returncode == 78
    r = run_fascia(fascia_bin, root, "run", "scenes/no_such_scene.yaml")
    assert r.returncode == 66
    r = run_fascia(fascia_bin, root, "run")
    assert r.returncode == 64


def test_schema_is_json_schema(fascia_bin, root):
    import json
    r = run_fascia(fascia_bin, root, "schema")
    assert r.returncode == 0
    schema = json.loads(r.stdout)
    assert schema["$schema"].startswith("http://json-schema.org/draft-07")
    assert "materials" in schema["properties"]


def test_check_reports_every_coupling(fascia_bin, root, tmp_path):
    """`fascia check` says how many frames each coupling merged or attached, in text and JSON.

    A rigid slab (scenes/meshes/slab_mm.obj: 60 x 20 x 10 mm) carries a tissue block 'lower'
    (3 x 1 x 1 cells on its top face: its 4 x 2 bottom frames lie on the slab), and a block 'upper'
    (6 x 2 x 1 cells) sits on 'lower' (its 7 x 3 bottom frames lie on lower's top face). Frame
    layers 10 mm apart, within 1 mm: exactly those layers are caught."""
    import json
    mesh = (Path(root) / "scenes/meshes/slab_mm.obj").as_posix()
    scene = tmp_path / "stack.yaml"
    scene.write_text(f"""fascia: 1
materials:
  soft: {{young: 10 kPa, poisson: 0.3, density: 1000 kg/m^3}}
objects:
  bone: {{kind: rigid, surface: {mesh}, transform: {{scale: 0.001}}, fixed: true}}
  lower: {{material: soft, box: {{min: [0, 0, 10 mm], max: [60 mm, 20 mm, 20 mm], cells: [3, 1, 1]}}}}
  upper: {{material: soft, box: {{min: [0, 0, 20 mm], max: [60 mm, 20 mm, 30 mm], cells: [6, 2, 1]}}}}
couplings:
  - {{attach: lower, to: bone, within: 1 mm}}
  - {{share: [upper, lower], within: 1 mm}}
run: {{steps: 1}}
""")
    r = run_fascia(fascia_bin, root, "check", str(scene))
    assert r.returncode == 0, r.stderr
    report = r.stdout.split("---\n", 1)[1]
    assert "couplings:\n" in report
    assert "  attach lower to bone: 8 frames of lower follow bone (within 0.001 m; 9:5)\n" in report
    assert "  share upper with lower: 21 frames of upper merged into frames of lower (within 0.001 m; 10:5)\n" in report

    r = run_fascia(fascia_bin, root, "check", str(scene), "--json")
    assert r.returncode == 0, r.stderr
    couplings = json.loads(r.stdout)["couplings"]
    assert [(c["kind"], c["object"], c["other"], c["frames"], c["line"]) for c in couplings] == [
        ("attach", "lower", "bone", 8, 9), ("share", "upper", "lower", 21, 10)]
    assert all(abs(c["within_m"] - 1e-3) < 1e-15 for c in couplings)
    # 16 + 42 frames of the blocks and the slab's one, less the 21 merged ones.
    assert json.loads(r.stdout)["discretisation"]["frames"] == 16 + 42 + 1 - 21


def test_check_reports_the_meshless_stages_seconds(fascia_bin, root):
    """`fascia check --json` gives each meshless object's stage times: disjoint parts of its
    discretisation's wall time, measured on one steady clock, so their sum cannot exceed the total
    (1e-9 s covers the rounding of the differences)."""
    r = run_fascia(fascia_bin, root, "check", "scenes/meshless_slab.yaml", "--json")
    assert r.returncode == 0, r.stderr
    meshless = json.loads(r.stdout)["meshless"]
    assert meshless
    stages = ["voxelise", "frames", "samples", "volumes", "shape_functions", "consistent_integration"]
    for name, obj in meshless.items():
        seconds = obj["seconds"]
        assert sorted(seconds) == sorted(stages + ["total"]), name
        assert all(seconds[s] >= 0 for s in stages), seconds
        assert sum(seconds[s] for s in stages) <= seconds["total"] + 1e-9, seconds
        assert seconds["total"] > 0, seconds
    r = run_fascia(fascia_bin, root, "check", "scenes/meshless_slab.yaml")
    assert r.returncode == 0, r.stderr
    assert "seconds: voxelise " in r.stdout


def test_rows_written_beside_the_steps_equal_rows_written_in_turn(fascia_bin, root, tmp_path):
    """With fewer step threads than the cores the process may use, each row is formed and written
    on an output thread while the next step runs; on one core, in turn with the steps. The two
    files hold the same bits (wall times and the run's environment aside)."""
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) < 2:
        pytest.skip("one core: the rows are written in turn with the steps either way")
    scene = ["scenes/pelvis.yaml", "--set", "run.duration=0.1 s", "--threads", "1", "--json", "-q"]
    beside, in_turn = tmp_path / "beside.h5", tmp_path / "in_turn.h5"
    r = run_fascia(fascia_bin, root, "run", *scene, "-o", str(beside))
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["threads"] == {"step": 1, "output": len(cores) - 1}
    r = run_fascia(fascia_bin, root, "run", *scene, "-o", str(in_turn), preexec_fn=lambda: os.sched_setaffinity(0, cores[:1]))
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["threads"] == {"step": 1, "output": 0}
    compared = []
    with h5py.File(beside, "r") as a, h5py.File(in_turn, "r") as b:
        def visit(name, obj):
            if not isinstance(obj, h5py.Dataset) or "wall_time" in name or name.startswith(("parameters", "h5md")):
                return
            x, y = obj[()], b[name][()]
            assert x.shape == y.shape and x.tobytes() == y.tobytes(), name
            compared.append(name)
        a.visititems(visit)
    assert len(compared) > 100 and "particles/samples/cauchy_stress/value" in compared
