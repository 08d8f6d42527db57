#!/usr/bin/python3
"""Taylor bar, Armco iron at 220 m/s (examples/sph_taylor_bar.yaml; reference: shared/reference
README §4 = Chen et al. 2021 Table 4 "Experiment", citing Johnson & Holmquist 1988): final
length L = 19.8 mm, impact-face (mushroom) diameter D = 13.7 mm, W = 8.6 mm (diameter at
0.2 L0 from the impact face). Tolerances: 2 % on L, 5 % on D and W.
Measured on the particles of the quarter model at the end time: L = max z + dx/2,
D = 2 (max r over the first particle layer + dx/2), W = 2 (max r over |z - 0.2 L0| < dx/2 + dx/2),
r = sqrt(x^2 + y^2). Runs each spacing given (default 0.76 and 0.54 mm), prints every number and
PASS/FAIL for the finest; writes taylor_bar.png (final profiles r(z))."""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import common  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
REF = {"L": 19.8e-3, "D": 13.7e-3, "W": 8.6e-3}
TOL = {"L": 0.02, "D": 0.05, "W": 0.05}
L0 = 25.4e-3


def measure(x, dx):
    r = np.hypot(x[:, 0], x[:, 1])
    z = x[:, 2]
    L = z.max() + 0.5 * dx
    face = z < z.min() + 0.5 * dx
    D = 2 * (r[face].max() + 0.5 * dx)
    band = np.abs(z - 0.2 * L0) < 0.5 * dx
    W = 2 * (r[band].max() + 0.5 * dx) if band.any() else float("nan")
    return {"L": L, "D": D, "W": W}


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--spacing", type=float, nargs="+", default=[0.76e-3, 0.54e-3])
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    base = open(os.path.join(common.ROOT, "examples", "sph_taylor_bar.yaml")).read()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 6))
    res = None
    for dx in sorted(args.spacing, reverse=True):
        name = f"taylor_dx{dx * 1e6:.0f}um"
        text = base.replace("spacing: 0.38 mm", f"spacing: {dx * 1e3:g} mm")
        path, wall = common.run(exe, text, name, args.out, reuse=args.reuse)
        d = common.read_frame(path, None, "bar")
        res = measure(d["x"], dx)
        errs = {k: res[k] / REF[k] - 1 for k in REF}
        print(f"  dx {dx * 1e3:.3f} mm, n = {len(d['x'])}, t = {d['time'] * 1e6:.1f} us: "
              + ", ".join(f"{k} = {res[k] * 1e3:.2f} mm (ref {REF[k] * 1e3:.1f}, {errs[k] * 100:+.1f} %)" for k in REF))
        r = np.hypot(d["x"][:, 0], d["x"][:, 1])
        ax.plot(r * 1e3, d["x"][:, 2] * 1e3, ".", ms=2, label=f"dx {dx * 1e3:g} mm")
    ax.axhline(REF["L"] * 1e3, color="k", ls="--", lw=0.8, label="exp. L 19.8 mm")
    ax.axvline(REF["D"] * 0.5e3, color="k", ls=":", lw=0.8, label="exp. D/2 6.85 mm")
    ax.set_xlabel("r [mm]")
    ax.set_ylabel("z [mm]")
    ax.set_title("Taylor bar, Armco iron 220 m/s, sph + JC + Mie-Grueneisen")
    ax.legend(fontsize=8)
    fig.savefig(os.path.join(HERE, "taylor_bar.png"), dpi=120)
    common.energy_figure(path, os.path.join(HERE, "taylor_bar_energy.png"),
                         title=f"Taylor bar, dx {min(args.spacing) * 1e3:g} mm: energy budget (plastic work)")
    ok = all(abs(res[k] / REF[k] - 1) <= TOL[k] for k in REF)
    print("PASS" if ok else "FAIL", "(finest spacing; tolerances L 2 %, D 5 %, W 5 %)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
