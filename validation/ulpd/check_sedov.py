#!/usr/bin/python3
"""Sedov-Taylor point explosion with the ulpd method (3D octant, ideal gas gamma = 1.4): shock
radius against the self-similar law and the energy budget.

Reference: L. I. Sedov, "Similarity and Dimensional Methods in Mechanics" (1959); G. I. Taylor,
Proc. R. Soc. A 201 (1950) 159; J. R. Kamm & F. X. Timmes, LA-UR-07-2849 (2007).
R(t) = xi0 (E t^2 / rho)^(1/5), xi0 = 1.0328 for gamma = 1.4 (validation/sedov/sedov_exact.py).

Scene: examples/ulpd_sedov_3d.yaml (the SPH scene examples/sedov_3d.yaml with method ulpd):
octant [0, 0.5]^3, three symmetry planes, E = 0.125 J in the octant, rho = 1, background
p = 1e-6 Pa. Spacing 0.02 (15.6k particles) by default, 0.01 (125k) with --full.
Measure and tolerances as validation/sedov (front_radius imported from there): the shock front
is the leading-edge mid-height of the radially binned density jump; |R - R_exact| / R_exact
<= 3 % at every frame with t >= 0.02 s; |balance| / total0 <= 0.5 % over the run.
"""
import argparse
import importlib.util
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
VAL = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(VAL, "sedov"))
sys.path.insert(0, VAL)
import common  # noqa: E402
import sedov_exact  # noqa: E402

_spec = importlib.util.spec_from_file_location("sedov_check", os.path.join(VAL, "sedov", "check.py"))
sedov_check = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(sedov_check)

GAMMA, E_FULL, RHO = 1.4, 1.0, 1.0
TOL_R, TOL_E, T_MIN = 0.03, 0.005, 0.02


def scene(dx, t_end=0.05, every=0.01):
    with open(os.path.join(common.ROOT, "examples", "ulpd_sedov_3d.yaml")) as f:
        text = f.read()
    text = text.replace("spacing: 0.02", f"spacing: {dx:g}")
    text = text.replace("radius: 0.04}", f"radius: {2 * dx:g}}}")
    return text.replace("end: 0.05", f"end: {t_end:g}").replace("every: 0.01", f"every: {every:g}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--full", action="store_true", help="spacing 0.01 (125k particles)")
    ap.add_argument("--spacing", type=float, default=0.0, help="override the spacing")
    ap.add_argument("--out", default=os.path.join(common.ROOT, "out", "validation", "ulpd_sedov"))
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    dx = args.spacing or (0.01 if args.full else 0.02)
    xi0 = sedov_exact.profile(GAMMA)[0]
    print(f"Sedov-Taylor blast with ulpd, gamma = {GAMMA}, xi0 = {xi0:.5f}, spacing {dx:g}")
    path, wall = common.run(exe, scene(dx), f"ulpd_sedov_{dx:g}", args.out, args.threads, args.reuse)
    ok = True
    rows = []
    print(f"\n  {'t [s]':>7} {'R front':>9} {'R exact':>9} {'error':>8}   (R peak)")
    for fr in common.frames(path):
        d = common.read_frame(path, fr)
        t = d["time"]
        if t < T_MIN - 1e-9:
            continue
        R, R_peak = sedov_check.front_radius(d, dx)
        Re = sedov_exact.shock_radius(t, E_FULL, RHO, xi0)
        err = (R - Re) / Re
        good = abs(err) <= TOL_R
        ok &= good
        rows.append((t, R, Re, err, R_peak))
        print(f"  {t:7.4f} {R:9.4f} {Re:9.4f} {100 * err:7.2f}%  {'PASS' if good else 'FAIL'}  ({R_peak:.4f})")
    es = common.read_series(path)
    total0 = es["kinetic"][0] + es["internal"][0]
    bal = np.abs(es["balance"]) / total0
    e_ok = bal.max() <= TOL_E
    ok &= e_ok
    kin = es["kinetic"][-1] / total0
    print(f"\n  initial total energy {total0:.6g} J; kinetic fraction at the end {kin:.3f} (self-similar 0.219)")
    print(f"  energy balance max |balance| / total0 = {100 * bal.max():.4f}% (tolerance {100 * TOL_E:g}%)  "
          f"{'PASS' if e_ok else 'FAIL'}")
    print(f"  viscous dissipation at the end {es['viscous'][-1] / total0:.3f} of total0; run {wall:.1f} s")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    d = common.read_frame(path)
    t = d["time"]
    Re = sedov_exact.shock_radius(t, E_FULL, RHO, xi0)
    r = np.linalg.norm(d["x"], axis=1)
    _, centres, mean, cnt = sedov_check.peak_radius(d, dx)
    R, _ = sedov_check.front_radius(d, dx)
    _, xs, gs, _, _ = sedov_exact.profile(GAMMA)
    ax = axes[0]
    ax.plot(r, d["rho"], ".", ms=1, alpha=0.3, color="C0", label="particles (ulpd)")
    ax.plot(centres[cnt > 0], mean[cnt > 0], "-", color="C1", label="binned mean")
    ax.plot(np.concatenate([xs * Re, [Re, 0.6]]), np.concatenate([gs * RHO, [RHO, RHO]]), "k-", lw=1,
            label="self-similar (Sedov)")
    ax.axvline(R, color="C1", ls=":", lw=0.8)
    ax.set_xlim(0, 0.5)
    ax.set_xlabel("r [m]")
    ax.set_ylabel(r"$\rho$ [kg/m$^3$]")
    ax.set_title(f"density at t = {t:.3f} s")
    ax.legend()
    ax = axes[1]
    tt = np.linspace(1e-4, 0.05, 200)
    Rt = sedov_exact.shock_radius(tt, E_FULL, RHO, xi0)
    ax.plot(tt, Rt, "k-", lw=1, label=r"$\xi_0 (E t^2/\rho)^{1/5}$")
    ax.fill_between(tt, (1 - TOL_R) * Rt, (1 + TOL_R) * Rt, color="0.85", label="±3 %")
    ax.plot([q[0] for q in rows], [q[1] for q in rows], "o", color="C1", label="ulpd (front)")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("shock radius [m]")
    ax.legend()
    ax = axes[2]
    for key in ("kinetic", "internal", "viscous"):
        ax.plot(es["t"], es[key] / total0, label=key)
    ax.plot(es["t"], es["balance"] / total0, "k-", label="balance")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("energy / initial total")
    ax.legend()
    fig.suptitle(f"Sedov-Taylor blast with ulpd (3D octant, spacing {dx:g} m)")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, f"ulpd_sedov_{dx:g}.png"), dpi=110)
    plt.close(fig)
    print(f"  figure: validation/ulpd/ulpd_sedov_{dx:g}.png")
    common.energy_figure(path, os.path.join(HERE, f"ulpd_sedov_{dx:g}_energy.png"),
                         title=f"Sedov-Taylor blast with ulpd, spacing {dx:g} m: energy budget")
    print(f"  figure: validation/ulpd/ulpd_sedov_{dx:g}_energy.png (tools/plot_series.py)")
    print(f"ulpd sedov: {'PASS' if ok else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
