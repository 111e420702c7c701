"""Corrupt trajectories: a run's output with bytes overwritten at random offsets of its HDF5
metadata (object headers, B-trees, heaps, the superblock: everything but the raw data of the
chunks, which only changes numbers) and truncated copies, read by `fascia info`, `fascia run
--resume`, `fascia render` and tools/post. Every reader ends with a documented exit code, never
a signal or a hang, and a refusal names the file. FASCIA_FUZZ_RUNS and FASCIA_FUZZ_SEED choose
how many copies and which bytes."""
import os
import random
import shutil
import subprocess
import sys

import h5py
import pytest

SCENE = ["scenes/tool_pull.yaml", "--set", "run.duration=0.03 s", "--threads", "1"]


def metadata_ranges(path):
    """[start, end) byte ranges of the file that hold no chunk or contiguous raw data."""
    raw = []
    with h5py.File(path, "r") as f:
        def visit(_, obj):
            if not isinstance(obj, h5py.Dataset):
                return
            if obj.chunks:
                for i in range(obj.id.get_num_chunks()):
                    c = obj.id.get_chunk_info(i)
                    raw.append((c.byte_offset, c.byte_offset + c.size))
            elif obj.id.get_offset() is not None:
                raw.append((obj.id.get_offset(), obj.id.get_offset() + obj.id.get_storage_size()))
        f.visititems(visit)
        size = f.id.get_filesize()
    ranges, at = [], 0
    for a, b in sorted(raw):
        if a > at:
            ranges.append((at, a))
        at = max(at, b)
    if at < size:
        ranges.append((at, size))
    return ranges


def corrupt(data, ranges, rng):
    b = bytearray(data)
    if rng.randrange(10) == 0:
        return bytes(b[:rng.randrange(len(b))])  # a truncated copy
    for _ in range(rng.randint(1, 8)):
        a, e = rng.choice(ranges)
        b[rng.randrange(a, e)] = rng.randrange(256)
    return bytes(b)


def check(r, path, allowed, what):
    context = f"{what} on {path.name}: exit {r.returncode}\nstderr:\n{r.stderr[-2000:]}"
    assert r.returncode >= 0, context  # no signal
    assert r.returncode in allowed, context
    if r.returncode != 0:
        assert path.name in r.stderr, context


def test_corrupt_outputs_are_refused_with_documented_codes(fascia_bin, root, tmp_path):
    runs = int(os.environ.get("FASCIA_FUZZ_RUNS", "40"))
    rng = random.Random(int(os.environ.get("FASCIA_FUZZ_SEED", "20261124")))
    good = tmp_path / "good.h5"
    r = subprocess.run([fascia_bin, "run", *SCENE, "-o", str(good)], cwd=root, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    data = good.read_bytes()
    ranges = metadata_ranges(good)
    post = [sys.executable, str(root / "tools" / "post" / "fascia_post.py")]
    codes = {}
    for run in range(runs):
        path = tmp_path / f"corrupt_{run}.h5"
        path.write_bytes(corrupt(data, ranges, rng))
        commands = [("info", [fascia_bin, "info", str(path)], {0, 65}),
                    ("info --json", [fascia_bin, "info", str(path), "--json"], {0, 65}),
                    ("fascia_post --summary", [*post, str(path), "--summary"], {0, 65}),
                    # A continued run may fail to converge from a corrupt state (1) or meet a
                    # write error (74).
                    ("run --resume", [fascia_bin, "run", *SCENE, "-o", str(path), "--resume"], {0, 1, 65, 74})]
        if run % 8 == 0:
            commands.append(("render", [fascia_bin, "render", str(path), "-o", str(tmp_path / "r.png")], {0, 65}))
        for what, args, allowed in commands:
            try:
                r = subprocess.run(args, cwd=root, capture_output=True, text=True, errors="replace", timeout=120)
            except subprocess.TimeoutExpired:
                pytest.fail(f"{what} on {path.name} hangs")
            check(r, path, allowed, what)
            codes.setdefault(what, set()).add(r.returncode)
        path.unlink()
    # The corruptions reach the readers: some copies are refused.
    assert any(65 in c for c in codes.values()), codes


def test_files_without_metadata_checksums_are_refused_clearly(fascia_bin, root, tmp_path):
    """A run's file copied into HDF5's default format (superblock version 0, no checksums), as
    older fascia versions wrote it: refused with exit 65 by every reader, naming the file and the
    format, before HDF5 decodes it; h5py still reads it."""
    good = tmp_path / "good.h5"
    r = subprocess.run([fascia_bin, "run", *SCENE, "-o", str(good)], cwd=root, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert good.read_bytes()[8] == 2  # superblock version 2: the HDF5 1.8 format
    old = tmp_path / "old.h5"
    with h5py.File(good, "r") as src, h5py.File(old, "w", libver="earliest") as dst:
        for name in src:
            src.copy(src[name], dst, name=name)
        for key, value in src.attrs.items():
            dst.attrs[key] = value
    assert old.read_bytes()[8] == 0
    post = [sys.executable, str(root / "tools" / "post" / "fascia_post.py")]
    for what, args in (("info", [fascia_bin, "info", str(old)]),
                       ("fascia_post --summary", [*post, str(old), "--summary"]),
                       ("run --resume", [fascia_bin, "run", *SCENE, "-o", str(old), "--resume"])):
        r = subprocess.run(args, cwd=root, capture_output=True, text=True, timeout=120)
        context = f"{what}: exit {r.returncode}\nstderr:\n{r.stderr[-2000:]}"
        assert r.returncode == 65, context
        assert f"{old}: HDF5 superblock version 0, a format without metadata checksums" in r.stderr, context
        if what == "run --resume":
            assert "cannot resume" in r.stderr, context
    with h5py.File(old, "r") as f:
        assert f["particles/frames/position/value"].shape[0] == 4
