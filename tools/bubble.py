#!/usr/bin/python3
"""Soil bubble of a buried-charge run: height and width against time, and cuts of the soil.

    /usr/bin/python3 tools/bubble.py OUT.h5 [--soil SET] [--gas SET] [--axis z] [--csv F] [--png F]
                                     [--cuts F] [--times 0.1,0.3,0.5]

Definitions (Bergeron et al. 1998 as used by Fan & Li, 000 Fig. 18; the thresholds are ejecta's
choice, stated here): the ground surface z_s is the highest initial position of the soil set; a
soil particle belongs to the bubble when it is higher than z_s + dx/2 (dx the initial spacing of
the surface layer). Bubble height = max z over the bubble particles within 2 dx of the charge
axis - z_s. Bubble width = twice the largest
distance from the charge axis among bubble particles whose height is below half the bubble height
(the width of the dome at its base half). With --min-nbrs N only soil particles with at least N
other soil particles within 1.5 dx count: the coherent dome without the isolated fragments that
fly ahead of it (validation/buried_charge uses N = 3). axis_front() (used by validation/buried_charge,
not written by this command) gives the highest soil and the height below which 90 % of the soil above
the surface lies within a fixed 30 mm of the axis: the same window at every spacing, where the
height's window above, 2 dx, narrows with the spacing. The scene's charge axis is the z axis through
x = y = 0 (a quarter model with symmetry planes x = 0 and y = 0).

Writes a CSV (t_ms, height_mm, width_mm), a PNG of both against time and a PNG of vertical cuts
(|y| < dx) of the soil (and gas) coloured by speed at the requested times.
"""
import argparse
import sys

import h5py
import numpy as np


def frames(f):
    keys = sorted(f["frames"].keys())
    return [(k, float(f["frames"][k].attrs["time"])) for k in keys]


def spacing(x0):
    """Typical spacing of the points: median nearest-neighbour distance of a sample."""
    n = len(x0)
    rng = np.random.default_rng(1)
    idx = rng.choice(n, size=min(n, 400), replace=False)
    d = []
    for i in idx:
        r = np.sqrt(((x0 - x0[i]) ** 2).sum(axis=1))
        r[i] = np.inf
        d.append(r.min())
    return float(np.median(d))


def measure(x, z_s, dx, min_nbrs=0):
    """Height and width of the bubble. min_nbrs > 0: only soil particles with at least min_nbrs
    other soil particles within 1.5 dx count (the coherent dome; isolated fragments thrown off
    ahead of it, which a coarse run makes, do not)."""
    up = x[:, 2] > z_s + 0.5 * dx
    if min_nbrs > 0 and up.any():
        from scipy.spatial import cKDTree

        cnt = cKDTree(x).query_ball_point(x[up], r=1.5 * dx, return_length=True) - 1
        keep = np.zeros_like(up)
        keep[np.flatnonzero(up)[cnt >= min_nbrs]] = True
        up = keep
    if not up.any():
        return 0.0, 0.0
    # height on the charge axis (within 2 spacings of it), so that a single fast fragment off
    # the axis does not count as the dome
    r_all = np.sqrt(x[:, 0] ** 2 + x[:, 1] ** 2)
    axis = up & (r_all < 2.0 * dx)
    height = float(x[axis, 2].max() - z_s) if axis.any() else 0.0
    low = up & (x[:, 2] - z_s <= 0.5 * height)
    r = np.sqrt(x[low, 0] ** 2 + x[low, 1] ** 2) if low.any() else np.array([0.0])
    return height, 2.0 * float(r.max())


