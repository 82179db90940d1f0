#!/usr/bin/python3
"""Draws docs/images/phantom_model.png from the quick start's exported meshes.

Run after scripts/quickstart.sh, with Debian's matplotlib (apt-get install python3-matplotlib):
    /usr/bin/python3 scripts/make_readme_figure.py out/liver_skin.obj out/liver_layer1.obj docs/images/phantom_model.png
Left: the skin (layer 0), lit. Right: the same model cut open at the sagittal midplane of the
right lobe, showing the inner layer inside the skin. A stop-gap until the OpenGL renderer lands.
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402


def read_obj(path):
    v, f = [], []
    with open(path) as fh:
        for line in fh:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                v.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                f.append([int(x.split("/")[0]) - 1 for x in p[1:4]])
    return np.array(v), np.array(f)


def shaded(V, F, color, light=np.array([0.3, -0.6, 0.75]), alpha=1.0):
    tri = V[F]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    light = light / np.linalg.norm(light)
    lambert = np.clip(n @ light, 0, 1)
    c = np.array(color)[None, :] * (0.35 + 0.65 * lambert[:, None])
    rgba = np.concatenate([np.clip(c, 0, 1), np.full((len(F), 1), alpha)], axis=1)
    return Poly3DCollection(tri, facecolors=rgba, edgecolors=(0, 0, 0, 0.15 * alpha), linewidths=0.2)


def setup(ax, V, title, elev, azim):
    lo, hi = V.min(0), V.max(0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo, zoom=1.05)  # true proportions, filling the panel
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    ax.set_title(title, fontsize=10)


def main(skin_path, inner_path, out_path):
    # Lamina works in LPS; show the patient upright, seen from the front-right.
    Vs, Fs = read_obj(skin_path)
    Vi, Fi = read_obj(inner_path)
    liver = (0.62, 0.22, 0.18)
    fig = plt.figure(figsize=(13, 4.6), dpi=110)
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    ax.add_collection3d(shaded(Vs, Fs, liver))
    # LPS: the patient's front is -y; azim -100 looks at it from the front-right.
    setup(ax, Vs, f"skin (layer 0): {len(Vs)} nodes, {len(Fs)} triangles", 15, -100)

    ax = fig.add_subplot(1, 3, 2, projection="3d")
    ax.add_collection3d(shaded(Vs, Fs, liver, light=np.array([0.2, -0.4, -0.9])))
    setup(ax, Vs, "from below: the concave visceral surface", -55, -100)

    ax = fig.add_subplot(1, 3, 3, projection="3d")
    cut = np.median(Vs[:, 1])  # keep the posterior half, look into it from the front
    keep_s = Fs[(Vs[Fs][:, :, 1] > cut).all(axis=1)]
    ax.add_collection3d(shaded(Vs, keep_s, liver, alpha=0.3))
    ax.add_collection3d(shaded(Vi, Fi, (0.95, 0.75, 0.3)))
    setup(ax, Vs, f"cut open: inner layer 1 ({len(Vi)} nodes) inside", 15, -100)
    fig.suptitle("Lamina: the built-in liver phantom as a two-layer volumetric mass-spring model", fontsize=12)
    fig.tight_layout()
    fig.savefig(out_path)


if __name__ == "__main__":
    main(*sys.argv[1:4])
