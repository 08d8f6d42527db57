#!/usr/bin/python3
"""A block torn apart by prescribed velocities (tlpd + elastic + critical stretch).

Problem: 3D bar 0.1 m x 0.02 m x 0.02 m, dx = 2.5 mm (40 x 8 x 8 particles), horizon 3 dx,
elastic E = 1 GPa, nu = 0.25, rho = 2000 kg/m^3, critical stretch s0 = 0.01 (000 Eqs 14-17).
The end layers (x < 1.5 dx and x > L - 1.5 dx) move apart at -/+ 1 m/s (`velocity` boundaries)
for 1 ms (nominal strain 2 %, twice s0), cfl 0.5 (stable step: min of dx/c and the family bound).
Checks: no NaN; damage localises (particles with damage > 0.5 exist and are fewer than 25 % of
the bar; the largest gap along x is reported); energy balance: max |/series/energy/balance|
over the run divided by the maximum external work (the core counts the work of prescribed
velocities) below 1 %.
"""
import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402

L, W, DX, V, S0 = 0.1, 0.02, 0.0025, 1.0, 0.01
CFL = 0.5  # see README: 2.6 % before tlpd's energy_correction, 0.065 % with it (damage fraction 0.234)
TOL = 0.01


def scene(out, t_end="1 ms", cfl=CFL, v=V):
    q = 1.5 * DX
    return f"""# A block torn apart (validation/tlpd_tearing/check.py)
ejecta: 1
dimension: 3
time: {{end: {t_end}, cfl: {cfl}}}
output: {{file: {out}, every: 0.025 ms, fields: [v, damage, x0]}}
materials:
  m: {{model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}}
sets:
  bar:
    method: tlpd
    material: m
    failure: {{critical_stretch: {S0}}}
    shape: {{box: {{min: [0, 0, 0], max: [{L}, {W}, {W}]}}}}
    spacing: {DX}
boundaries:
  - {{set: bar, region: {{box: {{min: [-1, -1, -1], max: [{q}, 1, 1]}}}}, velocity: [{-v}, 0, 0]}}
  - {{set: bar, region: {{box: {{min: [{L - q}, -1, -1], max: [1, 1, 1]}}}}, velocity: [{v}, 0, 0]}}
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/validation/tlpd_tearing")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--cfl", type=float, default=CFL)
    ap.add_argument("--velocity", type=float, default=V, help="speed of each pulled end (m/s)")
    a = ap.parse_args()
    exe = common.ejecta_binary(a.build)
    out = os.path.join(a.out, "tearing.h5")
    common.run(exe, scene(out, cfl=a.cfl, v=a.velocity), "tearing", a.out, threads=a.threads, reuse=a.reuse)
    d = common.read_frame(out)
    finite = all(np.all(np.isfinite(d[k])) for k in ("x", "v", "damage"))
    dmg = d["damage"]
    frac = np.mean(dmg > 0.5)
    x0, x = d["x0"][:, 0], d["x"][:, 0]
    band = dmg > 0.05
    # the crack: largest gap in current x between neighbouring particles sorted along the bar
    xs = np.sort(x)
    gap = np.max(np.diff(xs))
    s = common.read_series(out)
    wext = np.max(np.abs(s["external"]))
    bal = np.max(np.abs(s["balance"])) / wext
    sb = common.read_series(out, "bar")
    print(f"{len(x)} particles; finite: {finite}; fraction with damage > 0.5: {frac:.3f} (must be in (0, 0.25)); "
          f"mean damage {np.mean(dmg):.3f}; largest gap along x {gap * 1e3:.2f} mm (dx {DX * 1e3:.1f} mm); broken bonds {sb['broken_bonds'][-1]:.0f}")
    print(f"energy: max |balance| = {np.max(np.abs(s['balance'])):.4e} J, max external work {wext:.4e} J, ratio {bal:.2e} "
          f"(tol {TOL})")
    ok = finite and 0 < frac < 0.25 and bal < TOL
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    sc = ax[0].scatter(x, d["x"][:, 2], c=dmg, s=6, cmap="viridis", vmin=0, vmax=1)
    fig.colorbar(sc, ax=ax[0], label="damage")
    ax[0].set_xlabel("x (m)")
    ax[0].set_ylabel("z (m)")
    ax[0].set_title(f"t = {d['time'] * 1e3:.2f} ms")
    ax[0].set_aspect("equal")
    ax[1].plot(s["t"] * 1e3, s["external"], label="external work (prescribed velocities)")
    ax[1].plot(s["t"] * 1e3, s["kinetic"], label="kinetic")
    ax[1].plot(s["t"] * 1e3, s["internal"], label="internal")
    ax[1].plot(s["t"] * 1e3, s["balance"], label="balance")
    ax[1].set_xlabel("t (ms)")
    ax[1].set_ylabel("J")
    ax[1].legend(fontsize=8)
    ax[1].set_title(f"energy: max|balance| / max W_ext = {bal:.1e}")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "tlpd_tearing.png"), dpi=110)
    # through tools/plot_series.py: the energy budget and the bar's mean damage against time
    common.energy_figure(out, os.path.join(HERE, "tlpd_tearing_energy.png"), title="tlpd tearing bar: energy budget")
    common.energy_figure(out, os.path.join(HERE, "tlpd_tearing_damage.png"), series=["bar/mean_damage"],
                         title="tlpd tearing bar: mean damage")
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
