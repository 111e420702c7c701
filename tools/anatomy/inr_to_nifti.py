#!/usr/bin/env python3
"""Convert an INRIMAGE-4 label image (.inr, .inr.gz; the format of CGAL's data sets) to NIfTI-1
(.nii or .nii.gz), which fascia reads as a scene object's `image`.

    inr_to_nifti.py INPUT OUTPUT [--crop MARGIN]

INPUT is a file, or ARCHIVE.tar.gz:MEMBER for a member of a tar archive (Debian's libcgal-demo
ships /usr/share/doc/libcgal-dev/data.tar.gz holding data/images/liver.inr.gz, a segmented liver
CT). --crop keeps the bounding box of the nonzero voxels widened by MARGIN voxels.

INRIMAGE-4: a text header of 256-byte blocks ("#INRIMAGE-4#{", KEY=VALUE lines, "##}") then the
voxels, x fastest. Keys read: XDIM, YDIM, ZDIM, VDIM (1), TYPE (unsigned fixed | signed fixed),
PIXSIZE (8 or 16 bits), CPU (decm, alpha, pc: little endian; sun, sgi: big endian), VX, VY, VZ
(voxel size, mm) and TX, TY, TZ (origin, mm; 0 when absent). The format has no orientation: voxel
(i, j, k) lies at (TX + i VX, TY + j VY, TZ + k VZ) mm, as CGAL places it; the NIfTI file says so
through its sform (code 2, aligned) and qform (code 2, identity rotation), in millimetres.

Exit codes: 0 done, 64 usage, 65 not a label image or a malformed file, 66 missing input, 74 the
output cannot be written (nothing is left half-written: the file is renamed into place).
Needs only the Python standard library.
"""

import argparse
import gzip
import os
import struct
import sys
import tarfile


class BadImage(Exception):
    pass


def read_input(spec):
    """The bytes of INPUT (gunzipped when gzip-compressed)."""
    member = None
    path = spec
    if not os.path.exists(spec) and ":" in spec:
        path, member = spec.rsplit(":", 1)
    if not os.path.exists(path):
        raise FileNotFoundError(path)
    if member is not None:
        with tarfile.open(path) as archive:
            try:
                data = archive.extractfile(member)
            except KeyError:
                raise BadImage(f"{path} holds no member '{member}'")
            if data is None:
                raise BadImage(f"{path}: '{member}' is not a regular file")
            raw = data.read()
    else:
        with open(path, "rb") as f:
            raw = f.read()
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError) as e:
            raise BadImage(f"{spec}: truncated or corrupt gzip data ({e})")
    return raw


