"""`--backend cuda` of `fascia run` and `fascia study beam`. Without a usable CUDA device, or in a
build without CUDA, the program stops with exit 69 (EX_UNAVAILABLE) and one line on stderr before
reading the scene or writing anything; with a device it runs and records the backend and the GPU
in /parameters/environment. Whether a device is present is decided independently of the program:
the build's FASCIA_WITH_CUDA (from CTest) and the NVIDIA driver's device list (`nvidia-smi -L`)."""
import json
import os
import shutil
import subprocess

import h5py


def run_fascia(fascia_bin, root, *args):
    return subprocess.run([fascia_bin, *args], cwd=root, capture_output=True, text=True, timeout=600)


def cuda_device_present():
    if os.environ.get("FASCIA_WITH_CUDA", "1") in ("0", "OFF", "FALSE", ""):
        return False
    smi = shutil.which("nvidia-smi")
    if smi is None:
        return False
    r = subprocess.run([smi, "-L"], capture_output=True, text=True, timeout=60)
    return r.returncode == 0 and any(line.startswith("GPU ") for line in r.stdout.splitlines())


def environment(path):
    with h5py.File(path, "r") as f:
        text = f["parameters/environment"][()]
    return json.loads(text.decode() if isinstance(text, bytes) else text)


def test_run_backend_cuda_exits_69_without_a_device_else_runs(fascia_bin, root, tmp_path):
    out = tmp_path / "pull.h5"
    r = run_fascia(fascia_bin, root, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set", "run.duration=20ms",
                   "--backend", "cuda", "--json", "--quiet")
    if not cuda_device_present():
        assert r.returncode == 69, r.stderr
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and "--backend cuda" in lines[0] and "--backend cpu" in lines[0], r.stderr
        assert r.stdout == ""
        assert not out.exists() and not (tmp_path / "pull.xmf").exists()
        return
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["status"] == "ok" and summary["backend"] == "cuda" and summary["gpu"]
    env = environment(out)
    assert env["backend"] == "cuda" and env["gpu"] == summary["gpu"] and env["precision"] == "double"


def test_run_records_the_cpu_backend(fascia_bin, root, tmp_path):
    out = tmp_path / "pull.h5"
    r = run_fascia(fascia_bin, root, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set", "run.duration=20ms",
                   "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["backend"] == "cpu"
    env = environment(out)
    assert env["backend"] == "cpu" and "gpu" not in env


def test_single_precision_on_the_cpu_backend_is_refused(fascia_bin, root, tmp_path):
    # The CPU engine computes in double: `--precision single` there is a usage error (64), not a
    # silent double run, and nothing is written.
    out = tmp_path / "bone.h5"
    for command in (["run", "scenes/bone.yaml", "-o", str(out)],
                    ["study", "beam", "--method", "frame-tet", "--resolution", "4x1x1"]):
        r = run_fascia(fascia_bin, root, *command, "--precision", "single")
        assert r.returncode == 64, r.stderr
        assert "--precision single applies to --backend cuda" in r.stderr
        assert r.stdout == ""
    assert not out.exists()


def test_study_backend_cuda_exits_69_without_a_device_else_runs(fascia_bin, root):
    args = ["study", "beam", "--method", "frame-tet", "--resolution", "4x1x1", "--json"]
    r = run_fascia(fascia_bin, root, *args, "--backend", "cuda")
    if not cuda_device_present():
        assert r.returncode == 69, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1 and "--backend cuda" in r.stderr
        assert r.stdout == ""
        return
    assert r.returncode == 0, r.stderr
    row = json.loads(r.stdout)
    cpu = json.loads(run_fascia(fascia_bin, root, *args).stdout)
    assert row["backend"] == "cuda" and cpu["backend"] == "cpu"
    assert row["converged"] and row["frames"] == cpu["frames"]
