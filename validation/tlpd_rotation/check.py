#!/usr/bin/python3
"""Rigid rotation of a cylinder (tlpd + elastic): objectivity of the stress update.

Reference: Fan & Li 2017 section 4.2.1 (digest 000 section 3.2): a cylinder R = 0.025 m,
H = 0.05 m spinning at omega = 1000 rad/s about its axis, free, for 1 ms; top-surface points at
r = R/2, 3R/4 and R keep the speeds 12.5, 18.75 and 25 m/s ("oscillate around the theoretical
values"), while without the objective algorithm the speeds diverge within a few steps.
Soil of 000 Table 2 (E = 98.5 MPa, nu = 0.25), elastic (bond breaking and plasticity off, as
the digest advises), rho = 1700 kg/m^3 (000 gives no density), spacing 2 mm (000: 11,882
particles, about 2.02 mm), horizon 3 dx, dt = 5e-7 s as in 000.

Measured: for the top-layer particles nearest to R/2, 3R/4 and R, max over t of
| |v| / (omega r0) - 1 | (r0 the particle's initial radius). Tolerance 0.5 % with the objective
update (objective: true). The run without the objective update (objective: false, nonobjective:
small_strain: none of 000 Eqs 78-94) must deviate by more than 5 % (diverge) within the 1 ms; the
run with half of it (nonobjective: rate: Eqs 78-92 kept, Eq 93's rotation dropped) is reported
without a verdict (README: an elastic body cannot diverge through a missing rotation of this
stress). Before 2026-11-28 the rate run had to diverge too, and the check printed FAIL.
Note: the centrifugal stress rho omega^2 R^2 ~ 1 MPa stretches this soft soil radially (0.2-0.8 %),
which changes |v| by the same order: this is physics, not an objectivity error. A particle's angular
momentum is NOT conserved for a body spun up from a stress-free start (the rings expand at different
rates and build up shear): the exact continuum disc (disc_reference.py) deviates 0.42/0.60/0.79 % in
speed at R/2, 3R/4, R (README "Study").

Pre-stressed start (--start prestressed, the default since 2026-11-22): the rigid-rotation
objectivity test proper. The set starts in the steadily rotating state: tlpd's initial_stress file
gives each particle the elastic plane-stress rotating-disc stress (Timoshenko & Goodier, rotating
disc: sigma_rr = (3 + nu)/8 rho w^2 (R^2 - r^2), sigma_tt = rho w^2/8 ((3 + nu) R^2 - (1 + 3 nu) r^2),
sigma_zz = sigma_rz = sigma_tz = 0). It is in equilibrium with the centripetal acceleration -w^2 r
everywhere and traction-free on the mantle AND on the end faces (plane strain would need sigma_zz =
nu (sigma_rr + sigma_tt) on the ends of this H = 2R cylinder); its incompatibility does not matter
for a rate-form (hypoelastic) material, whose stress at F = I is whatever it is given. So the exact
solution keeps |v| = w r0 at every point for ever; the objective update must stay within 0.5 %,
objective: false (small_strain) strains the body by sym(R - I) and must leave the band (> 5 %);
objective: false (rate) keeps the stress in its t = 0 orientation (reported). --start stress_free:
the earlier runs.
"""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402

R, H, OMEGA = 0.025, 0.05, 1000.0
TOL = 0.005


NU, RHO = 0.25, 1700.0


def disc_stress(x, y):
    """Plane-stress rotating-disc stress (Pa) at (x, y): sxx, syy, sxy (Timoshenko & Goodier)."""
    r2 = x * x + y * y
    a = RHO * OMEGA ** 2 / 8
    srr = a * (3 + NU) * (R * R - r2)
    stt = a * ((3 + NU) * R * R - (1 + 3 * NU) * r2)
    with np.errstate(invalid="ignore", divide="ignore"):
        c2 = np.where(r2 > 0, x * x / np.where(r2 > 0, r2, 1), 1.0)
        s2 = np.where(r2 > 0, y * y / np.where(r2 > 0, r2, 1), 0.0)
        cs = np.where(r2 > 0, x * y / np.where(r2 > 0, r2, 1), 0.0)
    return srr * c2 + stt * s2, srr * s2 + stt * c2, (srr - stt) * cs


