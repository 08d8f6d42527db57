#!/usr/bin/python3
"""Aluminium plate in uniaxial tension to 30 % nominal strain (issue 6): SPH with strength must
stretch it without spurious clumping or numerical fracture. 2D plane strain (sph in 2D: eps_zz = 0),
plate 20 mm x 50 mm (x across, y along), spacing 0.5 mm (40 x 100 = 4000 particles), aluminium
6061-T6 of examples/materials/al6061_t6.yaml (Johnson-Cook + Mie-Grueneisen) with `failure: false`
(no damage: any separation is numerical, not material). Grips: the 3 end rows at each end
(|y| > 23.5 mm) move at -+6.25 m/s (both components prescribed: clamped grips), so the nominal strain
rate over the free length L_f = 47 mm is 2 V / L_f = 266 /s (a longitudinal wave crosses the plate
~140 times in the run; at 1064 /s, --velocity 25, the lateral start-up transient breaks metric 3);
the free part starts with the homogeneous velocity v_y = V y / (L_f / 2) (one
`initial` strip per lattice row), so there is no start-up wave along the plate. End: 30 % nominal
strain (t = 1128 us). Runs art_stress on (the case) and off (the comparison); Wendland C2,
h = 1.5 dx, art_eps 0.3, art_n 4, Monaghan viscosity alpha 1 beta 2 (the sph defaults).

Metrics (fixed before the first run; README.md):
  1. clumping: for each particle the nearest-neighbour distance d_i over the distance expected
     from the local deformation, dx * min_u |F_i u| over the lattice directions u = (1,0), (0,1),
     (1,+-1)/..., with F_i the least-squares deformation gradient of its reference neighbours
     within 3 dx (ratio 1 for any homogeneous deformation of the lattice, incl. the anisotropic
     stretch of tension); PASS if the minimum over all particles and all checked frames >= 0.5
     (the 1st percentile is reported). d_i / sqrt(m_i / rho_i) is reported too.
  2. numerical fracture: (a) one cluster (pairs linked when closer than 1.5 dx s_max, s_max the
     larger of the two particles' largest principal stretch of F, capped at 2); (b) no interior void: no particle
     of the free length that is farther than 3 dx (= 2h) from every particle of the plate's
     original boundary and has fewer than 0.8 x the bulk count of neighbours within 3 dx (number
     density is constant under plastic flow, so the count does not depend on the stretch).
  3. engineering stress-strain: S = (sum over the gauge |Y| < 5 mm of sigma_yy m/rho) / (current
     gauge length) / W0 against the gauge strain e_g (rows Y = +-4.75 mm), compared with the
     closed-form plane-strain flow stress (2/sqrt3) sigma_JC(eps_p, rate, T) / (1 + e_g)
     (adiabatic heating as the material: T += chi sigma d eps_p / (rho cp), rate 2V/L_f) for e_g in
     [0.01, e_c], e_c its maximum-load (Considere) strain; PASS if max |S / S_cf - 1| <= 5 %.
  4. energy: max |balance| <= 1 % of the work done by the grips (series energy/external) at the end.
PASS when the art_stress-on run meets 1-4. The off run is reported (and drawn) without a verdict.
Writes plate_tension.png (final particles of both runs, stress-strain curves) and
plate_tension_energy.png (energy budget of the on run). --write-example writes
examples/sph_plate_tension.yaml (the on run's scene)."""
import argparse
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import common  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
SET = "plate"
W0, L0 = 0.020, 0.050  # m: width (x), length (y)
GRIP_ROWS = 3
V = 6.25  # m/s, each grip (266 /s; --velocity 25 is the 1064 /s study of README "Strain rate")
E_END = 0.30  # nominal strain at the end
GAUGE = 0.010  # m, extensometer length (centred)
# aluminium 6061-T6, examples/materials/al6061_t6.yaml (Johnson-Cook, Mie-Grueneisen), failure off
RHO0, E_MOD, NU = 2703.0, 68.9e9, 0.33
JC = dict(A=324e6, B=114e6, n=0.42, C=0.002, m=1.34, T_room=293.0, T_melt=925.0, cp=896.0, chi=0.9, eps_dot0=1.0)


