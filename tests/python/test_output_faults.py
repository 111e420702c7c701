"""Output faults: a write that the operating system refuses (here a file-size limit, EFBIG; a full
disk, ENOSPC, takes the same path) ends with exit 74 and the system's reason, without a crash at
exit and without a stale temporary file; an output path that is a directory is refused before
the scene is discretised."""
import resource
import signal
import subprocess
from pathlib import Path


def limited_file_size(limit_bytes):
    def apply():
        # Ignored, SIGXFSZ turns writes beyond the limit into EFBIG errors instead of killing.
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    return apply


def test_a_refused_write_is_reported_with_its_reason_and_no_crash(fascia_bin, root, tmp_path):
    out = tmp_path / "run.h5"
    r = subprocess.run([fascia_bin, "run", "scenes/tool_pull.yaml", "-o", str(out), "--quiet"], cwd=root,
                       capture_output=True, text=True, timeout=300, preexec_fn=limited_file_size(200 * 1024))
    # Before: "HDF5 error: create dataset step" without a reason, then SIGSEGV (-11) in HDF5's
    # clean-up at exit.
    assert r.returncode == 74, r.stderr
    assert "File too large" in r.stderr, r.stderr
    assert not list(tmp_path.glob("*.tmp")), list(tmp_path.iterdir())


def test_an_output_that_is_a_directory_is_refused_before_the_discretisation(fascia_bin, root, tmp_path):
    r = subprocess.run([fascia_bin, "run", "scenes/tool_pull.yaml", "-o", str(tmp_path), "--quiet"], cwd=root,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 74, r.stderr
    assert "is a directory" in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_values_beyond_the_stored_range_are_a_solver_failure_not_an_io_error(fascia_bin, root, tmp_path):
    # A modulus of 1e200 Pa: round-off stresses of 1e184 Pa are beyond the float32 that the
    # stress fields are stored in (and the von Mises stresses overflow a double).
    out = tmp_path / "run.h5"
    r = subprocess.run([fascia_bin, "run", "scenes/tool_pull.yaml", "-o", str(out), "--quiet",
                        "--set", "materials.fascia.young=1e200Pa", "--set", "run.duration=0.05s"], cwd=root,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 1, r.stderr
    assert "refusing to write values beyond float32's range of" in r.stderr, r.stderr
    import h5py
    import numpy as np
    with h5py.File(out, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name.endswith("/value"):
                steps = f[name.rsplit("/", 1)[0] + "/step"][()]
                written = obj[()][steps >= 0]
                assert np.all(np.isfinite(written)), name
        f.visititems(visit)
