#!/usr/bin/env python3
"""A clinical-size liver mask for timing `lamina validate` (docs/validation.md, "A clinical-size
mask"): the TotalSegmentator example liver (3 mm, tests/data) resampled, nearest neighbour,
onto a 512 x 512 x 129 grid of 0.57 x 0.57 x 1.6 mm centred on the organ, the size and spacing of
an abdominal CT. Its shape is the 3 mm mask's; its voxel count (2.1 million inside, 33.8 million
in all) and anisotropy are a clinical scan's. Plain Python (gzip, struct), no numpy; ~2 s.

    scripts/clinical_liver.py [SOURCE.nii.gz] OUT.nii.gz
"""
import gzip
import os
import struct
import sys

SIZE = (512, 512, 129)
SPACING = (0.57, 0.57, 1.6)


def main(argv):
    here = os.path.dirname(os.path.abspath(__file__))
    default = os.path.join(here, "..", "tests", "data", "liver_totalseg_example_3mm.nii.gz")
    if len(argv) not in (2, 3):
        sys.exit(__doc__)
    src, dst = (argv[1], argv[2]) if len(argv) == 3 else (default, argv[1])
    raw = gzip.open(src).read()
    hdr = bytearray(raw[:348])
    dim = struct.unpack_from("<8h", hdr, 40)
    pix = struct.unpack_from("<8f", hdr, 76)
    datatype = struct.unpack_from("<h", hdr, 70)[0]
    if datatype != 2:
        sys.exit(f"{src}: expected a uint8 mask (datatype 2), got datatype {datatype}")
    vox = int(struct.unpack_from("<f", hdr, 108)[0])
    srow = [struct.unpack_from("<4f", hdr, 280 + 16 * r) for r in range(3)]
    sx, sy, sz = dim[1], dim[2], dim[3]
    data = raw[vox:vox + sx * sy * sz]
    # The source's axes are its sform's diagonal (a positive-diagonal affine, PROVENANCE.md).
    o_in = [srow[r][3] for r in range(3)]
    lo, hi = [10**9] * 3, [-1] * 3
    for idx, value in enumerate(data):
        if value:
            c = (idx % sx, (idx // sx) % sy, idx // (sx * sy))
            for a in range(3):
                lo[a], hi[a] = min(lo[a], c[a]), max(hi[a], c[a])
    centre = [o_in[a] + (lo[a] + hi[a]) / 2 * pix[1 + a] for a in range(3)]
    o_out = [centre[a] - SIZE[a] * SPACING[a] / 2 for a in range(3)]

    def index_map(a):
        out = []
        for i in range(SIZE[a]):
            s = int(round((o_out[a] + i * SPACING[a] - o_in[a]) / pix[1 + a]))
            out.append(s if 0 <= s < dim[1 + a] else -1)
        return out

    mi, mj, mk = index_map(0), index_map(1), index_map(2)
    nx = SIZE[0]
    out = bytearray(SIZE[0] * SIZE[1] * SIZE[2])
    pos = 0
    for k in range(SIZE[2]):
        for j in range(SIZE[1]):
            if mk[k] >= 0 and mj[j] >= 0:
                base = (mk[k] * sy + mj[j]) * sx
                row = data[base:base + sx]
                out[pos:pos + nx] = bytes(row[i] if i >= 0 else 0 for i in mi)
            pos += nx
    h = bytearray(hdr)
    struct.pack_into("<8h", h, 40, 3, SIZE[0], SIZE[1], SIZE[2], 1, 1, 1, 1)
    struct.pack_into("<8f", h, 76, 1.0, SPACING[0], SPACING[1], SPACING[2], 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, 352.0)
    for r in range(3):
        row = [0.0, 0.0, 0.0, o_out[r]]
        row[r] = SPACING[r]
        struct.pack_into("<4f", h, 280 + 16 * r, *row)
    struct.pack_into("<3f", h, 268, *o_out)  # qoffset: the qform keeps the source's rotation
    tmp = dst + ".part"
    with gzip.open(tmp, "wb", compresslevel=1) as f:
        f.write(bytes(h) + b"\0\0\0\0" + bytes(out))
    os.replace(tmp, dst)
    print(f"{dst}: {SIZE[0]}x{SIZE[1]}x{SIZE[2]} at {SPACING} mm, "
          f"{sum(1 for b in out if b)} voxels inside")


if __name__ == "__main__":
    main(sys.argv)