def axis_front(x, z_s, dx, radius=0.03, q=0.9):
    """Two heights of the soil above the surface (z > z_s + dx/2) within a FIXED distance `radius`
    of the charge axis (default 30 mm, the charge's radius), the same window at every spacing
    (measure()'s window, 2 dx, narrows as the spacing does): the highest such particle, and the
    height below which the fraction q of them lies (default 0.9: the front of the bulk of the
    lifted soil on the axis, not its few fastest particles). Counts are masses where the window
    lies in one uniform lattice (the refined box of the buried-charge scenes). Returns (0, 0)
    when no soil is above the surface there."""
    r = np.sqrt(x[:, 0] ** 2 + x[:, 1] ** 2)
    z = x[(x[:, 2] > z_s + 0.5 * dx) & (r < radius), 2] - z_s
    if z.size == 0:
        return 0.0, 0.0
    return float(z.max()), float(np.quantile(z, q))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", help="ejecta HDF5 output")
    ap.add_argument("--soil", default="soil", help="soil set name (default soil)")
    ap.add_argument("--gas", default="charge", help="gas set name, drawn in the cuts if present")
    ap.add_argument("--csv", default=None, help="CSV of height and width (default OUT_bubble.csv)")
    ap.add_argument("--png", default=None, help="PNG of height and width (default OUT_bubble.png)")
    ap.add_argument("--cuts", default=None, help="PNG of cuts (default OUT_cuts.png)")
    ap.add_argument("--times", default=None, help="comma-separated times in ms for the cuts (default 4 frames)")
    ap.add_argument("--min-nbrs", type=int, default=0,
                    help="count only soil particles with at least this many soil particles within 1.5 dx "
                         "(the coherent dome, not isolated fragments; 0 = all, the default)")
    a = ap.parse_args()
    base = a.out[:-3] if a.out.endswith(".h5") else a.out
    csv = a.csv or base + "_bubble.csv"
    png = a.png or base + "_bubble.png"
    cuts = a.cuts or base + "_cuts.png"

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with h5py.File(a.out, "r") as f:
        fr = frames(f)
        if not fr or a.soil not in f["frames"][fr[0][0]]:
            sys.exit(f"{a.out}: no set '{a.soil}' in the frames")
        x_init = f["frames"][fr[0][0]][a.soil]["x"][:]
        z_s = float(x_init[:, 2].max())
        top = x_init[x_init[:, 2] > z_s - 1e-9 - 0.1 * (x_init[:, 2].max() - x_init[:, 2].min())]
        dx = spacing(top)
        rows = []
        for k, t in fr:
            h, w = measure(f["frames"][k][a.soil]["x"][:], z_s, dx, a.min_nbrs)
            rows.append((t * 1e3, h * 1e3, w * 1e3))
        rows = np.array(rows)
        np.savetxt(csv, rows, delimiter=",", header="t_ms,height_mm,width_mm", comments="", fmt="%.6g")

        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        ax[0].plot(rows[:, 0], rows[:, 1], "o-")
        ax[0].set_xlabel("t (ms)")
        ax[0].set_ylabel("bubble height (mm)")
        ax[1].plot(rows[:, 0], rows[:, 2], "o-")
        ax[1].set_xlabel("t (ms)")
        ax[1].set_ylabel("bubble width (mm)")
        for q in ax:
            q.grid(alpha=0.3)
        fig.suptitle(f"soil bubble: {a.out}")
        fig.tight_layout()
        fig.savefig(png, dpi=110)
        plt.close(fig)

        if a.times:
            want = [float(s) * 1e-3 for s in a.times.split(",")]
            pick = [min(fr, key=lambda kt: abs(kt[1] - tw)) for tw in want]
        else:
            step = max(1, (len(fr) - 1) // 3)
            pick = fr[::step][:4]
        fig, axs = plt.subplots(1, len(pick), figsize=(4.2 * len(pick), 4.2), squeeze=False)
        vmax = 0.0
        data = []
        for k, t in pick:
            g = f["frames"][k]
            parts = []
            for name in (a.soil, a.gas):
                if name not in g:
                    continue
                x = g[name]["x"][:]
                v = g[name]["v"][:]
                sel = np.abs(x[:, 1]) < 2.5 * dx  # the first lattice row of a coarse far field too
                sp = np.sqrt((v[sel] ** 2).sum(axis=1))
                vmax = max(vmax, float(sp.max()) if sp.size else 0.0)
                parts.append((name, x[sel], sp))
            data.append((t, parts))
        for q, (t, parts) in zip(axs[0], data):
            for name, x, sp in parts:
                sc = q.scatter(x[:, 0], x[:, 2], c=sp, s=4, cmap="viridis", vmin=0, vmax=vmax or 1,
                               marker="s" if name == a.soil else "o")
            q.set_title(f"t = {t * 1e3:.3f} ms")
            q.set_aspect("equal")
            q.set_xlabel("x (m)")
            q.set_ylabel("z (m)")
        fig.colorbar(sc, ax=axs[0].tolist(), label="speed (m/s)")
        fig.savefig(cuts, dpi=110)
        plt.close(fig)
    print(f"bubble: {csv}, {png}, {cuts}")
    for t, h, w in rows:
        print(f"  t = {t:7.4f} ms  height {h:7.2f} mm  width {w:7.2f} mm")
    energy_split(a.out)


def energy_split(path):
    """Where the energy went at the end, from output.set_series (/series/set/<set>/): each set's
    kinetic and internal energy against the initial total. Prints nothing without set_series."""
    with h5py.File(path, "r") as f:
        if "set" not in f["series"]:
            return
        e = f["series"]["energy"]
        e0 = float(e["kinetic"][0] + e["internal"][0])
        t = float(e["t"][-1])
        print(f"energy at t = {t * 1e3:.4f} ms (of the initial {e0 / 1e3:.1f} kJ; output.set_series):")
        for name in sorted(f["series"]["set"].keys()):
            g = f["series"]["set"][name]
            k, i, i0 = float(g["kinetic"][-1]), float(g["internal"][-1]), float(g["internal"][0])
            print(f"  {name:<8} kinetic {k / 1e3:8.2f} kJ ({100 * k / e0:5.1f} %)  internal {i / 1e3:8.2f} kJ "
                  f"({100 * i / e0:5.1f} %; at t = 0 {100 * i0 / e0:5.1f} %)")


if __name__ == "__main__":
    main()
