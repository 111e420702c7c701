"""tools/post/fascia_post.py on a real run and on study lines."""
import json
import shutil
import subprocess

import pytest

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
    # The jaws at x = 100 mm move at 20 mm/s: the +x end's frames (jaws and the free rest of the
    # edge) follow; after 40 ms the jaws themselves are 0.8 mm along.
    assert 0 < d[-1, 0] <= 0.8e-3 + 1e-12
    fig = fp.plot_tip(run, out=tmp_path / "tip.png")
    assert (tmp_path / "tip.png").stat().st_size > 1000
    assert fig.axes[0].get_xlabel() == "time (s)"
    assert fp.main([str(out), "--tip", str(tmp_path / "tip2.png")]) == 0


def test_plot_convergence_from_a_real_study(fascia_bin, root, tmp_path):
    r = subprocess.run([fascia_bin, "study", "beam", "--json", "--method", "frame-hex", "--method", "fem-hex",
                        "--resolution", "4x1x1", "--resolution", "8x1x1"], cwd=root, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    path = tmp_path / "study.jsonl"
    path.write_text(r.stdout)
    records = fp.read_json_lines(path)
    assert len(records) == 4 and len(records[0]["tip_displacement"]) == 3  # a vector, in m
    fig = fp.plot_convergence(path, out=tmp_path / "conv.png")
    ax = fig.axes[0]
    assert len(ax.lines) == 2
    assert ax.get_xscale() == "log"
    # The plotted deflection is |dz|, the largest component of the cantilever's tip displacement.
    for line in ax.lines:
        method = line.get_label()
        expected = sorted((r["dofs"], abs(r["tip_displacement"][2])) for r in records if r["method"] == method)
        assert np.allclose(line.get_ydata(), [e[1] for e in expected])
    assert_not_blank(tmp_path / "conv.png")
    assert fp.main(["--convergence", str(path), "--out", str(tmp_path / "conv2.png"), "--reference=-6.506"]) == 0
    with_reference = fp.plot_convergence(path, reference=-6.506).axes[0]
    assert len(with_reference.lines) == 3 and with_reference.lines[-1].get_ydata()[0] == 6.506


def assert_not_blank(png, min_colours=20, min_ink=0.05):
    """An image with a drawing on it: many distinct colours and at least `min_ink` of its pixels
    not white (a blank or nearly blank figure has a few colours and is almost all white)."""
    import matplotlib.image as mpimg

    image = mpimg.imread(png)[:, :, :3]
    colours = np.unique((image * 255).astype(np.uint8).reshape(-1, 3), axis=0)
    ink = np.mean(np.any(image < 0.95, axis=2))
    assert len(colours) >= min_colours, (png, len(colours))
    assert ink >= min_ink, (png, ink)


def test_render_observables_and_summary_of_a_real_run(fascia_bin, root, tmp_path, capsys):
    out = tmp_path / "pull.h5"
    r = subprocess.run([fascia_bin, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set", "run.duration=30ms",
                        "-q"], cwd=root, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert fp.main([str(out), "--summary", "--render", str(tmp_path / "pull.png"), "--field", "cauchy_stress",
                    "--observables", str(tmp_path / "obs.png"), "--tip", str(tmp_path / "tip.png"),
                    "--tip-axis=-z", "--tip-group", "slab"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["steps"] == 4 and summary["surfaces"] == ["slab"]
    assert summary["tip"]["group"] == "slab" and summary["tip"]["displacement"][2] < 0  # the slab sags
    for png in ("pull.png", "obs.png", "tip.png"):
        assert_not_blank(tmp_path / png)
    run = fp.load(out)
    # A movie of every other step: steps 0, 2 and the last.
    assert fp.render(run, tmp_path / "pull.gif", every=2, field_name="displacement") == 3
    from PIL import Image
    with Image.open(tmp_path / "pull.gif") as gif:
        assert gif.n_frames == 3
    if shutil.which("ffmpeg") is None:
        pytest.skip("ffmpeg not found (Debian package ffmpeg; tools/install-deps installs it): MP4 not checked")
    assert fp.render(run, tmp_path / "pull.mp4", every=1, field_name="strain_energy_density") == 4
    probe = subprocess.run(["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
                            "stream=nb_read_frames,codec_name", "-of", "json", str(tmp_path / "pull.mp4")],
                           capture_output=True, text=True)
    assert probe.returncode == 0, probe.stderr
    stream = json.loads(probe.stdout)["streams"][0]
    assert int(stream["nb_read_frames"]) == 4
    vm = fp.field(run, "samples", "cauchy_von_mises")
    assert vm.shape == (4, run.samples.shape[1]) and fp.field_unit(run, "samples", "cauchy_von_mises") == "Pa"
    # Bad input: a message and exit 65, nothing drawn.
    assert fp.main([str(out), "--render", str(tmp_path / "x.png"), "--field", "no_such_field"]) == 65
    assert not (tmp_path / "x.png").exists()


def test_fascia_render_draws_a_step_and_reports_bad_input(fascia_bin, root, tmp_path):
    out = tmp_path / "pull.h5"
    r = subprocess.run([fascia_bin, "run", "scenes/tool_pull.yaml", "-o", str(out), "--set", "run.duration=20ms",
                        "-q"], cwd=root, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr

    def render(*args):
        return subprocess.run([fascia_bin, "render", str(out), *args], cwd=tmp_path, capture_output=True, text=True,
                              timeout=600)

    r = render("--field", "cauchy_von_mises", "--step", "1")
    assert r.returncode == 0, r.stderr
    assert_not_blank(tmp_path / "pull.png")  # the default name: RUN.png
    r = render("--every", "1", "-o", str(tmp_path / "pull.gif"))
    assert r.returncode == 0, r.stderr
    from PIL import Image
    with Image.open(tmp_path / "pull.gif") as gif:
        assert gif.n_frames == 3
    assert render("--step", "7").returncode == 65  # 3 steps written
    assert render("--field", "no_such_field", "-o", str(tmp_path / "x.png")).returncode == 65
    assert render("--every", "2", "-o", str(tmp_path / "x.png")).returncode == 64  # a movie needs .gif or .mp4
    assert render("-o", str(tmp_path / "missing" / "x.png")).returncode == 74
    assert not (tmp_path / "x.png").exists()
    missing = subprocess.run([fascia_bin, "render", str(tmp_path / "none.h5")], capture_output=True, text=True)
    assert missing.returncode == 66
