#!/usr/bin/python3
"""Depth tracks in Seguin's container with the Mohr-Coulomb bed (README, "Seguin's container and the
Mohr-Coulomb bed, SPH against RKPM"): the SPH bed at 6 and 4 mm (three heights each) and 3.5 mm (h 500 mm), the RKPM bed at 5 mm (msnni_w 0.5) and
6 mm (msnni_w 0.25), from the CSV tracks kept here and in validation/sphere_drop/tracks. Writes
../sphere_drop_methods_seguin_tracks.png."""
import csv
import importlib.util
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
RK = os.path.join(HERE, "..", "..", "sphere_drop", "tracks")
# ball diameter, Seguin's depths and the tolerance: validation/sphere_drop's, not restated here
_spec = importlib.util.spec_from_file_location("sphere_drop", os.path.join(HERE, "..", "..", "sphere_drop", "check.py"))
sphere_drop = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(sphere_drop)
RUNS = [
    (os.path.join(HERE, "sph_h100_s6mm_seguin_cap3_mc.csv"), "SPH 6 mm, h 100 mm", "C0", ":"),
    (os.path.join(HERE, "sph_h300_s6mm_seguin_cap3_mc.csv"), "SPH 6 mm, h 300 mm", "C0", "-"),
    (os.path.join(HERE, "sph_h500_s6mm_seguin_cap3_mc.csv"), "SPH 6 mm, h 500 mm", "C0", "--"),
    (os.path.join(HERE, "sph_h100_s4mm_seguin_cap3_mc.csv"), "SPH 4 mm, h 100 mm", "C3", ":"),
    (os.path.join(HERE, "sph_h300_s4mm_seguin_cap3_mc.csv"), "SPH 4 mm, h 300 mm (from 23.4 ms)", "C3", "-"),
    (os.path.join(HERE, "sph_h500_s4mm_seguin_cap3_mc.csv"), "SPH 4 mm, h 500 mm", "C3", "--"),
    (os.path.join(HERE, "sph_h500_s3.5mm_seguin_cap3_mc.csv"), "SPH 3.5 mm, h 500 mm", "C2", "--"),
    (os.path.join(RK, "h300_s5mm_cap3_mc_nbody_seguin.csv"), "RKPM 5 mm, w 0.5, h 300 mm", "k", "-"),
    (os.path.join(RK, "h300_s6mm_cap3_mc_nbody_seguin_w0.25.csv"), "RKPM 6 mm, w 0.25, h 300 mm", "0.5", "-"),
]
D = sphere_drop.D
fig, ax = plt.subplots(figsize=(7.5, 4.5))
for path, label, color, ls in RUNS:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    ax.plot([1000 * float(r["t_s"]) for r in rows], [float(r["depth_m"]) / D for r in rows], color=color, ls=ls,
            label=label)
for h, e in sphere_drop.EXP.items():
    ax.axhspan((1 - sphere_drop.TOL) * e, (1 + sphere_drop.TOL) * e, color="gray", alpha=0.08)
    ax.axhline(e, color="gray", lw=0.6, ls=":")
    ax.annotate(f"Seguin {h * 1000:.0f} mm", (121, e), fontsize=7, va="center")
ax.set_xlim(0, 135)
ax.set_xlabel("t [ms]")
ax.set_ylabel("depth of the ball's lowest point / d")
ax.set_title("Seguin's container, Mohr-Coulomb bed (cap3_mc), level-set contact normal")
ax.legend(fontsize=7, loc="lower right")
fig.tight_layout()
fig.savefig(os.path.join(HERE, "..", "sphere_drop_methods_seguin_tracks.png"), dpi=100)
