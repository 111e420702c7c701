"""ParaView 5.11 (Debian 12's pvbatch, under xvfb-run: Debian's build needs an X server) opens a run's
XDMF sidecars: run.xmf with the default reader for .xmf (Xdmf3ReaderS), run.xmf2 with the legacy
XDMF reader. Every object at every step has the HDF5 rows' point count, positions and field values.

The scene (scenes/coupling.yaml) has a mesh-based tissue, a shell and a meshless tissue. Skipped,
visibly, only where pvbatch is not installed (tools/install-deps installs it)."""
import json
import shutil
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

PROBE = Path(__file__).with_name("paraview_probe.py")


@pytest.fixture(scope="module")
def run(fascia_bin, root, tmp_path_factory):
    out = tmp_path_factory.mktemp("paraview") / "coupling.h5"
    r = subprocess.run([fascia_bin, "run", "scenes/coupling.yaml", "-o", str(out), "--set", "run.duration=20ms",
                        "-q"], cwd=root, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return out


def pvbatch(xmf, reader=None):
    if shutil.which("pvbatch") is None:
        pytest.skip("pvbatch not found (Debian package paraview; tools/install-deps installs it)")
    assert shutil.which("xvfb-run"), "xvfb-run not found (Debian package xvfb; tools/install-deps installs it)"
    out = Path(str(xmf) + ".json")
    cmd = ["xvfb-run", "-a", "pvbatch", str(PROBE), str(xmf), str(out)] + ([reader] if reader else [])
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return json.loads(out.read_text())


def expected_blocks(f):
    """The sidecar's grids in order: the surfaces (as in /connectivity, the layout's order is kept in
    the XDMF file), then frames and samples."""
    return [name for name in f["particles"] if name not in ("frames", "samples")] + ["frames", "samples"]


@pytest.mark.parametrize("sidecar,reader,expected_reader", [
    ("xmf", None, "Xdmf3ReaderS"),
    ("xmf2", None, "XdmfReader"),
])
def test_paraview_reads_every_object_and_field(run, sidecar, reader, expected_reader):
    xmf = run.with_suffix("." + sidecar)
    seen = pvbatch(xmf, reader)
    assert seen["reader"] == expected_reader
    import xml.etree.ElementTree as ET
    order = [g.get("Name") for g in ET.parse(xmf).getroot().find("Domain/Grid").find("Grid").findall("Grid")]
    with h5py.File(run, "r") as f:
        times = f["particles/frames/position/time"][:]
        assert np.allclose(seen["times"], times, rtol=0, atol=1e-15)
        assert len(seen["steps"]) == len(times) == 3
        assert set(order) == set(expected_blocks(f))
        for k, blocks in enumerate(seen["steps"]):
            assert len(blocks) == len(order)
            for name, block in zip(order, blocks):
                group = f["particles"][name]
                rows = group["position/value"]
                assert block["points"] == rows.shape[1], (name, k)
                assert np.array_equal(np.array(block["coordinates"]), rows[k]), (name, k)
                fields = [e for e in group if isinstance(group[e], h5py.Group) and e not in ("position", "orientation", "box")]
                assert sorted(block["arrays"]) == sorted(fields), name
                for field in fields:
                    value = group[field]["value"][k]
                    got = np.array(block["arrays"][field]).reshape(value.shape)
                    # ParaView stores 3 x 3 tensors column by column: our tensors are symmetric.
                    assert np.array_equal(got, value) or (value.ndim == 3 and np.array_equal(got, value.transpose(0, 2, 1))), (name, field, k)
        # Surfaces carry the measures and kinematics of the tissues they bound; not all zero.
        assert np.abs(f["particles/layer/cauchy_von_mises/value"][-1]).max() > 0
        assert np.abs(f["particles/organ/green_strain/value"][-1]).max() > 0
        assert np.abs(f["particles/band/velocity/value"][-1]).max() > 0
