"""Post-processing of fascia trajectories (HDF5, H5MD layout) with h5py, numpy and matplotlib.

    import fascia_post as fp
    run = fp.load("tool_pull.h5")
    run.times, run.frames.shape                 # (T,), (T, N, 3)
    run.observables["newton_iterations"]       # (T,)
    fp.field(run, "slab", "cauchy_von_mises")   # (T, V) Pa, a per-particle field
    fp.plot_tip(run, out="tip.png")             # displacement of the far end along +x over time
    fp.plot_observables(run, out="obs.png")     # energies, Newton and CG iterations, residual
    fp.render(run, "pull.png", field="displacement")          # deformed surfaces, last step
    fp.render(run, "pull.gif", every=2)                       # a movie (.gif, or .mp4 with ffmpeg)
    fp.plot_convergence("study.jsonl", out="convergence.png")   # `fascia study beam --json` lines

Only complete steps are returned: a file from a run killed with SIGKILL keeps preallocated rows
whose `step` is -1 after the last complete step; they are left out (see complete_steps).

Command line (headless, matplotlib's Agg backend):
    python3 tools/post/fascia_post.py RUN.h5 [--summary] [--tip PNG [--tip-axis +x] [--tip-group frames]]
        [--observables PNG] [--render PNG|GIF|MP4 [--step K | --every N] [--field NAME]]
    python3 tools/post/fascia_post.py --convergence STUDY.jsonl --out PNG
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, Iterable, Optional, Union

import h5py
import numpy as np


@dataclass
class Surface:
    positions: np.ndarray     # (T, V, 3) m
    connectivity: np.ndarray  # (F, 3|4) indices into positions
    frames: np.ndarray        # (V,) frame of each surface vertex


@dataclass
class Run:
    path: str
    steps: np.ndarray                 # (T,)
    times: np.ndarray                 # (T,) s
    frames: np.ndarray                # (T, N, 3) m
    orientations: np.ndarray          # (T, N, 4) unit quaternions (w, x, y, z)
    samples: Optional[np.ndarray]     # (T, S, 3) m, or None
    surfaces: Dict[str, Surface] = field(default_factory=dict)
    observables: Dict[str, np.ndarray] = field(default_factory=dict)
    parameters: Dict[str, str] = field(default_factory=dict)

    @property
    def step_count(self) -> int:
        return len(self.steps)


class FormatError(ValueError):
    """A file that is not in fascia's format: not HDF5, or HDF5 without metadata checksums."""


_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def require_checksummed_format(path: Union[str, Path]) -> None:
    """Refuses, before HDF5 reads it, a file that is not HDF5 or whose superblock is version 0 or 1
    (no metadata checksums): files of an older fascia, whose variable-length strings HDF5 1.10
    follows into the global heap unchecked (a damaged file crashes the interpreter), as fascia's own
    readers do (engine/io/hdf5_format.hpp). fascia writes superblock version 3 and fixed-length text."""
    with open(path, "rb") as f:
        head = f.read(len(_HDF5_SIGNATURE) + 1)
    if len(head) < len(_HDF5_SIGNATURE) + 1 or not head.startswith(_HDF5_SIGNATURE):
        raise FormatError(f"{path}: not an HDF5 file (no HDF5 signature at its start)")
    if head[-1] < 2:
        raise FormatError(f"{path}: HDF5 superblock version {head[-1]}, a format without metadata checksums "
                          "(written by an older fascia, or by another program in HDF5's default format); "
                          "run the scene again with this fascia")


def _text_dataset(d: h5py.Dataset) -> str:
    """Fixed-length text: variable-length strings (none in fascia's files) are refused unread."""
    kind = h5py.check_string_dtype(d.dtype)
    if kind is None or kind.length is None:
        raise FormatError(f"{d.file.filename}: {d.name} is not fixed-length text")
    return _text(d[()])


def _text(value) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray):
        return _text(value[()])
    return str(value)


