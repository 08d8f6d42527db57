#!/usr/bin/python3
"""Blast hole in granite (examples/granite_blast_hole.yaml, which has seed 002's crack-opening cut,
tlpd `failure: {cut_distance: 0.5}`, 002 Sec. 2.4 (b)) with and without the cut: runs both, prints
the damage by initial radius and the counts, and draws the damage at the end side by side
(granite_blast_hole_cut.png).

    /usr/bin/python3 plugins/materials/jh2/blast_hole.py --build build [--outdir /tmp/bh] [--reuse]

Run from the repository root. About 15 s and 20 s CPU on one core.
"""
import argparse
import os
import re
import subprocess
import sys

import h5py
import numpy as np

os.environ.setdefault("HDF5_USE_FILE_LOCKING", "FALSE")
HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
SCENE = os.path.join(ROOT, "examples", "granite_blast_hole.yaml")
BANDS = [(0, 5), (5, 11), (11, 15), (15, 20), (20, 30), (30, 40), (40, 50), (50, 60), (60, 72)]


def scene(cut, out):
    text = open(SCENE).read()
    text, n = re.subn(r"^output: \{file: [^,]+,", "output: {file: %s," % out, text, flags=re.M)
    assert n == 1
    text, n = re.subn(r"^    failure: \{cut_distance: [0-9.]+\}", "    failure: {cut_distance: %g}" % cut, text, flags=re.M)
    assert n == 1
    return text


def run(build, outdir, cut, reuse):
    name = "cut" if cut > 0 else "nocut"
    out = os.path.join(outdir, name + ".h5")
    log = os.path.join(outdir, name + ".log")
    if not (reuse and os.path.exists(out) and os.path.exists(log)):
        path = os.path.join(outdir, name + ".yaml")
        with open(path, "w") as f:
            f.write(scene(cut, out))
        exe = os.path.join(build, "bin", "ejecta")
        res = subprocess.run([exe, "run", path, "--threads", "1"], capture_output=True, text=True)
        with open(log, "w") as f:
            f.write(res.stdout + res.stderr)
        if res.returncode != 0:
            sys.exit("ejecta failed (%s):\n%s" % (name, res.stderr[-2000:]))
    text = open(log).read()
    counts = {k: int(v) for k, v in re.findall(r"set 'rock': ([^:(]+?)(?: \([^)]*\))?: (\d+)", text)}
    steps = int(re.search(r"\((\d+) steps", text).group(1))
    bal = float(re.search(r"energy balance error \S+ J \((\S+) of", text).group(1))
    with h5py.File(out, "r") as f:
        g = f["checkpoint/rock"]
        x, x0, dmg = g["x"][:], g["x0"][:], g["damage"][:]
    rad = 1e3 * np.hypot(x0[:, 0], x0[:, 1])  # initial radius [mm]
    return dict(x=x, rad=rad, dmg=dmg, counts=counts, steps=steps, bal=bal)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--outdir", default="/tmp/ej_blast_hole")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--png", default=os.path.join(HERE, "granite_blast_hole_cut.png"))
    a = ap.parse_args()
    os.makedirs(a.outdir, exist_ok=True)
    runs = [(0.0, run(a.build, a.outdir, 0.0, a.reuse)), (0.5, run(a.build, a.outdir, 0.5, a.reuse))]
    print("mean damage (tlpd broken-bond fraction) at 60 us by initial radius [mm]:")
    print("%-12s" % "band" + "".join("%12s" % ("cut %g" % c) for c, _ in runs))
    for lo, hi in BANDS:
        row = "%-12s" % ("%d-%d" % (lo, hi))
        for _, r in runs:
            sel = (r["rad"] >= lo) & (r["rad"] < hi)
            row += "%12.3f" % r["dmg"][sel].mean()
        print(row)
    for c, r in runs:
        rad = r["rad"]
        print("cut %g: %d steps, balance %.2e, broken bonds %d, detached %d, spring fallback %d particle-steps, "
              "damage >= 0.5 on %d of %d particles, all failed within %.1f mm" %
              (c, r["steps"], r["bal"], r["counts"].get("broken bonds", -1), r["counts"].get("detached particles", -1),
               r["counts"].get("singular shape tensor K, spring fallback", -1), int((r["dmg"] >= 0.5).sum()),
               len(r["dmg"]), rad[r["dmg"] < 1].min() if (r["dmg"] < 1).any() else float("nan")))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(1, 2, figsize=(11, 5.4), constrained_layout=True)
    for ax, (c, r) in zip(axs, runs):
        sc = ax.scatter(1e3 * r["x"][:, 0], 1e3 * r["x"][:, 1], c=r["dmg"], s=1.2, cmap="inferno_r", vmin=0, vmax=1,
                        linewidths=0)
        ax.set_aspect("equal")
        ax.set_xlim(0, 80), ax.set_ylim(0, 80)
        ax.set_xlabel("x [mm]"), ax.set_ylabel("y [mm]")
        ax.set_title("%s: %d detached, %d broken bonds" % (
            "cut_distance %g (002 Sec. 2.4 (b))" % c if c > 0 else "no cut (failed ends only)",
            r["counts"].get("detached particles", -1), r["counts"].get("broken bonds", -1)), fontsize=10)
    fig.colorbar(sc, ax=axs, shrink=0.8, label="damage (broken-bond fraction)")
    fig.suptitle("Granite blast hole (JH2 + 002 tension, tlpd 0.8/0.4 mm, 2-D quarter), 60 us")
    fig.savefig(a.png, dpi=110)
    print("wrote", a.png)


if __name__ == "__main__":
    main()
