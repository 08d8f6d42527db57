#!/usr/bin/python3
"""Soil column under a step load (tlpd + elastic): settlement against 1-D elasticity.

Reference: Fan & Li 2017 section 4.1 (digest 000 section 3.1). Column 1 m x 1 m x 10 m, the
four sides on rollers (zero normal displacement), bottom fixed in z, a pressure P(t) on the top ramped
linearly over 0.05 s to P0 and then held (tlpd `traction:` block). Elastic soil lambda = mu = 39.4 MPa (E = 98.5 MPa,
nu = 0.25), rho = 1700 kg/m^3. Static settlement of the top (uniaxial strain):
    dH = P0 H / (lambda + 2 mu) = 0.846, 1.692, 2.538 mm for P0 = 10, 20, 30 kPa.
Static state: mass-proportional velocity damping (tlpd `damping`, a -= gamma v) with
gamma = 2 omega_1, omega_1 = (pi/2) c_p / H the first mode of the fixed-free column, i.e. about
critical damping of the first mode; run to 0.6 s (more than 20 / omega_1).
Discretisation: particle centres on a cubic lattice spanning z in [0, H] (the fixed layer sits on
z = 0, the loaded layer on z = H; box from -dx/2 to H + dx/2), x, y in (0, 1).
Measured: settlement = -(mean u_z of the top layer) at the end; tolerance 1 % per load.
"""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402

L, H = 1.0, 10.0
LAM = MU = 39.4e6
RHO = 1700.0
E = MU * (3 * LAM + 2 * MU) / (LAM + MU)
NU = LAM / (2 * (LAM + MU))
T_RISE, T_END = 0.05, 0.6
TOL = 0.01


def lattice(dx):
    """Spacing with H = (N + 1/2) dx: a mirror plane at z = 0 and particle centres at (k + 1/2) dx, the
    last one on z = H (the loaded layer)."""
    return H / (round(H / dx - 0.5) + 0.5)


def scene(dx, p0, out, rollers, width=L, t_end=T_END):
    cp = math.sqrt((LAM + 2 * MU) / RHO)
    w1 = 0.5 * math.pi * cp / H
    gamma = 2 * w1
    e = 0.25 * dx
    if rollers == "symmetry":
        zlo, zhi = 0.0, H + 0.5 * dx
        bottom = "  - symmetry: {point: [0, 0, 0], normal: [0, 0, 1]}\n"
    else:
        zlo, zhi = -0.5 * dx, H + 0.5 * dx
        bottom = "  - {set: col, region: {box: {min: [-1, -1, -1], max: [2, 2, %.9g]}}, fix: [z]}\n" % e
    if rollers == "symmetry":
        # the nonlocal roller: mirror planes (zero normal displacement, complete families)
        sides = "".join("  - symmetry: {point: [%g, %g, 0], normal: [%g, %g, 0]}\n" % t
                        for t in ((0, 0, 1, 0), (width, 0, -1, 0), (0, 0, 0, 1), (0, width, 0, -1)))
    else:
        # fixed normal component on the outer particle layer of each side face
        q = 0.75 * dx
        sides = "".join("  - {set: col, region: {box: {min: [%.9g, %.9g, -1], max: [%.9g, %.9g, 20]}}, fix: [%s]}\n" % t
                        for t in ((-1, -1, q, 2, "x"), (width - q, -1, 2, 2, "x"), (-1, -1, 2, q, "y"), (-1, width - q, 2, 2, "y")))
    return f"""# Soil column under a step load (validation/tlpd_soil_column/check.py; 000 section 4.1)
ejecta: 1
dimension: 3
time: {{end: {t_end}, cfl: 0.5}}
output: {{file: {out}, every: {t_end / 30:.6g}, fields: [v, stress, x0]}}
materials:
  soil: {{model: elastic, rho0: {RHO:g}, E: {E:.9g}, nu: {NU:.9g}}}
sets:
  col:
    method: tlpd
    material: soil
    damping: {gamma:.6g}
    traction: {{pressure: {p0:g}, normal: [0, 0, 1], lo: [-1, -1, {H - e:.9g}], hi: [2, 2, {H + e:.9g}], rise_time: {T_RISE}}}
    shape: {{box: {{min: [0, 0, {zlo:.9g}], max: [{width:.9g}, {width:.9g}, {zhi:.9g}]}}}}
    spacing: {dx}
boundaries:
{sides}{bottom}"""


