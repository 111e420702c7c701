"""fascia run never destroys a file it did not create: an existing output is refused (exit 73)
unless --overwrite or --resume is given, and an output that is one of the run's inputs (the
scene, an included scene, a mesh) or a sidecar that would land on the trajectory is always
refused. Every refused file is checked byte for byte afterwards."""
import shutil
import subprocess
from pathlib import Path

import pytest

CANT_CREATE = 73


@pytest.fixture
def scene_dir(root, tmp_path):
    """scenes/block_mesh.yaml with its mesh, and a scene that includes it, in a scratch folder."""
    shutil.copy(root / "scenes" / "block_mesh.yaml", tmp_path / "block_mesh.yaml")
    (tmp_path / "meshes").mkdir()
    shutil.copy(root / "scenes" / "meshes" / "block_hex.vtk", tmp_path / "meshes" / "block_hex.vtk")
    (tmp_path / "longer.yaml").write_text("include: block_mesh.yaml\nrun: {duration: 0.06 s}\n")
    return tmp_path


def fascia(fascia_bin, cwd, *args):
    return subprocess.run([fascia_bin, *args, "-q"], cwd=cwd, capture_output=True, text=True, timeout=600)


def snapshot(folder):
    return {p: p.read_bytes() for p in Path(folder).rglob("*") if p.is_file()}


SHORT = ["--set", "run.duration=0.04 s"]


@pytest.mark.parametrize("args, culprit", [
    (["run", "block_mesh.yaml", "-o", "block_mesh.yaml"], "block_mesh.yaml"),
    (["run", "block_mesh.yaml", "-o", "./meshes/../block_mesh.yaml", "--overwrite"], "block_mesh.yaml"),
    (["run", "block_mesh.yaml", "--set", "output.file=meshes/block_hex.vtk", "--overwrite"], "block_hex.vtk"),
    (["run", "longer.yaml", "-o", "block_mesh.yaml", "--overwrite"], "block_mesh.yaml"),
    (["run", "block_mesh.yaml", "-o", "result.xmf"], "result.xmf"),
])
def test_an_output_that_is_an_input_is_refused(fascia_bin, scene_dir, args, culprit):
    before = snapshot(scene_dir)
    r = fascia(fascia_bin, scene_dir, *args, *SHORT)
    assert r.returncode == CANT_CREATE, r.stderr
    assert culprit in r.stderr
    assert snapshot(scene_dir) == before  # nothing written, nothing replaced


def test_an_existing_output_is_refused_unless_overwrite(fascia_bin, scene_dir):
    assert fascia(fascia_bin, scene_dir, "run", "block_mesh.yaml", "-o", "out.h5", *SHORT).returncode == 0
    before = snapshot(scene_dir)
    r = fascia(fascia_bin, scene_dir, "run", "block_mesh.yaml", "-o", "out.h5", *SHORT)
    assert r.returncode == CANT_CREATE and "out.h5 exists" in r.stderr and "--overwrite" in r.stderr
    assert snapshot(scene_dir) == before
    # The scene's own output.file is guarded the same way.
    assert fascia(fascia_bin, scene_dir, "run", "block_mesh.yaml", *SHORT).returncode == 0
    r = fascia(fascia_bin, scene_dir, "run", "block_mesh.yaml", *SHORT)
    assert r.returncode == CANT_CREATE and "block_mesh.h5 exists" in r.stderr
    # A sidecar left alone is someone's file too.
    (scene_dir / "out.h5").unlink()
    r = fascia(fascia_bin, scene_dir, "run", "block_mesh.yaml", "-o", "out.h5", *SHORT)
    assert r.returncode == CANT_CREATE and "out.xmf exists" in r.stderr
    r = fascia(fascia_bin, scene_dir, "run", "block_mesh.yaml", "-o", "out.h5", "--overwrite", *SHORT)
    assert r.returncode == 0, r.stderr
    assert (scene_dir / "out.h5").exists()


def test_outputs_are_refused_before_the_scene_is_discretised(fascia_bin, scene_dir):
    """The outputs are checked once the scene is parsed: with the scene's mesh unreadable, which
    the discretisation would report, the run ends on the kept sidecar's refusal instead."""
    (scene_dir / "out.xmf").write_text("a sidecar someone kept\n")
    (scene_dir / "meshes" / "block_hex.vtk").write_text("not a mesh\n")
    before = snapshot(scene_dir)
    r = fascia(fascia_bin, scene_dir, "run", "block_mesh.yaml", "-o", "out.h5", *SHORT)
    assert r.returncode == CANT_CREATE and "out.xmf exists" in r.stderr, r.stderr
    assert "block_hex.vtk" not in r.stderr
    assert snapshot(scene_dir) == before
    # Without the sidecar the same run reaches the discretisation, which reports the mesh.
    (scene_dir / "out.xmf").unlink()
    r = fascia(fascia_bin, scene_dir, "run", "block_mesh.yaml", "-o", "out.h5", *SHORT)
    assert r.returncode not in (0, CANT_CREATE) and "block_hex.vtk" in r.stderr, r.stderr
    assert not (scene_dir / "out.h5").exists()