def complete_steps(f: h5py.File) -> int:
    """Number of steps that every time series holds completely: the shortest dataset, and within it
    the leading rows whose step is written (a run killed with SIGKILL leaves preallocated rows with
    step -1 at the end)."""
    groups = []

    def visit(name, obj):
        if isinstance(obj, h5py.Group) and "step" in obj and "time" in obj and "value" in obj:
            groups.append(obj)

    f.visititems(visit)
    if not groups:
        return 0
    t = min(min(g["step"].shape[0], g["time"].shape[0], g["value"].shape[0]) for g in groups)
    for g in groups:
        steps = g["step"][:t]
        unwritten = np.nonzero(steps < 0)[0]
        if len(unwritten):
            t = int(unwritten[0])
    return t


def load(path: Union[str, Path]) -> Run:
    """Reads a fascia trajectory: frames, samples, surfaces, observables and parameters."""
    require_checksummed_format(path)
    with h5py.File(path, "r") as f:
        t = complete_steps(f)
        particles = f["particles"]
        frames = particles["frames"]
        samples = particles["samples"]["position"]["value"][:t] if "samples" in particles else None
        surfaces = {}
        for name, group in particles.items():
            if name in ("frames", "samples"):
                continue
            surfaces[name] = Surface(
                positions=group["position"]["value"][:t],
                connectivity=f["connectivity"][name][()],
                frames=group["frames"][()] if "frames" in group else np.arange(group["position"]["value"].shape[1]),
            )
        observables = {name: g["value"][:t] for name, g in f.get("observables", {}).items()}
        parameters = {name: _text_dataset(d) for name, d in f.get("parameters", {}).items()}
        return Run(
            path=str(path),
            steps=frames["position"]["step"][:t],
            times=frames["position"]["time"][:t],
            frames=frames["position"]["value"][:t],
            orientations=frames["orientation"]["value"][:t],
            samples=samples,
            surfaces=surfaces,
            observables=observables,
            parameters=parameters,
        )


_AXES = {"x": 0, "y": 1, "z": 2}


def _axis(spec: str):
    """'+x', '-z', 'y' -> (component, sign)."""
    sign = -1.0 if spec.startswith("-") else 1.0
    name = spec.lstrip("+-")
    if name not in _AXES:
        raise ValueError(f"axis '{spec}': expected x, y or z with an optional sign (+x, -z)")
    return _AXES[name], sign


def _group_positions(run: Run, group: str) -> np.ndarray:
    if group == "frames":
        return run.frames
    if group == "samples" and run.samples is not None:
        return run.samples
    if group in run.surfaces:
        return run.surfaces[group].positions
    raise ValueError(f"no particle group '{group}' (frames, samples, {', '.join(run.surfaces)})")


def tip_particles(run: Run, axis: str = "+x", group: str = "frames") -> np.ndarray:
    """Indices of the particles of `group` at the far end along `axis` ('+x', '-z', ...) in the first
    recorded step, within 1e-6 of the group's extent: the tip of a cantilever clamped at the other
    end, the jaws side of a pulled slab, the lowest points of a hanging organ (-z)."""
    c, sign = _axis(axis)
    x = sign * _group_positions(run, group)[0, :, c]
    span = x.max() - x.min()
    return np.nonzero(x >= x.max() - 1e-6 * max(span, 1e-30))[0]


def tip_displacement(run: Run, axis: str = "+x", group: str = "frames") -> np.ndarray:
    """Mean displacement of the tip particles (tip_particles) from the first recorded step, (T, 3) m."""
    tip = tip_particles(run, axis, group)
    x = _group_positions(run, group)
    return x[:, tip, :].mean(axis=1) - x[0, tip, :].mean(axis=0)


def field(run: Union[Run, str, Path], group: str, name: str) -> np.ndarray:
    """A per-particle field of the complete steps, (T, n[, 3[, 3]]), e.g. field(run, "samples",
    "cauchy_stress"); units in field_unit."""
    path = run.path if isinstance(run, Run) else run
    require_checksummed_format(path)
    with h5py.File(path, "r") as f:
        t = complete_steps(f)
        return f["particles"][group][name]["value"][:t]


def field_unit(run: Union[Run, str, Path], group: str, name: str) -> str:
    path = run.path if isinstance(run, Run) else run
    require_checksummed_format(path)
    with h5py.File(path, "r") as f:
        value = f["particles"][group][name]["value"]
        if "unit" not in value.attrs:
            return ""
        kind = h5py.check_string_dtype(value.attrs.get_id("unit").dtype)
        if kind is None or kind.length is None:
            raise FormatError(f"{path}: the unit of {value.name} is not fixed-length text")
        return _text(value.attrs["unit"])


