"""fascia sweep without a scheduler: expansion of lists, ranges (with units), crossed and zipped
parameters; --task runs, finds finished, and resumes; errors with file:line:col; fascia collect."""
import json
import subprocess

import h5py


def fascia(fascia_bin, cwd, *args, timeout=600):
    return subprocess.run([fascia_bin, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout)


def test_runs_are_the_product_of_crossed_and_zipped_parameters(fascia_bin, root, tmp_path):
    sweep = tmp_path / "s.yaml"
    sweep.write_text(f"""scene: {root / 'scenes' / 'tool_pull.yaml'}
name: s
set: {{run.duration: 0.03 s}}
cross:
  materials.fascia.young: {{from: 20 kPa, to: 80 kPa, count: 3, scale: log}}
zip:
  - {{materials.fascia.poisson: [0.3, 0.4], solver.dt: [5 ms, 10 ms]}}
""")
    r = fascia(fascia_bin, tmp_path, "sweep", str(sweep), "--list", "--json")
    assert r.returncode == 0, r.stderr
    runs = json.loads(r.stdout)["runs"]
    assert len(runs) == 6
    young = [float(run["parameters"]["materials.fascia.young"]) for run in runs]
    assert young[0] == 20000 and young[-1] == 80000 and abs(young[2] - 40000) < 1e-9  # geometric middle
    assert [run["parameters"]["solver.dt"] for run in runs[:2]] == ["5 ms", "10 ms"]  # zipped, varying fastest
    assert [run["parameters"]["materials.fascia.poisson"] for run in runs[:2]] == ["0.3", "0.4"]
    assert runs[3]["output"] == "s/s-003.h5" and runs[3]["state"] == "pending"

    r = fascia(fascia_bin, tmp_path, "sweep", str(sweep), "--task", "1", "-q")
    assert r.returncode == 0, r.stderr
    record = json.loads((tmp_path / "s" / "s-001.json").read_text())
    assert record["status"] == "finished" and record["parameters"]["solver.dt"] == "10 ms"
    with h5py.File(tmp_path / "s" / "s-001.h5", "r") as f:
        scene = f["parameters/scene"][()]
        scene = scene.decode() if isinstance(scene, bytes) else scene
        assert "young: 20000 Pa" in scene and "dt: 0.01 s" in scene
    r = fascia(fascia_bin, tmp_path, "sweep", str(sweep), "--task", "1")
    assert r.returncode == 0 and "nothing to resume" in r.stderr
    assert fascia(fascia_bin, tmp_path, "sweep", str(sweep), "--task", "6").returncode == 64

    r = fascia(fascia_bin, tmp_path, "collect", "s")
    assert r.returncode == 0, r.stderr
    table = (tmp_path / "s" / "results.csv").read_text().splitlines()
    assert len(table) == 2
    header = table[0].split(",")
    assert header[:6] == ["name", "task", "status", "exit_code", "steps", "time"]
    assert "materials.fascia.young" in header and "elastic_energy" in header
    row = dict(zip(header, table[1].split(",")))
    assert row["status"] == "finished" and row["task"] == "1" and row["steps"] == "3"


def test_a_bad_sweep_file_is_reported_with_its_position(fascia_bin, root, tmp_path):
    sweep = tmp_path / "bad.yaml"
    sweep.write_text(f"scene: {root / 'scenes' / 'tool_pull.yaml'}\ncross:\n  a.b: {{from: 1 kPa, to: 2 mm, count: 2}}\n"
                     "colour: red\n")
    r = fascia(fascia_bin, tmp_path, "sweep", str(sweep), "--list")
    assert r.returncode == 78
    assert f"{sweep}:3:" in r.stderr and "different units" in r.stderr
    assert f"{sweep}:4:" in r.stderr and "unknown key 'colour'" in r.stderr
