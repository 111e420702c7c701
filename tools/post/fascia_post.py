"""Post-processing of fascia trajectories (HDF5, H5MD layout) with h5py, numpy and matplotlib.

    import fascia_post as fp
    run = fp.load("tool_pull.h5")
    run.times, run.frames.shape                 # (T,), (T, N, 3)
    run.observables["newton_iterations"]       # (T,)
    fp.plot_tip(run, out="tip.png")             # tip displacement over time
    fp.plot_convergence("study.jsonl", out="convergence.png")   # `fascia study beam --json` lines

Only complete steps are returned: a file from a run killed with SIGKILL keeps preallocated rows
whose `step` is -1 after the last complete step; they are left out (see complete_steps).

Command line:  python3 tools/post/fascia_post.py RUN.h5 [--tip tip.png] [--summary]
"""
from __future__ import annotations

import argparse
import json
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
        parameters = {name: _text(d[()]) for name, d in f.get("parameters", {}).items()}
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


def tip_frames(run: Run, axis: int = 0) -> np.ndarray:
    """Frames at the far end of the object along `axis` in the first recorded step (the tip of a
    cantilever clamped at the low end)."""
    x = run.frames[0, :, axis]
    span = x.max() - x.min()
    return np.nonzero(x >= x.max() - 1e-9 * max(span, 1e-30))[0]


def tip_displacement(run: Run, axis: int = 0) -> np.ndarray:
    """Mean displacement of the tip frames from the first recorded step, (T, 3) m."""
    tip = tip_frames(run, axis)
    return run.frames[:, tip, :].mean(axis=1) - run.frames[0, tip, :].mean(axis=0)


def _pyplot():
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "ps", "cairo"):
        try:
            matplotlib.use("Agg")
        except Exception:  # an interactive backend already in use: keep it
            pass
    import matplotlib.pyplot as plt

    return plt


def plot_tip(run: Union[Run, str, Path], component: Optional[int] = None, axis: int = 0, out=None, ax=None):
    """Tip displacement over time (all components, or one of 0, 1, 2), in mm. Returns the figure."""
    plt = _pyplot()
    if not isinstance(run, Run):
        run = load(run)
    d = tip_displacement(run, axis) * 1e3
    fig = ax.figure if ax is not None else plt.figure(figsize=(6, 3.5))
    ax = ax or fig.add_subplot(1, 1, 1)
    names = "xyz"
    for c in range(3) if component is None else [component]:
        ax.plot(run.times, d[:, c], marker="." if len(run.times) < 50 else None, label=f"tip {names[c]}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("displacement (mm)")
    ax.set_title(Path(run.path).name)
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    if out:
        fig.savefig(out, dpi=120)
    return fig


_X_KEYS = ("dofs", "nominal_dofs", "dof")
_Y_KEYS = ("tip_deflection", "deflection", "tip_displacement", "tip_z")
_GROUP_KEYS = ("method", "label", "discretisation", "elements", "series")


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


def plot_convergence(source, out=None, ax=None):
    """The paper's Figure 3: tip deflection at equilibrium against degrees of freedom, one line per
    method, from the JSON lines of `fascia study beam --json` (keys: dofs, tip_deflection and
    method; a few synonyms accepted). Returns the figure."""
    plt = _pyplot()
    records = source if isinstance(source, list) and (not source or isinstance(source[0], dict)) else read_json_lines(source)
    series: Dict[str, list] = {}
    for r in records:
        x = next((r[k] for k in _X_KEYS if k in r), None)
        y = next((r[k] for k in _Y_KEYS if k in r), None)
        if x is None or y is None:
            continue
        label = next((str(r[k]) for k in _GROUP_KEYS if k in r), "run")
        series.setdefault(label, []).append((float(x), abs(float(y))))
    if not series:
        raise ValueError("no records with dofs and tip_deflection")
    fig = ax.figure if ax is not None else plt.figure(figsize=(6, 4))
    ax = ax or fig.add_subplot(1, 1, 1)
    for label, points in sorted(series.items()):
        points.sort()
        ax.plot([p[0] for p in points], [p[1] for p in points], marker="o", label=label)
    ax.set_xscale("log")
    ax.set_xlabel("degrees of freedom")
    ax.set_ylabel("tip deflection (m)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    if out:
        fig.savefig(out, dpi=120)
    return fig


def summary(run: Run) -> dict:
    s = {"file": run.path, "steps": run.step_count, "frames": int(run.frames.shape[1])}
    if run.step_count:
        s["time"] = [float(run.times[0]), float(run.times[-1])]
        s["tip_displacement"] = tip_displacement(run)[-1].tolist()
    for name in ("newton_iterations", "cg_iterations"):
        if name in run.observables:
            s[name + "_total"] = int(np.sum(run.observables[name]))
    return s


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("file", help="trajectory (HDF5)")
    p.add_argument("--tip", metavar="PNG", help="plot the tip displacement over time")
    p.add_argument("--convergence", metavar="JSONL", help="plot the convergence figure from study lines")
    p.add_argument("--out", metavar="PNG", default="convergence.png", help="output of --convergence")
    args = p.parse_args(argv)
    run = load(args.file)
    print(json.dumps(summary(run)))
    if args.tip:
        plot_tip(run, out=args.tip)
    if args.convergence:
        plot_convergence(args.convergence, out=args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
