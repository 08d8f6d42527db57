#!/usr/bin/python3
"""Depth tracks in Seguin's container with the Mohr-Coulomb bed (README, "Seguin's container and the
Mohr-Coulomb bed, SPH against RKPM"): the SPH bed at 6 and 4 mm, the RKPM bed at 5 mm (msnni_w 0.5) and
6 mm (msnni_w 0.25), from the CSV tracks kept here and in validation/sphere_drop/tracks. Writes
../sphere_drop_methods_seguin_tracks.png."""
import csv
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
RK = os.path.join(HERE, "..", "..", "sphere_drop", "tracks")
RUNS = [
    (os.path.join(HERE, "sph_h100_s6mm_seguin_cap3_mc.csv"), "SPH 6 mm, h 100 mm", "C0", ":"),
    (os.path.join(HERE, "sph_h300_s6mm_seguin_cap3_mc.csv"), "SPH 6 mm, h 300 mm", "C0", "-"),
    (os.path.join(HERE, "sph_h500_s6mm_seguin_cap3_mc.csv"), "SPH 6 mm, h 500 mm", "C0", "--"),
    (os.path.join(HERE, "sph_h300_s4mm_seguin_cap3_mc.csv"), "SPH 4 mm, h 300 mm (from 23.4 ms)", "C3", "-"),
    (os.path.join(RK, "h300_s5mm_cap3_mc_nbody_seguin.csv"), "RKPM 5 mm, w 0.5, h 300 mm", "k", "-"),
    (os.path.join(RK, "h300_s6mm_cap3_mc_nbody_seguin_w0.25.csv"), "RKPM 6 mm, w 0.25, h 300 mm", "0.5", "-"),
]
D = 0.019
fig, ax = plt.subplots(figsize=(7.5, 4.5))
for path, label, color, ls in RUNS:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    ax.plot([1000 * float(r["t_s"]) for r in rows], [float(r["depth_m"]) / D for r in rows], color=color, ls=ls,
            label=label)
for e, h in ((1.4, 100), (2.4, 300), (2.85, 500)):
    ax.axhspan(0.8 * e, 1.2 * e, color="gray", alpha=0.08)
    ax.axhline(e, color="gray", lw=0.6, ls=":")
    ax.annotate(f"Seguin {h} mm", (121, e), fontsize=7, va="center")
ax.set_xlim(0, 135)
ax.set_xlabel("t [ms]")
ax.set_ylabel("depth of the ball's lowest point / d")
ax.set_title("Seguin's container, Mohr-Coulomb bed (cap3_mc), level-set contact normal")
ax.legend(fontsize=7, loc="lower right")
fig.tight_layout()
fig.savefig(os.path.join(HERE, "..", "sphere_drop_methods_seguin_tracks.png"), dpi=100)
