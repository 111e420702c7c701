"""The time series of a trajectory, for bitwise comparisons of runs (resume, Slurm requeue)."""
import h5py


def rows(path):
    """Every time series of a trajectory (wall_time aside), as arrays of its complete rows."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if (isinstance(obj, h5py.Group) and "step" in obj and "value" in obj and "wall_time" not in name
                    and not name.startswith("checkpoint")):
                for part in ("step", "time", "value"):
                    out[f"{name}/{part}"] = obj[part][()]
        f.visititems(visit)
    return out