def lengths(dx):
    grip = GRIP_ROWS * dx
    l_free = L0 - 2 * grip
    return grip, l_free, E_END * l_free / (2 * V)


def scene(dx, art, out="out/sph_plate_tension.h5", every=None, comment=True):
    """Scene text at spacing dx (art_stress on/off); the velocity strips follow the lattice rows
    (cell-centred: Y_k = -L0/2 + (k + 1/2) dx)."""
    grip, l_free, t_end = lengths(dx)
    every = every if every else t_end / 100
    nrow = int(round(L0 / dx))
    strips = []
    for k in range(nrow):
        y = -0.5 * L0 + (k + 0.5) * dx
        vy = V * max(-1.0, min(1.0, y / (0.5 * l_free)))
        strips.append(f"      - {{region: {{box: {{min: [-1, {y - 0.5 * dx:.9g}], max: [1, {y + 0.5 * dx:.9g}]}}}}, "
                      f"velocity: [0, {vy:.9g}]}}")
    head = ""
    if comment:
        head = f"""# Aluminium plate in uniaxial tension to 30 % nominal strain (issue 6; validation/sph_plate_tension).
# 2D plane strain, plate 20 mm (x) x 50 mm (y), spacing {dx * 1e3:g} mm; aluminium 6061-T6 of
# examples/materials/al6061_t6.yaml (Johnson-Cook + Mie-Grueneisen) with failure: false, so any
# separation would be numerical. Clamped grips: the {GRIP_ROWS} end rows at each end move at -+{V:g} m/s
# (nominal strain rate 2 V / L_free = {2 * V / l_free:.0f} /s over the free length {l_free * 1e3:g} mm); the free part
# starts with the homogeneous stretching velocity v_y = V y / (L_free / 2), one `initial` strip per
# lattice row (no start-up wave along the plate). Artificial stress (Gray, Monaghan & Swift 2001)
# against the tensile instability: art_stress: false shows what it prevents (validation README).
# Generated by validation/sph_plate_tension/check.py --write-example.
"""
    return head + f"""ejecta: 1
dimension: 2
time: {{end: {t_end:.9g}, cfl: 0.3}}
output: {{file: {out}, every: {every:.9g}, fields: [v, rho, stress, eps_p, temperature, m]}}
materials:
  al6061_t6:
    model: johnson_cook
    rho0: 2703 kg/m^3
    E: 68.9 GPa
    nu: 0.33
    A: 324 MPa
    B: 114 MPa
    n: 0.42
    C: 0.002
    m: 1.34
    T_room: 293 K
    T_melt: 925 K
    cp: 896
    taylor_quinney: 0.9
    failure: false
    volumetric: eos
    eos: {{model: mie_gruneisen, rho0: 2703 kg/m^3, C0: 5350 m/s, S1: 1.34, gamma0: 2.0, a: 0.48}}
sets:
  {SET}:
    method: sph
    strength: true
    art_stress: {'true' if art else 'false'}
    kernel: wendland_c2
    h_factor: 1.5
    material: al6061_t6
    shape: {{box: {{min: [{-0.5 * W0:.9g}, {-0.5 * L0:.9g}], max: [{0.5 * W0:.9g}, {0.5 * L0:.9g}]}}}}
    spacing: {dx:.9g}
    initial:
""" + "\n".join(strips) + f"""
boundaries:
  - {{set: {SET}, region: {{box: {{min: [-1, {0.5 * L0 - grip:.9g}], max: [1, 1]}}}}, velocity: [0, {V:g}]}}
  - {{set: {SET}, region: {{box: {{min: [-1, -1], max: [1, {-0.5 * L0 + grip:.9g}]}}}}, velocity: [0, {-V:g}]}}
"""