def settlement(path, dx):
    T, U = [], []
    for fr in common.frames(path):
        d = common.read_frame(path, fr)
        top = np.abs(d["x0"][:, 2] - H) < 0.25 * dx
        T.append(d["time"])
        U.append(-np.mean(d["x"][top, 2] - d["x0"][top, 2]))
    return np.array(T), np.array(U), d


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/validation/tlpd_soil_column")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--dx", type=float, default=0.2)
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--width", type=float, default=L, help="cross-section side (symmetry rollers only)")
    ap.add_argument("--t-end", type=float, default=T_END)
    ap.add_argument("--rollers", choices=("symmetry", "fix"), default="symmetry",
                    help="side faces: symmetry planes (default) or fix: [x]/[y] on the outer particle layer")
    ap.add_argument("--full", action="store_true",
                    help="the judged resolution (make validate): dx 0.05 m, width 0.2 m, t_end 0.4 s")
    a = ap.parse_args()
    if a.full:
        a.dx, a.width, a.t_end = 0.05, 0.2, 0.4
    exe = common.ejecta_binary(a.build)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    ok = True
    dx = lattice(a.dx) if a.rollers == "symmetry" else a.dx
    # with mirror planes on the four sides the solution does not depend on the width (translation
    # invariance); --width < 1 m saves particles at fine spacing (it must exceed the horizon)
    width = a.width if a.rollers == "symmetry" else L
    if a.rollers == "symmetry":
        width = dx * max(1, round(width / dx))
    for p0 in (10e3, 20e3, 30e3):
        name = f"column_{a.rollers}_dx{a.dx:g}_{int(p0 / 1e3)}kPa"
        out = os.path.join(a.out, name + ".h5")
        common.run(exe, scene(dx, p0, out, a.rollers, width, a.t_end), name, a.out, threads=a.threads, reuse=a.reuse)
        T, U, d = settlement(out, dx)
        ref = p0 * H / (LAM + 2 * MU)
        err = U[-1] / ref - 1
        s = common.read_series(out)
        good = abs(err) < TOL
        ok &= good
        print(f"P0 = {p0 / 1e3:4.0f} kPa, dx = {dx:.5g} m, width {width:.4g} m ({len(d['x'])} particles): settlement {U[-1] * 1e3:.4f} mm, "
              f"reference {ref * 1e3:.4f} mm, error {100 * err:+.3f} % (tol 1 %); last-frame change "
              f"{abs(U[-1] - U[-2]) / ref:.1e} of dH; energy balance {abs(s['balance'][-1]):.2e} J  "
              f"{'PASS' if good else 'FAIL'}")
        ax[0].plot(T, U * 1e3, "o-", ms=3, label=f"P0 = {p0 / 1e3:g} kPa")
        ax[0].axhline(ref * 1e3, ls="--", lw=0.8, color="k")
        z0 = d["x0"][:, 2]
        uz = -(d["x"][:, 2] - z0)
        ax[1].plot(z0, uz * 1e3, ".", ms=2)
        ax[1].plot([0, H], [0, ref * 1e3], "k--", lw=0.8)
    ax[0].set_xlabel("t (s)")
    ax[0].set_ylabel("settlement of the top layer (mm)")
    ax[0].set_title(f"tlpd soil column, dx = {dx:.4g} m (dashed: P0 H/(lambda+2mu))")
    ax[0].legend(fontsize=8)
    ax[1].set_xlabel("z0 (m)")
    ax[1].set_ylabel("-u_z at the end (mm)")
    ax[1].set_title("displacement profile (dashed: uniaxial strain)")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "tlpd_soil_column.png"), dpi=110)
    # The 30 kPa run (the last) through the user tools: sigma_zz along z at the end against the
    # static uniaxial-strain state sigma_zz = -P0 (the derivative of the settlement profile
    # u_z = P0 z / (lambda + 2 mu); tools/compare.py), and the energy budget (tools/plot_series.py).
    ref_csv = os.path.join(a.out, f"column_{int(p0 / 1e3)}kPa_static.csv")
    np.savetxt(ref_csv, np.column_stack([[0.0, H], [-p0, -p0]]), delimiter=",", header="z,szz", comments="")
    l1r, linfr = common.profile_figure(out, "col", "stress", ref_csv, os.path.join(HERE, "tlpd_soil_column_compare.png"),
                                       component="zz", axis="z")
    common.energy_figure(out, os.path.join(HERE, "tlpd_soil_column_energy.png"),
                         title=f"tlpd soil column, P0 = {p0 / 1e3:g} kPa, dx = {dx:.4g} m: energy budget")
    print(f"tools/compare.py, sigma_zz(z) at the end of the {p0 / 1e3:g} kPa run against -P0: L1_rel = {l1r:.4f}, "
          f"Linf_rel = {linfr:.3f} (shown, not a criterion); figures tlpd_soil_column_compare.png, tlpd_soil_column_energy.png")
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