def write_prestress(path, X):
    sxx, syy, sxy = disc_stress(X[:, 0], X[:, 1])
    with open(path, "w") as f:
        f.write("x,y,z,sxx,syy,sxy\n")
        for k in range(len(X)):
            f.write(f"{X[k,0]:.17g},{X[k,1]:.17g},{X[k,2]:.17g},{sxx[k]:.17g},{syy[k]:.17g},{sxy[k]:.17g}\n")


def scene(dx, objective, out, columns=None, t_end="1 ms", E="98.5 MPa", kind="rate", prestress=None, every="0.02 ms"):
    init = ""
    if columns is not None:
        lines = []
        for (x, y) in columns:
            lines.append(f"      - {{region: {{box: {{min: [{x - dx / 2:.9g}, {y - dx / 2:.9g}, -1], max: [{x + dx / 2:.9g}, "
                         f"{y + dx / 2:.9g}, 1]}}}}, velocity: [{-OMEGA * y:.9g}, {OMEGA * x:.9g}, 0]}}")
        init = "    initial:\n" + "\n".join(lines) + "\n"
    return f"""# Rigid rotation of a cylinder (validation/tlpd_rotation/check.py; 000 section 4.2.1)
ejecta: 1
dimension: 3
time: {{end: {t_end}, dt: 5e-7}}
output: {{file: {out}, every: {every}, fields: [v, stress]}}
materials:
  soil: {{model: elastic, rho0: 1700, E: {E}, nu: 0.25}}
sets:
  cyl:
    method: tlpd
    material: soil
    objective: {str(objective).lower()}
""" + ("" if objective else f"    nonobjective: {kind}\n") + f"""    shape: {{cylinder: {{base: [0, 0, 0], axis: [0, 0, 1], radius: {R}, height: {H}}}}}
    spacing: {dx}
""" + (f"    initial_stress: {{file: {prestress}}}\n" if prestress else "") + init


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/validation/tlpd_rotation")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--dx", type=float, default=0.002)
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--start", default="prestressed", choices=["prestressed", "stress_free"],
                    help="prestressed: sigma(t=0) = the rotating-disc stress (the objectivity test); "
                         "stress_free: the earlier runs (centrifugal expansion transient)")
    ap.add_argument("--materials", default="soil", help="comma list of soil, stiff")
    ap.add_argument("--every", default="0.02 ms", help="output interval (the maxima are over the frames)")
    ap.add_argument("--kinds", default="objective,rate,small_strain", help="comma list of objective, rate, small_strain")
    a = ap.parse_args()
    pre = a.start == "prestressed"
    exe = common.ejecta_binary(a.build)
    # positions of the lattice (a zero-length run), then one initial-velocity column per (x, y)
    p0, _ = common.run(exe, scene(a.dx, True, "x", None, t_end="1e-9").replace("file: x", f"file: {a.out}/pos.h5"), "pos", a.out,
                       threads=a.threads)
    d0 = common.read_frame(p0, common.frames(p0)[0])
    xy = np.round(d0["x"][:, :2], 9)  # the lattice's own columns (any dx)
    cols = sorted(set(map(tuple, xy)))
    pfile = None
    if pre:
        pfile = os.path.abspath(os.path.join(a.out, "prestress.csv"))
        write_prestress(pfile, d0["x"])
    # (tag, E, kind): kind "objective" (Hughes-Winget), "rate" (objective: false, 000 Eq 92
    # without the rotation of Eq 93), "small_strain" (objective: false, sym(grad_X du)).
    # soil: 000 Table 2 elastic constants (the paper's set-up); stiff: 25x E (centrifugal
    # stretch rho omega^2 R^2 / E 1.08 % and 0.043 %)
    mats = [m for m in (("soil", "98.5 MPa"), ("stiff", "2.4625 GPa")) if m[0] in a.materials.split(",")]
    cases = [(t, E, k) for t, E in mats for k in a.kinds.split(",")]
    tagp = "pre_" if pre else ""
    res = {}
    for tag, E, kind in cases:
        name = f"rot_{tagp}{tag}_{kind}"
        out = os.path.join(a.out, name + ".h5")
        txt = scene(a.dx, kind == "objective", out, cols, t_end="1 ms", E=E, kind=kind, prestress=pfile, every=a.every)
        if not (a.reuse and (os.path.exists(out) or os.path.exists(out + ".partial"))):
            try:
                common.run(exe, txt, name, a.out, threads=a.threads)
            except RuntimeError as e:  # a non-objective run may be stopped (det F < 0)
                print(f"  {name}: {e}")
        res[(tag, kind)] = out if os.path.exists(out) else (out + ".partial" if os.path.exists(out + ".partial") else None)
    # probes from the initial frame
    p0 = next(v for v in res.values() if v is not None)
    f0 = common.read_frame(p0, common.frames(p0)[0])
    x0 = f0["x"]
    ids0 = f0["id"]
    ztop = x0[:, 2].max()
    top = np.abs(x0[:, 2] - ztop) < 0.25 * a.dx
    rr = np.hypot(x0[:, 0], x0[:, 1])
    probes = []
    for frac in (0.5, 0.75, 1.0):
        cand = np.where(top)[0]
        k = cand[np.argmin(np.abs(rr[cand] - frac * R))]
        probes.append((frac, int(ids0[k]), rr[k]))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    nrow, ncol = len(mats), len(a.kinds.split(","))
    fig, axs = plt.subplots(nrow, ncol, figsize=(5 * ncol, 4 * nrow), squeeze=False)
    ok = True
    summary = []
    for (tag, E, kind), axk in zip(cases, axs.flat):
        path = res[(tag, kind)]
        if path is not None:
            try:  # a run stopped while writing may leave an unreadable file
                common.frames(path)
            except OSError as err:
                print(f"{tag} {kind}: unreadable output {path} ({err})")
                path = None
        if path is None:
            print(f"{tag} {kind}: no output")
            ok = False
            continue
        T = []
        V = {p[1]: [] for p in probes}
        Rr = {p[1]: [] for p in probes}
        Hh = {p[1]: [] for p in probes}
        for fr in common.frames(path):
            d = common.read_frame(path, fr)
            pos = {int(i): k for k, i in enumerate(d["id"])}
            if any(pid not in pos for _, pid, _ in probes):
                continue
            T.append(d["time"])
            for _, pid, _ in probes:
                xk, vk = d["x"][pos[pid]], d["v"][pos[pid]]
                V[pid].append(np.linalg.norm(vk))
                Rr[pid].append(np.hypot(*xk[:2]))
                Hh[pid].append(xk[0] * vk[1] - xk[1] * vk[0])
        T = np.array(T)
        worst_v = worst_r = worst_h = 0.0
        for frac, pid, r0 in probes:
            v, rad, hh = np.array(V[pid]), np.array(Rr[pid]), np.array(Hh[pid])
            fin = np.all(np.isfinite(v)) and np.all(np.isfinite(rad))
            dev = np.max(np.abs(v / (OMEGA * r0) - 1)) if fin else np.inf
            rdev = np.max(np.abs(rad / r0 - 1)) if fin else np.inf
            # specific angular momentum (x v_y - y v_x) / (omega r0^2): reported; it changes also in the
            # exact continuum spin-up (shear between rings), and a mis-rotated stress changes it more
            hdev = np.max(np.abs(hh / (OMEGA * r0 * r0) - 1)) if fin else np.inf
            worst_v, worst_r, worst_h = max(worst_v, dev), max(worst_r, rdev), max(worst_h, hdev)
            ln = axk.plot(T * 1e3, v / (OMEGA * r0), label=f"|v|/(w r0), r0 = {r0*1e3:.2f} mm ({frac:g} R)")
            axk.plot(T * 1e3, rad / r0, ls=":", color=ln[0].get_color(), label=f"r/r0 ({frac:g} R)")
            print(f"{tag:5s} {kind:12s} r0 = {r0*1e3:6.3f} mm ({frac:4.2f} R): omega r0 = {OMEGA*r0:6.3f} m/s, |v| in "
                  f"[{np.nanmin(v):.4g}, {np.nanmax(v):.4g}], speed dev {100*dev:.3f} %, radius dev {100*rdev:.3f} %, "
                  f"ang. mom. dev {100*hdev:.3f} %, reached t = {T[-1]*1e3:.3f} ms")
        axk.axhline(1, ls="--", lw=0.7, color="k")
        if kind == "objective":
            good = worst_v < TOL
            print(f"{tag}, objective update: max speed deviation {100*worst_v:.3f} % (tol {100*TOL:.1f} %, issue 4)  "
                  f"{'PASS' if good else 'FAIL'}; radius {100*worst_r:.3f} %, angular momentum {100*worst_h:.3f} %")
        elif kind == "small_strain":
            # 000 Fig. 8a: without the objective update the speeds diverge; here: the speed leaves
            # the rigid value by more than 10x the tolerance (5 %) within the 1 ms. "Without the
            # objective update" = none of 000 Eqs 78-94: the strain increment from the reference
            # gradient sym(grad_X du), no spatial increment gradient (Eq 88), no rotation (Eq 93).
            good = worst_v > 10 * TOL
            print(f"{tag}, objective: false ({kind}, no part of Eqs 78-94): max speed deviation {100*worst_v:.2f} % "
                  f"(diverges: > {1000*TOL:.0f} %)  {'PASS' if good else 'FAIL'}; radius {100*worst_r:.2f} %, "
                  f"angular momentum {100*worst_h:.2f} %")
        else:
            # `rate` keeps Eqs 78-92 (the spatial increment gradient h = grad_X du F^-1 at the
            # mid-step, whose d is zero for any rigid motion) and drops only Eq 93's rotation of the
            # old stress: half of the objective update. Reported without a verdict: for this
            # axisymmetric stress a missing rotation misplaces only the in-plane deviator, and an
            # elastic body pulls a misoriented stress back within a wave transit (README).
            good = None
            print(f"{tag}, objective: false ({kind}, Eq 93's rotation dropped only): max speed deviation "
                  f"{100*worst_v:.2f} % (reported, no verdict); radius {100*worst_r:.2f} %, angular momentum {100*worst_h:.2f} %")
        summary.append((tag, kind, good))
        if good is not None:
            ok &= good
        axk.set_title(("pre-stressed " if pre else "stress-free ") + f"{tag} (E = {E}), " + ("Hughes-Winget (objective)" if kind == "objective" else f"objective: false, {kind}"),
                      fontsize=9)
        axk.set_xlabel("t (ms)")
        axk.set_ylabel("|v| / (omega r0); r / r0 dotted")
        if kind != "objective" and (worst_v > 0.5 or worst_r > 0.5):
            axk.set_yscale("log")
        axk.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "tlpd_rotation.png" if pre else "tlpd_rotation_stress_free.png"), dpi=110)
    if res.get(("soil", "objective")) is not None and not pre:  # the paper's run: energy budget through tools/plot_series.py
        common.energy_figure(res[("soil", "objective")], os.path.join(HERE, "tlpd_rotation_energy.png"),
                             title="tlpd rotating cylinder, soil, objective: energy budget")
    print("summary: " + ", ".join(f"{t}/{k} {'reported' if g is None else 'PASS' if g else 'FAIL'}" for t, k, g in summary))
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