def closed_form(e_rate, e_max=0.35, n=20000):
    """Engineering stress S(e) of plane-strain uniaxial tension (sigma_xx = 0, eps_zz = 0) of the
    Johnson-Cook material: rigid-plastic flow with incompressible plastic strain (sigma_zz =
    sigma_yy / 2, sigma_eq = (sqrt3/2) sigma_yy, eps_p = (2/sqrt3) eps_yy^p), the elastic strain
    sigma_yy (1 - nu^2) / E subtracted, adiabatic heating T += chi sigma_eq d eps_p / (rho cp) with
    the flow stress at the previous T (as the material), rate factor 1 + C ln max(eps_p_dot, 1)
    with eps_p_dot = (2/sqrt3) e_rate / (1 + e); width W0 / (1 + e). Returns (e, S, T)."""
    k = 2 / math.sqrt(3)
    es = np.linspace(0, e_max, n + 1)
    S, T = np.zeros_like(es), np.zeros_like(es)
    temp, sig_yy, ep_prev = JC["T_room"], 0.0, 0.0
    e_ps = E_MOD / (1 - NU * NU)
    for i, e in enumerate(es):
        eps = math.log1p(e)
        rate = max(k * e_rate / (1 + e), JC["eps_dot0"])
        ts = min(max((temp - JC["T_room"]) / (JC["T_melt"] - JC["T_room"]), 0.0), 1.0)
        fac = (1 + JC["C"] * math.log(rate / JC["eps_dot0"])) * (1 - ts ** JC["m"])
        # fixed point for the elastic share
        s = sig_yy
        for _ in range(50):
            ep = max(0.0, k * (eps - s / e_ps))
            s_new = min(e_ps * eps, k * (JC["A"] + JC["B"] * ep ** JC["n"]) * fac)
            if abs(s_new - s) < 1e-6:
                break
            s = s_new
        sig_yy = s
        ep = max(0.0, k * (eps - s / e_ps))
        if ep > ep_prev:
            temp += JC["chi"] * (s / k) * (ep - ep_prev) / (RHO0 * JC["cp"])
            ep_prev = ep
        S[i], T[i] = s / (1 + e), temp
    return es, S, T


def nearest(x, r):
    """Nearest-neighbour distance of every point (inf when none within r)."""
    i, j, d = common.pairs_within(x, r)
    dn = np.full(len(x), np.inf)
    np.minimum.at(dn, i, d)
    np.minimum.at(dn, j, d)
    return dn


class Reference:
    """The reference configuration (first frame, t = 0) in id order: positions, neighbour pairs
    within 3 dx (for F), boundary particles, bulk neighbour count, gauge rows."""

    def __init__(self, f0, dx):
        order = np.argsort(f0["id"])
        self.ids = f0["id"][order]
        X = f0["x"][order, :2]
        self.X, self.dx = X, dx
        self.i, self.j, _ = common.pairs_within(X, 3 * dx)
        n = len(X)
        self.boundary = (np.abs(X[:, 0]) > 0.5 * W0 - dx) | (np.abs(X[:, 1]) > 0.5 * L0 - dx)
        grip, l_free, _ = lengths(dx)
        self.free = np.abs(X[:, 1]) < 0.5 * l_free
        inner = (np.abs(X[:, 0]) < 0.5 * W0 - 3 * dx) & (np.abs(X[:, 1]) < 0.5 * L0 - 3 * dx)
        cnt = np.bincount(self.i, minlength=n) + np.bincount(self.j, minlength=n)
        self.n_bulk = float(np.median(cnt[inner]))
        self.gauge = np.abs(X[:, 1]) < 0.5 * GAUGE
        self.top = np.abs(X[:, 1] - (0.5 * GAUGE - 0.5 * dx)) < 0.25 * dx
        self.bot = np.abs(X[:, 1] + (0.5 * GAUGE - 0.5 * dx)) < 0.25 * dx
        dX = X[self.j] - X[self.i]
        A = np.zeros((n, 2, 2))
        np.add.at(A, self.i, dX[:, :, None] * dX[:, None, :])
        np.add.at(A, self.j, dX[:, :, None] * dX[:, None, :])
        self.Ainv = np.linalg.inv(A)

    def sorted_frame(self, fr):
        order = np.argsort(fr["id"])
        assert np.array_equal(fr["id"][order], self.ids), "particles lost or added"
        return {k: (v[order] if isinstance(v, np.ndarray) and v.ndim >= 1 and len(v) == len(order) else v)
                for k, v in fr.items()}

    def F(self, x):
        dX = self.X[self.j] - self.X[self.i]
        dx_ = x[self.j] - x[self.i]
        B = np.zeros((len(x), 2, 2))
        np.add.at(B, self.i, dx_[:, :, None] * dX[:, None, :])
        np.add.at(B, self.j, dx_[:, :, None] * dX[:, None, :])
        return B @ self.Ainv