def _pyplot():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "ps", "cairo"):
        try:
            matplotlib.use("Agg")
        except Exception:  # an interactive backend already in use: keep it
            pass
    import matplotlib.pyplot as plt

    return plt


def plot_tip(run: Union[Run, str, Path], component: Optional[int] = None, axis: str = "+x", group: str = "frames",
             out=None, ax=None):
    """Displacement of the far end along `axis` (tip_particles) over time, all components or one of
    0, 1, 2, in mm. Returns the figure."""
    plt = _pyplot()
    if not isinstance(run, Run):
        run = load(run)
    d = tip_displacement(run, axis, group) * 1e3
    fig = ax.figure if ax is not None else plt.figure(figsize=(6, 3.5))
    ax = ax or fig.add_subplot(1, 1, 1)
    names = "xyz"
    for c in range(3) if component is None else [component]:
        ax.plot(run.times, d[:, c], marker="." if len(run.times) < 50 else None, label=f"d{names[c]}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("displacement (mm)")
    ax.set_title(f"{Path(run.path).name}: {group} at the {axis} end ({len(tip_particles(run, axis, group))})")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    if out:
        fig.savefig(out, dpi=120)
    return fig


def plot_observables(run: Union[Run, str, Path], out=None):
    """Energies (J), Newton and CG iterations and the residual per written step. Returns the figure."""
    plt = _pyplot()
    if not isinstance(run, Run):
        run = load(run)
    o = run.observables
    fig, axes = plt.subplots(2, 2, figsize=(10, 6), sharex=True)
    for name in ("elastic_energy", "kinetic_energy", "external_potential", "total_energy"):
        if name in o:
            axes[0, 0].plot(run.times, o[name], label=name.replace("_", " "))
    axes[0, 0].set_ylabel("energy (J)")
    axes[0, 0].legend(fontsize=8)
    for ax, name, label in ((axes[0, 1], "newton_iterations", "Newton iterations"),
                            (axes[1, 0], "cg_iterations", "CG iterations")):
        if name in o:
            ax.plot(run.times, o[name], marker=".", drawstyle="steps-mid")
        ax.set_ylabel(label + " per step")
    if "residual" in o:
        solved = o["residual"] > 0  # step 0, the initial state, has no solve
        axes[1, 1].semilogy(run.times[solved], o["residual"][solved], marker=".")
    axes[1, 1].set_ylabel("residual")
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(Path(run.path).name)
    fig.tight_layout()
    if out:
        fig.savefig(out, dpi=120)
    return fig


def _scalar(values: np.ndarray, name: str):
    """Per-vertex scalar of a field: itself, the norm of a vector, the von Mises value of a tensor."""
    if values.ndim == 1:
        return values, name
    if values.ndim == 2:
        return np.linalg.norm(values, axis=1), f"|{name}|"
    dev = values - np.trace(values, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)
    return np.sqrt(1.5 * np.einsum("nij,nij->n", dev, dev)), f"von Mises of {name}"


def render(run: Union[Run, str, Path], out, step: Optional[int] = None, every: Optional[int] = None,
           field_name: str = "displacement", fps: int = 10, dpi: int = 100):
    """Draws the deformed surfaces of every object coloured by a per-vertex field (a scalar; the norm
    of a vector; the von Mises value of a tensor), with a colour bar and its unit, the time, and a
    camera that frames all objects over all drawn steps. `out` ending in .png draws one step (`step`,
    default the last); .gif (Pillow) or .mp4 (ffmpeg) draws every `every`-th step (default 1) as a
    movie. Objects without the field are drawn grey. Returns the number of frames drawn."""
    plt = _pyplot()
    import matplotlib
    from matplotlib import animation, cm, colors
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    if not isinstance(run, Run):
        run = load(run)
    if not run.surfaces:
        raise ValueError(f"{run.path}: no surfaces to draw")
    out = Path(out)
    movie = out.suffix.lower() in (".gif", ".mp4")
    if not movie and out.suffix.lower() != ".png":
        raise ValueError(f"{out}: expected .png, .gif or .mp4")
    if movie:
        steps = list(range(0, run.step_count, max(int(every or 1), 1)))
        if steps[-1] != run.step_count - 1:
            steps.append(run.step_count - 1)
    else:
        k = run.step_count - 1 if step is None else int(step)
        if not -run.step_count <= k < run.step_count:
            raise ValueError(f"step {step} out of range: {run.step_count} steps written")
        steps = [k % run.step_count]

    values, unit, label = {}, "", field_name
    for name in run.surfaces:
        try:
            raw = field(run, name, field_name)
        except KeyError:
            continue
        values[name] = np.stack([_scalar(raw[k], field_name)[0] for k in range(run.step_count)])
        label = _scalar(raw[0], field_name)[1]
        unit = field_unit(run, name, field_name)
    if not values:
        raise ValueError(f"{run.path}: no surface has the field '{field_name}'")
    drawn = np.concatenate([v[steps].ravel() for v in values.values()])
    norm = colors.Normalize(vmin=float(drawn.min()), vmax=float(drawn.max()) if drawn.max() > drawn.min() else float(drawn.min()) + 1e-30)
    cmap = matplotlib.colormaps["viridis"]

    points = np.concatenate([s.positions[steps].reshape(-1, 3) for s in run.surfaces.values()])
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1e-12) * 1.05

    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.7,
                 label=f"{label} ({unit})" if unit else label)

    def draw(k):
        ax.clear()
        for name, surface in run.surfaces.items():
            x = surface.positions[k]
            faces = x[surface.connectivity]
            if name in values:
                face_values = values[name][k][surface.connectivity].mean(axis=1)
                facecolors = cmap(norm(face_values))
            else:
                facecolors = (0.7, 0.7, 0.7, 1.0)
            ax.add_collection3d(Poly3DCollection(faces, facecolors=facecolors, edgecolors=(0, 0, 0, 0.15),
                                                 linewidths=0.2))
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
        ax.view_init(elev=20, azim=-60)
        ax.set_title(f"{Path(run.path).stem}   t = {run.times[k]:.4g} s   (step {int(run.steps[k])})")

    if not movie:
        draw(steps[0])
        fig.savefig(out, dpi=dpi, bbox_inches="tight")
    else:
        writer = animation.PillowWriter(fps=fps) if out.suffix.lower() == ".gif" else animation.FFMpegWriter(fps=fps)
        with writer.saving(fig, str(out), dpi=dpi):
            for k in steps:
                draw(k)
                writer.grab_frame()
    plt.close(fig)
    return len(steps)


