"""Writes the binary seeds of the fuzz corpus (tests/fuzz/corpus/{nii,nrrd,h5,msh}): small valid
files of each format, so that the fuzzers start from inputs the readers accept. The text seeds
(scenes, VTK, OBJ, STL) are copies of shipped files. Run from the repository root:
    python3 tests/fuzz/make_seeds.py"""
import ctypes
import ctypes.util
import struct
from pathlib import Path

import h5py
import numpy as np

OUT = Path(__file__).resolve().parent / "corpus"


def nifti1(path, shape=(4, 3, 2)):
    """A NIfTI-1 single file (.nii) of int16 labels, 1 mm voxels, a qform."""
    hdr = bytearray(348)
    struct.pack_into("<i", hdr, 0, 348)
    struct.pack_into("<8h", hdr, 40, 3, *shape, 1, 1, 1, 1)
    struct.pack_into("<hh", hdr, 70, 4, 16)  # datatype int16, bitpix
    struct.pack_into("<8f", hdr, 76, 1, 1, 1, 1, 0, 0, 0, 0)  # pixdim (qfac 1), mm
    struct.pack_into("<f", hdr, 108, 352)  # vox_offset
    struct.pack_into("<f", hdr, 112, 0)  # scl_slope: none
    hdr[123] = 2  # xyzt_units: mm
    struct.pack_into("<hh", hdr, 252, 1, 0)  # qform_code scanner, sform_code none
    hdr[344:348] = b"n+1\0"
    labels = np.arange(np.prod(shape), dtype="<i2") % 3
    path.write_bytes(bytes(hdr) + b"\0\0\0\0" + labels.tobytes())


def nrrd(path, shape=(4, 3, 2)):
    header = ("NRRD0004\ntype: uint8\ndimension: 3\nsizes: %d %d %d\nencoding: raw\nspace: left-posterior-superior\n"
              "space directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (0,0,0)\n\n" % shape)
    labels = (np.arange(np.prod(shape)) % 3).astype(np.uint8)
    path.write_bytes(header.encode() + labels.tobytes())


def text(value):
    return np.array(value.encode() + b"\0", dtype=f"S{len(value) + 1}")


HDF5 = ctypes.CDLL(ctypes.util.find_library("hdf5_serial") or "libhdf5_serial.so.103")


def compact_groups_file(path):
    """An HDF5 file in fascia's format (engine/io/hdf5_format.hpp): HDF5 1.8, checksummed metadata,
    links kept in their groups' object headers."""
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_libver_bounds(h5py.h5f.LIBVER_V18, h5py.h5f.LIBVER_V18)
    # The root group's 6 links stay compact under HDF5's defaults (up to 8); h5py cannot set its
    # phase change.
    return h5py.File(h5py.h5f.create(str(path).encode(), h5py.h5f.ACC_TRUNC, fapl=fapl))


def group(parent, path):
    """The group at path under parent, created with compact links where missing."""
    for name in path.split("/"):
        if name not in parent:
            gcpl = h5py.h5p.create(h5py.h5p.GROUP_CREATE)
            # h5py has no binding for it: HDF5's own, in the library h5py loaded.
            if HDF5.H5Pset_link_phase_change(ctypes.c_int64(gcpl.id), 65535, 65535) < 0:
                raise RuntimeError("H5Pset_link_phase_change failed")
            h5py.h5g.create(parent.id, name.encode(), gcpl=gcpl)
        parent = parent[name]
    return parent


def trajectory(path, frames=2, rows=2):
    """fascia's trajectory layout (io/trajectory.hpp), a few frames and rows, with a checkpoint."""
    with compact_groups_file(path) as f:
        h5md = group(f, "h5md")
        h5md.attrs["version"] = np.array([1, 1], dtype="<i4")
        creator = group(h5md, "creator")
        creator.attrs["name"] = text("fascia")
        creator.attrs["version"] = text("0.1.0")
        for name, width, unit in (("position", 3, "m"), ("orientation", 4, "")):
            g = group(f, f"particles/frames/{name}")
            g["step"] = np.arange(rows, dtype="<i4")
            g["time"] = np.linspace(0, 0.01, rows)
            g["value"] = np.zeros((rows, frames, width))
            if unit:
                g["value"].attrs["unit"] = text(unit)
        g = group(f, "observables/elastic_energy")
        g["step"] = np.arange(rows, dtype="<i4")
        g["time"] = np.linspace(0, 0.01, rows)
        g["value"] = np.zeros(rows)
        f["connectivity/surface"] = np.array([[0, 1, 0]], dtype="<i4")
        for name, value in (("scene", "fascia: 1\n"), ("scene_file", "s.yaml"), ("command_line", "fascia run s.yaml"),
                            ("environment", "{}"), ("version", "0.1.0")):
            f["parameters/" + name] = text(value)
        c = group(f, "checkpoint")
        c.attrs["format"] = np.int32(6)  # kCheckpointFormat
        c.attrs["frames"] = np.int32(frames)
        c["scene"] = text("scene")
        c["build"] = text("build")
        c["commit"] = np.array([1, 1], dtype="<i8")
        for slot in ("slot_0", "slot_1"):
            s = group(c, slot)
            s["counters"] = np.array([1, 1, rows, 1], dtype="<i8")
            s["clock"] = np.array([0.01, 0.01])
            s["tangent"] = np.array([1, 0, 3, 20, 2], dtype="<i8")  # a kept tangent (3 solves, 20 iterations served, shift step 2): its two states follow
            s["tangent_clock"] = np.array([0.01, 1.0])
            s["controller"] = np.array([0.01, 0.0])  # step size, after a rejection
            s["controller_counts"] = np.array([1, 0, 0, 0, 0, 0], dtype="<i8")
            s["history"] = np.array([0.01])  # a held path history: its state follows
            for prefix in ("", "tangent_start_", "tangent_", "history_"):
                s[prefix + "positions"] = np.zeros((frames, 3))
                s[prefix + "orientations"] = np.tile([1.0, 0, 0, 0], (frames, 1))
                s[prefix + "velocities"] = np.zeros((frames, 6))


def gmsh(path):
    path.write_text("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n10 0 0 0\n11 1 0 0\n12 0 1 0\n13 0 0 1\n"
                    "$EndNodes\n$Elements\n2\n1 2 2 0 1 10 11 12\n2 4 2 0 1 10 11 12 13\n$EndElements\n")


if __name__ == "__main__":
    nifti1(OUT / "nii" / "labels.nii")
    nrrd(OUT / "nrrd" / "labels.nrrd")
    trajectory(OUT / "h5" / "trajectory.h5")
    gmsh(OUT / "msh" / "tetrahedron.msh")
