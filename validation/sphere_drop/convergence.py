#!/usr/bin/python3
"""Sphere drop, bed-resolution study: final depth against the bed spacing for runs made with
check.py at one drop height (same scene, only --spacing changed), the least-squares line
delta(s) = delta_0 + k s through them and, with three or more spacings, the observed order p of
delta(s) = delta_0 + k s^p (fitted on the three finest). Writes sphere_drop_convergence.png and
prints a Markdown table. delta_0 is an extrapolation, not a measurement: check.py's PASS/FAIL is
on the computed depths.

    /usr/bin/python3 validation/sphere_drop/convergence.py --height 0.1 \\
        --run 0.006:OUT6.h5 --run 0.004:OUT4.h5 --run 0.003:OUT3.h5 [--depth 0.084] [--label TEXT]
        [--other 0.006:OLD6.h5 ... --other-label TEXT]   # a second series for comparison, no fit
"""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import check  # noqa: E402


def observed_order(s, d):
    """p of d = d0 + k s^p through three points (s ascending), by bisection on the ratio of the
    differences; None when the differences do not shrink monotonically."""
    (s1, s2, s3), (d1, d2, d3) = s, d
    r = (d3 - d2) / (d2 - d1) if d2 != d1 else float("nan")
    if not (r > 0):
        return None
    f = lambda p: (s3 ** p - s2 ** p) / (s2 ** p - s1 ** p) - r  # noqa: E731
    lo, hi = 0.05, 8.0
    if f(lo) * f(hi) > 0:
        return None
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(lo) * f(mid) > 0 else (lo, mid)
    p = 0.5 * (lo + hi)
    k = (d2 - d1) / (s2 ** p - s1 ** p)
    return p, d1 - k * s1 ** p


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--height", type=float, required=True, help="drop height of the runs [m]")
    ap.add_argument("--run", action="append", required=True, help="SPACING:PATH of a check.py output (.h5)")
    ap.add_argument("--depth", type=float, default=0.084, help="bed depth of the runs (check.py --depth)")
    ap.add_argument("--png", default=os.path.join(HERE, "sphere_drop_convergence.png"))
    ap.add_argument("--label", default="ejecta RKPM bed (computed, ball stopped)", help="legend of the --run series")
    ap.add_argument("--other", action="append", default=[],
                    help="SPACING:PATH of a second series drawn for comparison (no fit), e.g. another setting")
    ap.add_argument("--other-label", default="other setting", help="legend of the --other series")
    a = ap.parse_args()

    def depths(items):
        out = []
        for item in items:
            sp, path = item.split(":", 1)
            s = float(sp)
            t, zc, vz, _, _ = check.ball_track(path)
            pen = check.surface(s, a.depth) - (zc - check.R)
            out.append((s, float(np.max(pen)), float(vz[-1]), float(t[-1])))
        return sorted(out)

    rows, other = depths(a.run), depths(a.other)
    exp = check.EXP.get(a.height)
    v0 = math.sqrt(2 * check.G * a.height)
    print(f"h = {a.height * 1000:.0f} mm (v0 {v0:.3f} m/s), Seguin delta/d = {exp} +-0.2")
    print("| bed spacing [mm] | delta [mm] | delta/d | error vs Seguin | ball v_z at the end [m/s] | stopped |")
    print("|---|---|---|---|---|---|")

    def table(series):
        for s, d, ve, _ in series:
            print(f"| {s * 1000:g} | {d * 1000:.1f} | {d / check.D:.3f} | {100 * (d / check.D / exp - 1):+.1f} % | "
                  f"{ve:.3f} | {'yes' if abs(ve) < 0.05 * v0 else 'no'} |")

    table(rows)
    if other:
        print(f"{a.other_label}:")
        table(other)
    s = np.array([r[0] for r in rows])
    d = np.array([r[1] for r in rows])
    k, d0 = np.polyfit(s, d, 1)
    print(f"least-squares line: delta = {d0 * 1000:.1f} mm {k:+.3f} s  -> delta_0/d = {d0 / check.D:.3f} "
          f"({100 * (d0 / check.D / exp - 1):+.1f} % vs Seguin; an extrapolation)")
    order = observed_order(s[:3], d[:3]) if len(rows) >= 3 else None
    if order:
        p, dp = order
        print(f"three finest spacings: observed order p = {p:.2f}, delta_0 = {dp * 1000:.1f} mm = {dp / check.D:.3f} d "
              f"({100 * (dp / check.D / exp - 1):+.1f} % vs Seguin; an extrapolation)")
    elif len(rows) >= 3:
        print("three finest spacings: not in the asymptotic range (the finest refinement changed delta more than "
              "any power law delta_0 + k s^p with p > 0 allows): no observed order, no extrapolation from them")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.plot(s * 1000, d / check.D, "o", label=a.label)
        if other:
            ax.plot([r[0] * 1000 for r in other], [r[1] / check.D for r in other], "s", color="0.5", mfc="none",
                    label=a.other_label)
        ss = np.linspace(0, s.max() * 1.05, 50)
        ax.plot(ss * 1000, (d0 + k * ss) / check.D, "--", label=f"least-squares line, s -> 0: {d0 / check.D:.2f} d")
        if order:
            p, dp = order
            kk = (d[1] - d[0]) / (s[1] ** p - s[0] ** p)
            ax.plot(ss * 1000, (dp + kk * ss ** p) / check.D, ":", label=f"order {p:.2f} fit, s -> 0: {dp / check.D:.2f} d")
        ax.axhspan(exp - 0.2, exp + 0.2, color="0.85", label=f"Seguin 2008 ({exp} +-0.2)")
        ax.axhline(exp * (1 - check.TOL), color="r", lw=0.8, label="target band (20 %)")
        ax.axhline(exp * (1 + check.TOL), color="r", lw=0.8)
        ax.set_xlabel("bed spacing s [mm]"), ax.set_ylabel("final depth / d")
        smax = max([s.max()] + [r[0] for r in other])
        ax.set_xlim(0, smax * 1050), ax.set_ylim(0, exp * 1.3)
        ax.set_title(f"sphere drop h = {a.height * 1000:.0f} mm: bed resolution")
        ax.legend(fontsize=7, loc="lower left")
        fig.tight_layout()
        fig.savefig(a.png, dpi=110)
        print("wrote", a.png)
    except Exception as e:  # noqa: BLE001
        print("figure not written:", e)
    return 0


if __name__ == "__main__":
    sys.exit(main())