_X_KEYS = ("dofs", "nominal_dofs", "dof")
_Y_KEYS = ("tip_displacement", "tip_deflection", "deflection", "tip_z")
_GROUP_KEYS = ("method", "label", "discretisation", "elements", "series")


def _deflection(value) -> float:
    """|tip deflection| of a study record: a scalar, or the largest-magnitude component of the tip
    displacement vector (dz for the cantilever, which bends under its weight along -z)."""
    v = np.atleast_1d(np.asarray(value, dtype=float))
    return float(np.abs(v).max())


def read_json_lines(source: Union[str, Path, Iterable[str]]) -> list:
    """JSON objects, one a line (blank lines and non-JSON lines skipped)."""
    lines = Path(source).read_text().splitlines() if isinstance(source, (str, Path)) else list(source)
    out = []
    for line in lines:
        line = line.strip()
        if not line.startswith("{"):
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return out


def plot_convergence(source, out=None, ax=None, reference: Optional[float] = None):
    """The paper's Figure 3: tip deflection at equilibrium against degrees of freedom, one line per
    method, from the JSON lines of `fascia study beam --json` (keys dofs, tip_displacement [dx, dy,
    dz] in m, method, converged; records that did not converge are left out), with an optional
    reference deflection (m) as a dashed line. Returns the figure."""
    plt = _pyplot()
    records = source if isinstance(source, list) and (not source or isinstance(source[0], dict)) else read_json_lines(source)
    series: Dict[str, list] = {}
    for r in records:
        x = next((r[k] for k in _X_KEYS if k in r), None)
        y = next((r[k] for k in _Y_KEYS if k in r), None)
        if x is None or y is None or r.get("converged") is False:
            continue
        label = next((str(r[k]) for k in _GROUP_KEYS if k in r), "run")
        series.setdefault(label, []).append((float(x), _deflection(y)))
    if not series:
        raise ValueError("no converged records with dofs and tip_displacement")
    fig = ax.figure if ax is not None else plt.figure(figsize=(6, 4))
    ax = ax or fig.add_subplot(1, 1, 1)
    for label, points in sorted(series.items()):
        points.sort()
        ax.plot([p[0] for p in points], [p[1] for p in points], marker="o", label=label)
    if reference is not None:
        ax.axhline(abs(reference), color="k", linestyle="--", linewidth=1, label=f"reference {abs(reference):.4g} m")
    ax.set_xscale("log")
    ax.set_xlabel("degrees of freedom")
    ax.set_ylabel("tip deflection (m)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    if out:
        fig.savefig(out, dpi=120)
    return fig


def summary(run: Run, axis: str = "+x", group: str = "frames") -> dict:
    s = {"file": run.path, "steps": run.step_count, "frames": int(run.frames.shape[1]),
         "surfaces": sorted(run.surfaces)}
    if run.step_count:
        s["time"] = [float(run.times[0]), float(run.times[-1])]
        s["tip"] = {"axis": axis, "group": group, "displacement": tip_displacement(run, axis, group)[-1].tolist()}
    for name in ("newton_iterations", "cg_iterations"):
        if name in run.observables:
            s[name + "_total"] = int(np.sum(run.observables[name]))
    return s


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("file", nargs="?", help="trajectory (HDF5)")
    p.add_argument("--summary", action="store_true", help="print a JSON summary (the default without other output)")
    p.add_argument("--tip", metavar="PNG", help="plot the displacement of the far end (--tip-axis) over time")
    p.add_argument("--tip-axis", default="+x", help="which end: +x, -x, +y, -y, +z, -z (default +x; write --tip-axis=-z)")
    p.add_argument("--tip-group", default="frames", help="frames, samples or a surface (default frames)")
    p.add_argument("--observables", metavar="PNG", help="plot energies, iterations and residual per step")
    p.add_argument("--render", metavar="OUT", help="draw the deformed surfaces: .png (one step), .gif or .mp4")
    p.add_argument("--step", type=int, help="--render .png: the step index (default the last; negative from the end)")
    p.add_argument("--every", type=int, help="--render .gif/.mp4: every N-th written step (default 1)")
    p.add_argument("--field", default="displacement", help="--render: the colouring field (default displacement)")
    p.add_argument("--convergence", metavar="JSONL", help="plot the convergence figure from study lines")
    p.add_argument("--out", metavar="PNG", default="convergence.png", help="output of --convergence")
    p.add_argument("--reference", type=float, help="--convergence: a reference tip deflection (m), drawn dashed")
    args = p.parse_args(argv)
    if args.file is None and not args.convergence:
        p.error("give a trajectory file, or --convergence STUDY.jsonl")

    def error(message, code):
        print(f"fascia_post: error: {message}", file=sys.stderr)
        return code

    run = None
    if args.file is not None:
        try:
            run = load(args.file)
        except FormatError as e:
            return error(e, 65)
        # Unreadable, not HDF5, not a fascia trajectory, or corrupt: h5py reports HDF5's errors as
        # OSError, KeyError, ValueError or RuntimeError, and a corrupt layout surfaces as objects of
        # the wrong kind or shape (TypeError, IndexError, AttributeError).
        except (OSError, KeyError, ValueError, RuntimeError, TypeError, IndexError, AttributeError) as e:
            return error(f"{args.file}: not a readable fascia trajectory: {type(e).__name__}: {e}", 65)
    try:
        if run is not None:
            if args.summary or not (args.tip or args.observables or args.render):
                print(json.dumps(summary(run, args.tip_axis, args.tip_group)))
            if args.tip:
                plot_tip(run, axis=args.tip_axis, group=args.tip_group, out=args.tip)
            if args.observables:
                plot_observables(run, out=args.observables)
            if args.render:
                render(run, args.render, step=args.step, every=args.every, field_name=args.field)
        if args.convergence:
            plot_convergence(args.convergence, out=args.out, reference=args.reference)
    except (ValueError, KeyError) as e:  # a field, step or axis that the file does not have
        return error(e, 65)
    except OSError as e:  # the picture or movie could not be written
        return error(e, 74)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