def frame_metrics(ref, fr):
    """Metrics 1 and 2 of one frame (sorted by id)."""
    dx = ref.dx
    x = fr["x"][:, :2]
    F = ref.F(x)
    dirs = np.array([[1, 0], [0, 1], [1, 1], [1, -1]], dtype=float)
    lens = np.linalg.norm(np.einsum("nab,kb->nka", F, dirs), axis=2)
    expect = dx * lens.min(axis=1)
    smax = np.linalg.svd(F, compute_uv=False)[:, 0]
    i, j, d = common.pairs_within(x, 3 * dx)
    dn = np.full(len(x), np.inf)
    np.minimum.at(dn, i, d)
    np.minimum.at(dn, j, d)
    ratio = dn / expect
    vol = fr["m"] / fr["rho"]
    ratio_v = dn / np.sqrt(vol)
    link = 1.5 * dx * np.minimum(2.0, np.maximum(smax[i], smax[j]))  # capped at the 3 dx of the pair search
    nc, frac = common.cluster_count(len(x), i[d < link], j[d < link])
    cnt = np.bincount(i, minlength=len(x)) + np.bincount(j, minlength=len(x))
    # distance to the nearest particle of the original boundary
    bx = x[ref.boundary]
    db = np.full(len(x), np.inf)
    for a in range(0, len(x), 512):
        db[a:a + 512] = np.min(np.hypot(x[a:a + 512, None, 0] - bx[None, :, 0], x[a:a + 512, None, 1] - bx[None, :, 1]),
                               axis=1)
    deep = ref.free & (db > 3 * dx)
    void = deep & (cnt < 0.8 * ref.n_bulk)
    return dict(t=fr["time"], rmin=ratio.min(), r1=np.percentile(ratio, 1), rvmin=ratio_v.min(),
                rv1=np.percentile(ratio_v, 1), nc=nc, frac=frac, n_deep=int(deep.sum()), n_void=int(void.sum()),
                cmin=int(cnt[deep].min()) if deep.any() else -1, ratio=ratio, smax=smax.max())


def stress_strain(ref, fr):
    x = fr["x"][:, :2]
    ell0 = GAUGE - ref.dx
    eg = (x[ref.top, 1].mean() - x[ref.bot, 1].mean()) / ell0 - 1
    vol = fr["m"] / fr["rho"]
    force = np.sum(fr["stress"][ref.gauge, 1] * vol[ref.gauge]) / (GAUGE * (1 + eg))
    return eg, force / W0


def neck(ref, fr):
    """Narrowest cross-section of the free length at the end: width of 0.5 mm slices in the
    current y (max x - min x + dx / s, where s = the slice's mean lateral stretch is not known:
    + dx is used), its position, and the largest plastic strain."""
    x = fr["x"][:, :2]
    grip, l_free, _ = lengths(ref.dx)
    y0, y1 = x[ref.free, 1].min(), x[ref.free, 1].max()
    best = (np.inf, 0.0)
    for yc in np.arange(y0 + 2 * ref.dx, y1 - 2 * ref.dx, 0.5e-3):
        sl = np.abs(x[:, 1] - yc) < 0.25e-3
        if sl.sum() < 2:
            continue
        w = x[sl, 0].max() - x[sl, 0].min() + ref.dx
        if w < best[0]:
            best = (w, yc)
    return best[0], best[1], float(fr["eps_p"].max()), float(fr["temperature"].max())