def parse_inr(raw, name):
    """The image's description (dims, spacing, origin, bytes per voxel, signedness) and its voxels."""
    if not raw.startswith(b"#INRIMAGE-4#{"):
        raise BadImage(f"{name}: not an INRIMAGE-4 file (no '#INRIMAGE-4#{{' at its start)")
    end = raw.find(b"##}")
    if end < 0:
        raise BadImage(f"{name}: the INRIMAGE header does not end ('##}}' missing)")
    header_size = ((end + 4 + 255) // 256) * 256
    fields = {}
    for line in raw[:end].decode("ascii", "replace").splitlines()[1:]:
        if "=" in line and not line.startswith("#"):
            k, v = line.split("=", 1)
            fields[k.strip()] = v.strip()

    def integer(key, default=None):
        if key not in fields:
            if default is None:
                raise BadImage(f"{name}: the INRIMAGE header lacks {key}")
            return default
        try:
            return int(fields[key])
        except ValueError:
            raise BadImage(f"{name}: {key}={fields[key]} is not an integer")

    def real(key, default):
        try:
            return float(fields.get(key, default))
        except ValueError:
            raise BadImage(f"{name}: {key}={fields[key]} is not a number")

    dims = [integer("XDIM"), integer("YDIM"), integer("ZDIM")]
    if min(dims) < 1:
        raise BadImage(f"{name}: dimensions {dims} must be positive")
    if integer("VDIM", 1) != 1:
        raise BadImage(f"{name}: VDIM={fields['VDIM']}: a label image has one value per voxel")
    kind = fields.get("TYPE", "")
    if kind not in ("unsigned fixed", "signed fixed"):
        raise BadImage(f"{name}: TYPE={kind}: a label image holds integers (unsigned fixed or signed fixed)")
    bits = fields.get("PIXSIZE", "8 bits").split()[0]
    if bits not in ("8", "16"):
        raise BadImage(f"{name}: PIXSIZE={fields.get('PIXSIZE')}: 8 or 16 bits expected")
    cpu = fields.get("CPU", "decm")
    big_endian = cpu in ("sun", "sgi")
    if cpu not in ("decm", "alpha", "pc", "sun", "sgi"):
        raise BadImage(f"{name}: CPU={cpu}: unknown byte order")
    spacing = [real("VX", 1), real("VY", 1), real("VZ", 1)]
    if min(spacing) <= 0:
        raise BadImage(f"{name}: voxel size {spacing} must be positive")
    origin = [real("TX", 0), real("TY", 0), real("TZ", 0)]
    size = int(bits) // 8
    count = dims[0] * dims[1] * dims[2]
    voxels = raw[header_size:header_size + count * size]
    if len(voxels) < count * size:
        raise BadImage(f"{name}: truncated: {len(voxels)} bytes of voxels, {count * size} expected")
    if size == 2 and big_endian:  # NIfTI is written little endian
        swapped = bytearray(voxels)
        swapped[0::2], swapped[1::2] = voxels[1::2], voxels[0::2]
        voxels = bytes(swapped)
    return dict(dims=dims, spacing=spacing, origin=origin, size=size, signed=kind == "signed fixed"), voxels


def crop(image, voxels, margin):
    """The bounding box of the nonzero voxels widened by margin (clamped to the image)."""
    nx, ny, nz = image["dims"]
    size = image["size"]
    zero = bytes(size)
    row_bytes = nx * size
    lo, hi = [nx, ny, nz], [-1, -1, -1]
    for k in range(nz):
        for j in range(ny):
            start = (k * ny + j) * row_bytes
            row = voxels[start:start + row_bytes]
            if row == zero * nx:
                continue
            first = next(i for i in range(nx) if row[i * size:(i + 1) * size] != zero)
            last = next(i for i in range(nx - 1, -1, -1) if row[i * size:(i + 1) * size] != zero)
            lo = [min(lo[0], first), min(lo[1], j), min(lo[2], k)]
            hi = [max(hi[0], last), max(hi[1], j), max(hi[2], k)]
    if hi[0] < 0:
        raise BadImage("the image holds no nonzero voxel: nothing to crop to")
    lo = [max(0, lo[a] - margin) for a in range(3)]
    hi = [min(image["dims"][a] - 1, hi[a] + margin) for a in range(3)]
    out = bytearray()
    for k in range(lo[2], hi[2] + 1):
        for j in range(lo[1], hi[1] + 1):
            start = ((k * ny + j) * nx + lo[0]) * size
            out += voxels[start:start + (hi[0] - lo[0] + 1) * size]
    cropped = dict(image)
    cropped["dims"] = [hi[a] - lo[a] + 1 for a in range(3)]
    cropped["origin"] = [image["origin"][a] + lo[a] * image["spacing"][a] for a in range(3)]
    return cropped, bytes(out)


def nifti_header(image):
    """The 348-byte NIfTI-1 header and its 4-byte extension flag (none) for a single file."""
    nx, ny, nz = image["dims"]
    dx, dy, dz = image["spacing"]
    ox, oy, oz = image["origin"]
    datatype, bitpix = {(1, False): (2, 8), (1, True): (256, 8), (2, False): (512, 16), (2, True): (4, 16)}[
        (image["size"], image["signed"])]
    header = struct.pack(
        "<i10s18sihcc8h3f4h8f3fhcc4f2i80s24s2h6f4f4f4f16s4s",
        348, b"", b"", 0, 0, b"r", b"\0",
        3, nx, ny, nz, 1, 1, 1, 1,
        0.0, 0.0, 0.0,
        0, datatype, bitpix, 0,
        1.0, dx, dy, dz, 0.0, 0.0, 0.0, 0.0,
        352.0, 1.0, 0.0,  # vox_offset, scl_slope 1 and scl_inter 0: the stored values are the labels
        0, b"\0", b"\x02",  # slice_end, slice_code, xyzt_units = millimetres
        0.0, 0.0, 0.0, 0.0, 0, 0,
        b"label image converted from INRIMAGE-4 by fascia tools/anatomy/inr_to_nifti.py", b"",
        2, 2,  # qform_code, sform_code: aligned to another file (the INR's own axes)
        0.0, 0.0, 0.0, ox, oy, oz,  # identity rotation, origin (mm)
        dx, 0.0, 0.0, ox,
        0.0, dy, 0.0, oy,
        0.0, 0.0, dz, oz,
        b"labels", b"n+1\0")
    assert len(header) == 348
    return header + b"\0\0\0\0"


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input", help="INR file (.inr, .inr.gz) or ARCHIVE.tar.gz:MEMBER")
    parser.add_argument("output", help="NIfTI-1 file (.nii or .nii.gz)")
    parser.add_argument("--crop", type=int, metavar="MARGIN", help="crop to the nonzero voxels plus MARGIN voxels")
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:
        return 64 if e.code else 0
    if args.crop is not None and args.crop < 0:
        print("inr_to_nifti: error: --crop takes a margin >= 0", file=sys.stderr)
        return 64
    try:
        raw = read_input(args.input)
        image, voxels = parse_inr(raw, args.input)
        if args.crop is not None:
            image, voxels = crop(image, voxels, args.crop)
    except FileNotFoundError as e:
        print(f"inr_to_nifti: error: {e.filename or args.input}: no such file", file=sys.stderr)
        return 66
    except (BadImage, tarfile.TarError) as e:
        print(f"inr_to_nifti: error: {e}", file=sys.stderr)
        return 65
    data = nifti_header(image) + voxels
    if args.output.endswith(".gz"):
        data = gzip.compress(data, compresslevel=9, mtime=0)  # reproducible bytes
    tmp = args.output + ".tmp"
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, args.output)
    except OSError as e:
        if os.path.exists(tmp):
            os.remove(tmp)
        print(f"inr_to_nifti: error: cannot write {args.output}: {e.strerror}", file=sys.stderr)
        return 74
    print(f"inr_to_nifti: {args.output}: {image['dims'][0]} x {image['dims'][1]} x {image['dims'][2]} voxels of "
          f"{image['spacing'][0]:g} x {image['spacing'][1]:g} x {image['spacing'][2]:g} mm, origin "
          f"({image['origin'][0]:g}, {image['origin'][1]:g}, {image['origin'][2]:g}) mm")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
