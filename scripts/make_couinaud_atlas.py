#!/usr/bin/env python3
"""Makes data/couinaud_atlas.bin, the expert Couinaud labels lamina's atlas places segments from.

Source: xukun-zhang/Couinaud-Segmentation (MIT), Datasets/LiTS/label/LiTS-N.nii.gz: expert labels
1-8 of the LiTS challenge's livers (CT: CC BY-NC-SA 4.0). LiTS-28 ... LiTS-47 are
3D-IRCADb-01's patients 1-20 (CC BY-NC-ND; the livers lamina is validated on) and are left out.

    python3 scripts/make_couinaud_atlas.py LABEL_DIR VESSEL_DIR data/couinaud_atlas.bin

VESSEL_DIR: the repository's Datasets/LiTS/vessel (the vessel masks of 20 of those livers, 17
outside 3D-IRCADb; portal and hepatic veins as one label).

Each liver is put in its own bounding box and binned on a G^3 grid (G = 40): a bin holds the
label most of the liver's voxels in it carry, 0 where none lies. Axes in LPS (x towards the
patient's left, y towards the back, z up); each volume's axes are turned so that its labels
lie in their anatomical order (2/3 left of 6/7, 4 in front of 7, 8 above 5), since the LiTS
volumes do not all come the same way round. The file is one zlib stream of: b"LCA1", uint32 G,
uint32 count, count uint16 LiTS numbers, then count x G^3 uint8 labels, z fastest, then y, x;
then uint32 vcount, vcount uint16 indices (into the livers above) of the livers whose vessels
are known, and vcount x G^3 uint8 vessel densities (the share of the liver's voxels in each bin
that are vessel, x 255, rounded), binned the same way.
"""
import glob, gzip, os, struct, sys, zlib
import numpy as np

G = 40
DT = {2: np.uint8, 4: np.int16, 8: np.int32, 16: np.float32, 64: np.float64, 256: np.int8,
      512: np.uint16, 768: np.uint32}


def read_nifti(path):
    b = gzip.open(path).read()
    dim = struct.unpack('<8h', b[40:56])
    dtype = DT[struct.unpack('<h', b[70:72])[0]]
    offset = int(struct.unpack('<f', b[108:112])[0])
    shape = dim[1:1 + dim[0]]
    a = np.frombuffer(b, dtype=dtype, count=int(np.prod(shape)), offset=offset)
    srow = np.array(struct.unpack('<12f', b[280:328])).reshape(3, 4)
    return a.reshape(shape[::-1]).transpose(), np.abs(np.diag(srow[:, :3]))


def binned(path, vessel_path=None):
    labels, spacing = read_nifti(path)
    idx = np.nonzero(labels)
    lab = labels[idx].astype(np.int64)
    X = np.stack([idx[d] * spacing[d] for d in range(3)], 1)
    c = {l: X[lab == l].mean(0) for l in range(1, 9) if (lab == l).any()}
    if len(c) < 8:
        raise SystemExit(f'{path}: not all eight segments labelled')
    # To LPS-like: x to the patient's left, y to the back, z up.
    if (c[2][0] + c[3][0]) < (c[6][0] + c[7][0]): X[:, 0] = -X[:, 0]
    if c[4][1] < c[7][1]: X[:, 1] = -X[:, 1]
    if c[8][2] < c[5][2]: X[:, 2] = -X[:, 2]
    X[:, 1] = -X[:, 1]  # 4 in front of 7 above; the back is +y
    lo, hi = X.min(0), X.max(0)
    b = np.clip(((X - lo) / (hi - lo) * G).astype(np.int64), 0, G - 1)
    flat = (b[:, 0] * G + b[:, 1]) * G + b[:, 2]
    counts = np.bincount(flat * 9 + lab, minlength=G ** 3 * 9).reshape(G ** 3, 9)
    out = counts[:, 1:].argmax(1).astype(np.uint8) + 1
    out[counts[:, 1:].sum(1) == 0] = 0
    if vessel_path is None:
        return out, None
    vessels, _ = read_nifti(vessel_path)
    if vessels.shape != labels.shape:
        raise SystemExit(f'{vessel_path}: not on the grid of {path}')
    in_vessel = vessels[idx] > 0
    share = np.bincount(flat[in_vessel], minlength=G ** 3) / np.maximum(
        np.bincount(flat, minlength=G ** 3), 1)
    return out, np.rint(share * 255).astype(np.uint8)


def main():
    src, vessel_dir, dst = sys.argv[1], sys.argv[2], sys.argv[3]
    numbers, grids, with_vessels, densities = [], [], [], []
    for path in sorted(glob.glob(os.path.join(src, 'LiTS-*.nii.gz')),
                       key=lambda p: int(os.path.basename(p)[5:-7])):
        n = int(os.path.basename(path)[5:-7])
        if 28 <= n <= 47:
            continue
        vessel_path = os.path.join(vessel_dir, os.path.basename(path))
        grid, density = binned(path, vessel_path if os.path.exists(vessel_path) else None)
        if density is not None:
            with_vessels.append(len(numbers))
            densities.append(density)
        grids.append(grid)
        numbers.append(n)
        print(f'LiTS-{n}', flush=True)
    payload = b'LCA2' + struct.pack('<II', G, len(numbers)) + struct.pack(
        f'<{len(numbers)}H', *numbers) + b''.join(g.tobytes() for g in grids) + struct.pack(
        '<I', len(with_vessels)) + struct.pack(f'<{len(with_vessels)}H', *with_vessels) + b''.join(
        d.tobytes() for d in densities)
    with open(dst + '.part', 'wb') as f:
        f.write(zlib.compress(payload, 9))
    os.replace(dst + '.part', dst)
    print(f'{dst}: {len(numbers)} livers ({len(with_vessels)} with vessels), '
          f'{os.path.getsize(dst)} bytes')


if __name__ == '__main__':
    main()