def main():
    global V
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--dx", type=float, default=0.5e-3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--only", choices=["on", "off"], help="run one of the two")
    ap.add_argument("--write-example", action="store_true")
    ap.add_argument("--velocity", type=float, default=V,
                    help="grip speed [m/s] (default 6.25: 266 /s); other values are studies (no figure, no verdict)")
    args = ap.parse_args()
    dx = args.dx
    study = args.velocity != V
    V = args.velocity
    args.out = os.path.join(args.out, f"v{V:g}")
    if study:
        print(f"grip speed {V:g} m/s (study run; outputs under {args.out}, figures not written)")
    if args.write_example:
        path = os.path.join(common.ROOT, "examples", "sph_plate_tension.yaml")
        open(path, "w").write(scene(dx, True))
        print(f"wrote {path}")
        return 0
    exe = common.ejecta_binary(args.build)
    grip, l_free, t_end = lengths(dx)
    e_rate = 2 * V / l_free
    ecf, Scf, Tcf = closed_form(e_rate)
    ic = int(np.argmax(Scf))
    e_c = ecf[ic]
    print(f"closed form: nominal rate {e_rate:.0f} /s, max load S = {Scf[ic] / 1e6:.1f} MPa at e = {e_c:.4f} "
          f"(T {Tcf[ic]:.1f} K); S(0.30) = {np.interp(0.30, ecf, Scf) / 1e6:.1f} MPa (uniform, no neck)")
    results = {}
    for art in (True, False):
        tag = "on" if art else "off"
        if args.only and args.only != tag:
            continue
        name = f"plate_art_{tag}"
        try:
            path, wall = common.run(exe, scene(dx, art, out=name + ".h5"), name, args.out, threads=args.threads,
                                    reuse=args.reuse)
        except RuntimeError as err:
            print(f"  {name}: run failed ({err})")
            results[art] = None
            continue
        names = common.frames(path)
        f0 = common.read_frame(path, names[0], SET)
        assert f0["time"] == 0.0
        ref = Reference(f0, dx)
        ss, mets = [], []
        check_every = 5
        for k, fn in enumerate(names):
            fr = ref.sorted_frame(common.read_frame(path, fn, SET))
            eg, S = stress_strain(ref, fr)
            ss.append((fr["time"], 2 * V * fr["time"] / l_free, eg, S))
            if k % check_every == 0 or k == len(names) - 1:
                mets.append(frame_metrics(ref, fr))
        last = fr
        ss = np.array(ss)
        w_neck, y_neck, epmax, tmax = neck(ref, last)
        e = common.read_series(path)
        bal = np.abs(e["balance"]).max()
        wext = abs(e["external"][-1])
        win = (ss[:, 2] >= 0.01) & (ss[:, 2] <= e_c)
        dev = np.abs(ss[win, 3] / np.interp(ss[win, 2], ecf, Scf) - 1) if win.any() else np.array([np.inf])
        imax = int(np.argmax(ss[:, 3]))
        res = dict(ss=ss, mets=mets, last=last, ref=ref, bal=bal / wext if wext > 0 else np.inf, wext=wext,
                   dev=dev.max(), nwin=int(win.sum()), neck=(w_neck, y_neck), epmax=epmax, tmax=tmax, wall=wall,
                   smax_sim=(ss[imax, 2], ss[imax, 1], ss[imax, 3]), t_end=last["time"])
        results[art] = res
        rmin = min(m["rmin"] for m in mets)
        r1 = min(m["r1"] for m in mets)
        rvmin = min(m["rvmin"] for m in mets)
        nc = max(m["nc"] for m in mets)
        fracmin = min(m["frac"] for m in mets)
        nvoid = max(m["n_void"] for m in mets)
        print(f"  art_stress {tag}: t_end {last['time'] * 1e6:.1f} us (nominal strain {2 * V * last['time'] / l_free:.4f}), "
              f"{len(names)} frames, {len(mets)} checked, wall {wall:.1f} s")
        print(f"    1 clumping: nn / affine-expected min {rmin:.3f}, 1st percentile (lowest over frames) {r1:.3f}; "
              f"nn / sqrt(m/rho) min {rvmin:.3f}; end: min {mets[-1]['rmin']:.3f}, p1 {mets[-1]['r1']:.3f}")
        print(f"    2 fracture: clusters max {nc} (largest fraction min {fracmin:.4f}); interior-void particles max "
              f"{nvoid} (bulk count {ref.n_bulk:.0f}, deep particles at end {mets[-1]['n_deep']}, their min count "
              f"{mets[-1]['cmin']}); largest principal stretch {max(m['smax'] for m in mets):.3f}")
        print(f"    3 stress-strain: {res['nwin']} frames with e_g in [0.01, {e_c:.4f}], max |S/S_cf - 1| = "
              f"{res['dev']:.4f}; simulated max load S = {res['smax_sim'][2] / 1e6:.1f} MPa at e_g {res['smax_sim'][0]:.4f} "
              f"(nominal {res['smax_sim'][1]:.4f}); S at end {ss[-1, 3] / 1e6:.1f} MPa, e_g at end {ss[-1, 2]:.4f}")
        print(f"    4 energy: max |balance| {bal:.4g} J/m = {res['bal']:.2e} of the grips' work {wext:.4g} J/m; "
              f"plastic {e['plastic'][-1]:.4g}, kinetic {e['kinetic'][-1]:.4g}, viscous {e['viscous'][-1]:.4g}")
        print(f"    neck: narrowest width {w_neck * 1e3:.2f} mm at y = {y_neck * 1e3:+.2f} mm (W0 20 mm); max eps_p "
              f"{epmax:.3f}, max T {tmax:.0f} K")
        res.update(rmin=rmin, r1=r1, nc=nc, nvoid=nvoid)
        if art and not study:
            common.energy_figure(path, os.path.join(HERE, "plate_tension_energy.png"),
                                 title="Plate tension, art_stress on: energy budget")

    if study:
        print("study run: no figure and no verdict (the case is the default --velocity 6.25)")
        return 0
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(13, 6.2))
    axs = [fig.add_subplot(1, 3, 1), fig.add_subplot(1, 3, 2), fig.add_subplot(1, 3, 3)]
    for ax, art in zip(axs[:2], (True, False)):
        ax.set_aspect("equal")
        ax.set_title(f"art_stress {'on' if art else 'off'}")
        res = results.get(art)
        if res is None:
            ax.text(0.5, 0.5, "not run / run failed", transform=ax.transAxes, ha="center")
            continue
        x = res["last"]["x"][:, :2] * 1e3
        sc = ax.scatter(x[:, 0], x[:, 1], c=res["mets"][-1]["ratio"], s=1.5, cmap="viridis", vmin=0.3, vmax=1.2)
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.text(0.02, 0.01, f"t = {res['t_end'] * 1e6:.0f} us\nnn ratio min {res['mets'][-1]['rmin']:.2f}",
                transform=ax.transAxes, fontsize=8)
        fig.colorbar(sc, ax=ax, shrink=0.6, label="nearest distance / affine-expected")
    ax = axs[2]
    ax.plot(ecf, Scf / 1e6, "k-", lw=1, label="closed form (uniform, JC plane strain)")
    ax.axvspan(0.01, e_c, color="0.9", label="compared (to max load)")
    for art, col in ((True, "C0"), (False, "C3")):
        res = results.get(art)
        if res is None:
            continue
        ss = res["ss"]
        tag = "on" if art else "off"
        ax.plot(ss[:, 2], ss[:, 3] / 1e6, "-", color=col, label=f"art_stress {tag}: gauge strain")
        ax.plot(ss[:, 1], ss[:, 3] / 1e6, ":", color=col, label=f"art_stress {tag}: vs nominal strain")
    ax.set_xlabel("engineering strain")
    ax.set_ylabel("engineering stress S [MPa]")
    ax.set_xlim(0, max(0.32, max((r["ss"][:, 2].max() for r in results.values() if r is not None), default=0.3)))
    ax.legend(fontsize=7)
    fig.suptitle(f"Al 6061-T6 plate, plane-strain tension to 30 % nominal strain (SPH, dx = {dx * 1e3:g} mm)")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "plate_tension.png"), dpi=100)
    on = results.get(True)
    if on is None:
        print("FAIL (the art_stress-on run did not finish)")
        return 1
    ok = [on["rmin"] >= 0.5, on["nc"] == 1 and on["nvoid"] == 0, on["dev"] <= 0.05 and on["nwin"] > 0,
          on["bal"] <= 0.01]
    for k, (name, good) in enumerate(zip(("clumping", "fracture", "stress-strain", "energy"), ok)):
        print(f"  criterion {k + 1} {name}: {'PASS' if good else 'FAIL'}")
    print("PASS" if all(ok) else "FAIL")
    return 0 if all(ok) else 1


if __name__ == "__main__":
    sys.exit(main())
