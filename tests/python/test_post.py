"""tools/post/fascia_post.py on a real run and on study lines."""
import json
import subprocess

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

import fascia_post as fp  # noqa: E402


def test_load_and_plot_a_run(fascia_bin, root, tmp_path):
    out = tmp_path / "pull.h5"
    r = subprocess.run([fascia_bin, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set", "run.duration=40ms",
                        "-q"], cwd=root, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    run = fp.load(out)
    assert run.step_count == 5
    assert run.frames.shape == (5, 11 * 5 * 3, 3)
    assert run.samples.shape[0] == 5
    assert set(run.surfaces) == {"slab"}
    assert run.surfaces["slab"].connectivity.shape[1] == 4
    assert np.all(np.diff(run.times) > 0)
    assert "materials:" in run.parameters["scene"]
    d = fp.tip_displacement(run)
    assert d.shape == (5, 3) and np.allclose(d[0], 0)
    fig = fp.plot_tip(run, out=tmp_path / "tip.png")
    assert (tmp_path / "tip.png").stat().st_size > 1000
    assert fig.axes[0].get_xlabel() == "time (s)"
    assert fp.main([str(out), "--tip", str(tmp_path / "tip2.png")]) == 0


def test_plot_convergence_from_json_lines(tmp_path):
    lines = [json.dumps({"method": m, "dofs": n, "tip_deflection": -d}) for m, pts in
             {"frames hex": [(108, 5.1), (540, 5.6), (1080, 5.7)], "fem hex": [(300, 3.0), (3000, 5.2)]}.items()
             for n, d in pts]
    path = tmp_path / "study.jsonl"
    path.write_text("fascia study beam\n" + "\n".join(lines) + "\n")
    fig = fp.plot_convergence(path, out=tmp_path / "conv.png")
    ax = fig.axes[0]
    assert len(ax.lines) == 2
    assert ax.get_xscale() == "log"
    assert (tmp_path / "conv.png").stat().st_size > 1000
