#!/usr/bin/python3
"""1 kg TNT sphere in free air, 1D spherically symmetric (sph geometry: spherical): peak incident
overpressure and arrival time against Kingery-Bulmash.

Reference: Kingery & Bulmash (1984), BRL-TR-02555, free-air spherical burst, incident
overpressure and arrival-time polynomials log10(Y) = sum C_i U^i, U = K0 + K1 log10 Z (metric
coefficients of /work/shared/reference/README.md section 3.2,
`kingery_bulmash_freeair_spherical_coefficients_metric.csv`). Tolerance: 20 % on Pso at each
Z = 1, 1.5, 2, 3, 4, 5 m/kg^(1/3) (fixed before any run). Arrival times are reported, not judged.

Scene (`scene()`; examples/charge_in_air_1d.yaml is nc = 20): dimension 1, x = r, both sets
`method: sph, geometry: spherical` (what AUTODYN's 1D wedge does for free-air blast). TNT: JWL of
digest 001 Table 1 with the A/B erratum (examples/materials/tnt_001.yaml: rho0 1630 kg/m^3, e0
4.29 MJ/kg, D 6930 m/s), [0, r0] with r0 = (3 W/(4 pi rho0))^(1/3) = 52.7 mm for W = 1 kg, lit
at r = 0 (programmed burn, lighting time r/D). Air: ideal gas gamma 1.4, 1.225 kg/m^3, 101325 Pa,
[r0, L], L = 6.5 m; air spacing dx = r0/nc, the charge's dx/charge_refine (default 4: the
break-out needs the fine charge, README "Break-out"), coupled by `continuum` (which must weigh the spherical sets' neighbours by their line
mass m_line: README "Coupling"), both with `spherical_energy: pair` (the exact pdV pair form; the local
form lost 19 % of the charge energy: README "Cause found"). Symmetry planes at r = 0 (the centre: v(0) = 0) and r = L (the
shock reaches L after t_end). W is the charge mass as built (sum of the shell masses).

Gauges (judged): the scene's probes (docs/core.md "Probes"), one gauge fixed at R = Z (1 kg)^(1/3)
per Z in the air set, recorded EVERY STEP (the Shepard average of the air particles whose support
covers R); Pso = max over the steps of p - 101325 Pa; arrival = first time the overpressure reaches
half of its peak (linear interpolation between steps). Printed beside them, the frame reading
used before the probes existed: at each frame (every --every, default 5 us) the air particle
nearest to R = Z W^(1/3), and the same from every 20 us of those frames (README "Gauge sampling
and artificial conductivity": 20 us read Z = 1 up to 11 % low). W as built differs from 1 kg by
4e-5 (nc 20), so the two gauge positions agree to 1e-5 of R. --cond-air / --cond-cpl: artificial conductivity of the air set
and of the contact (README "Gauge sampling and artificial conductivity at the contact").
--air-renormalize (default 1) / --air-h-factor (default 1.5): the air set's sph `renormalize`
and `h_factor` (README "Density drift": without the renormalisation the continuity density of the
expanding shocked air drifts 20-60 % above the particles' and holds the shell's energy as
compression; 0 / 0 give the runs before).

    /usr/bin/python3 validation/charge_in_air/check.py --build build [--nc 10 20] [--reuse]
    /usr/bin/python3 validation/charge_in_air/check.py --write-example   (examples/charge_in_air_1d.yaml)
"""
import argparse
import math
import os
import sys

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)
import common  # noqa: E402
from check_3d import TNT, kb_pso, kb_ta  # noqa: E402  (KB polynomials, the JWL block)

P0 = 101325.0
RHO_TNT = 1630.0
W = 1.0
ZS = [1.0, 1.5, 2.0, 3.0, 4.0, 5.0]
TOL = 0.20
L = 6.5
T_END = 11e-3
EVERY = 20e-6


def scene(nc, out="out/charge_in_air_1d.h5", t_end=T_END, every=EVERY, charge_refine=1, cond_air=0.0, cond_cpl=0.0,
          air_renormalize=False, air_h_factor=0.0, probes=True):
    """nc: air spacings across r0 (dx = r0/nc); the charge's spacing is dx/charge_refine (README
    "Break-out: the charge's resolution"). cond_air, cond_cpl: artificial conductivity alpha_u of the
    air set (sph `conductivity`) and of the charge/air interface (continuum `conductivity`); 0 is off
    (README "Gauge sampling and artificial conductivity at the contact"). air_renormalize: sph
    `renormalize: true` on the air (the method's default; README "Density drift"); air_h_factor: the
    air's sph h_factor (0: the 1D default, 2)."""
    air_cond = f"\n    conductivity: {cond_air:g}  # artificial conductivity (Price 2008)" if cond_air > 0 else ""
    cpl_cond = f", conductivity: {cond_cpl:g}" if cond_cpl > 0 else ""
    air_ren = ("true  # the sph default: the continuity density stays with the particles (validation/charge_in_air/README.md \"Density drift\")"
               if air_renormalize else "false")
    if air_h_factor > 0:
        air_ren += f"\n    h_factor: {air_h_factor:g}  # h = {air_h_factor:g} dx (1D default 2: same section)"
    r0 = (3 * W / (4 * math.pi * RHO_TNT)) ** (1 / 3)
    dx = r0 / nc
    dxc = dx / charge_refine
    # the outer wall on a lattice line (L - r0 a whole number of spacings): otherwise the last gap
    # differs from dx and the mirror ghost pushes the end particles, which sends a 12 kPa wave inward
    Lw = r0 + dx * round((L - r0) / dx)
    return f"""# 1 kg TNT sphere in free air, 1D spherically symmetric (validation/charge_in_air/check.py, nc = {nc},
# charge spacing dx/{charge_refine}).
# x is the radius; sph geometry: spherical (plugins/methods/sph/README.md "Spherical symmetry").
# The continuum coupling of the two sets needs continuum to read the line mass m_line
# (validation/charge_in_air/README.md "Coupling").
ejecta: 1
dimension: 1
time: {{end: {t_end}, cfl: 0.3}}
output: {{file: {out}, every: {every}, fields: [v, rho, p]}}
materials:
{TNT}
  air: {{rho0: 1.225, eos: {{model: ideal_gas, gamma: 1.4}}}}
sets:
  charge:
    method: sph
    material: tnt
    geometry: spherical
    spherical_energy: pair  # exact pdV pair form (the local form lost 19 % of E0: README)
    renormalize: false  # coupled set (continuum README "Limits")
    h_max: 4
    h_min: 0.25
    rho_min: 1e-4
    shape: {{box: {{min: [0], max: [{r0:.12g}]}}}}
    spacing: {dxc:.12g}
  air:
    method: sph
    material: air
    geometry: spherical
    spherical_energy: pair
    renormalize: {air_ren}{air_cond}
    rho_min: 0.01
    # The innermost air shells are swept out with the products and stretched over r^2: their
    # radial thickness m/(4 pi r^2 rho), hence h, falls 100x (h = 7e-5 m at 0.6 m, dt 6e-9 s).
    # h_min bounds h (and the step) at a quarter of its initial value (the shock compresses 6x).
    h_min: 0.25
    shape: {{box: {{min: [{r0:.12g}], max: [{Lw:.12g}]}}}}
    spacing: {dx:.12g}
    p: 101325
interactions:
  - {{model: continuum, sets: [charge, air]{cpl_cond}}}
boundaries:
  - symmetry: {{point: [0], normal: [1]}}
  - symmetry: {{point: [{Lw:.12g}], normal: [-1]}}
""" + (gauge_block() if probes else "")


def gauge_block():
    """One probe per scaled distance: a gauge fixed at R = Z (1 kg)^(1/3) in the air, every step."""
    lines = ["# Gauges at the scaled distances Z of Kingery-Bulmash, recorded every step (docs/core.md \"Probes\")",
             "probes:"]
    for Z in ZS:
        lines.append(f"  - {{name: z{Z:g}, set: air, point: [{Z * W ** (1 / 3):.12g}], fields: [p]}}")
    return "\n".join(lines) + "\n"


def analyse(h5):
    """Charge mass, gauge histories and peaks."""
    with h5py.File(h5, "r") as f:
        names = sorted(f["frames"].keys())
        g0 = f["frames"][names[0]]
        Wc = float(np.sum(g0["charge"]["m"][()])) if "m" in g0["charge"] else None
        t = np.array([float(f["frames"][n].attrs["time"]) for n in names])
        xs = [f["frames"][n]["air"]["x"][()][:, 0] for n in names]
        ps = [f["frames"][n]["air"]["p"][()] for n in names]
    return Wc, t, xs, ps


def probe_gauges(h5):
    """Peak overpressure and arrival at every step, from the scene's probes (None without them)."""
    with h5py.File(h5, "r") as f:
        if "probe" not in f["series"]:
            return None
        t = f["series"]["energy"]["t"][()]
        res = []
        for Z in ZS:
            g = f["series"]["probe"][f"z{Z:g}"]
            hist = g["p"][()] - P0
            k = int(np.nanargmax(hist))
            peak = float(hist[k])
            ta = float("nan")
            for j in range(1, len(hist)):
                if hist[j] >= 0.5 * peak:
                    ta = t[j - 1] + (0.5 * peak - hist[j - 1]) / (hist[j] - hist[j - 1]) * (t[j] - t[j - 1])
                    break
            res.append(dict(Z=Z, R=Z * W ** (1 / 3), peak=peak, tpeak=t[k], ta=ta, hist=hist, t=t,
                            count=int(np.min(g["count"][()]))))
        return res


def charge_mass(h5):
    with h5py.File(h5, "r") as f:
        cp = f["checkpoint"]["charge"]
        return float(np.sum(cp["m"][()]))


def gauges(t, xs, ps, Wc):
    res = []
    for Z in ZS:
        R = Z * Wc ** (1 / 3)
        hist = np.array([p[np.argmin(np.abs(x - R))] - P0 for x, p in zip(xs, ps)])
        k = int(np.argmax(hist))
        peak = hist[k]
        ta = float("nan")
        for j in range(1, len(hist)):
            if hist[j] >= 0.5 * peak:
                ta = t[j - 1] + (0.5 * peak - hist[j - 1]) / (hist[j] - hist[j - 1]) * (t[j] - t[j - 1])
                break
        res.append(dict(Z=Z, R=R, peak=peak, tpeak=t[k], ta=ta, hist=hist))
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--nc", type=int, nargs="+", default=[10, 20], help="spacings across the charge radius")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--charge-refine", type=int, default=4, help="charge spacing = air spacing / this (README "
                    "\"Break-out\"; 1: the same spacing in both sets, the runs before)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", default=os.path.join(common.ROOT, "out", "charge_in_air_1d"))
    ap.add_argument("--write-example", action="store_true")
    ap.add_argument("--every", type=float, default=5e-6, help="frame interval [s]: the gauges read the frames, so "
                    "a coarse interval misses the peak (README \"Gauge sampling and artificial conductivity\": 20 us read Z = 1 up to 11 %% low)")
    ap.add_argument("--cond-air", type=float, default=1.0, help="sph conductivity (alpha_u) of the air set (0: off, "
                    "the runs before)")
    ap.add_argument("--cond-cpl", type=float, default=1.0, help="continuum conductivity (alpha_u) at the contact (0: off)")
    ap.add_argument("--air-renormalize", type=int, default=1, help="1: sph renormalize: true on the air (README "
                    "\"Density drift\"; 0: the runs before)")
    ap.add_argument("--air-h-factor", type=float, default=1.5, help="sph h_factor of the air (README \"Density drift\"; "
                    "0: the 1D default 2, the runs before)")
    ap.add_argument("--t-end", type=float, default=T_END, help="end time [s] (short diagnostic runs)")
    ap.add_argument("--fd", nargs="*", default=[], help="lagrange1d.py --save files: the FD reference's peaks in the "
                    "figure (label from the file name)")
    a = ap.parse_args(argv)
    if a.write_example:
        path = os.path.join(common.ROOT, "examples", "charge_in_air_1d.yaml")
        with open(path, "w") as f:
            f.write(scene(20, every=a.every, charge_refine=a.charge_refine, cond_air=a.cond_air, cond_cpl=a.cond_cpl,
                          air_renormalize=bool(a.air_renormalize), air_h_factor=a.air_h_factor))
        print("wrote", path)
        return 0
    exe = common.ejecta_binary(a.build)
    runs = {}
    for nc in a.nc:
        name = f"charge_1d_nc{nc}" + (f"_c{a.charge_refine}" if a.charge_refine != 1 else "")
        name += f"_e{1e6 * a.every:g}us" if a.every != EVERY else ""
        name += f"_ka{a.cond_air:g}" if a.cond_air > 0 else ""
        name += f"_kc{a.cond_cpl:g}" if a.cond_cpl > 0 else ""
        name += "_ren" if a.air_renormalize else ""
        name += f"_h{a.air_h_factor:g}" if a.air_h_factor > 0 else ""
        name += f"_t{1e3 * a.t_end:g}ms" if a.t_end != T_END else ""
        h5, wall = common.run(exe, scene(nc, out=name + ".h5", t_end=a.t_end, every=a.every, charge_refine=a.charge_refine,
                                         cond_air=a.cond_air, cond_cpl=a.cond_cpl,
                                         air_renormalize=bool(a.air_renormalize), air_h_factor=a.air_h_factor),
                              name, a.out,
                              threads=a.threads, reuse=a.reuse)
        Wc = charge_mass(h5)
        _, t, xs, ps = analyse(h5)
        runs[nc] = dict(h5=h5, W=Wc, gf=gauges(t, xs, ps, Wc), t=t, wall=wall)
        runs[nc]["gp"] = probe_gauges(h5)
        if runs[nc]["gp"] is None:
            sys.exit(f"{h5}: no probes (an output of check.py before the probes; rerun without --reuse)")
        runs[nc]["g"] = runs[nc]["gp"]
        # the same gauges read every 20 us only (the frame interval of the runs before: README "Gauge sampling and artificial conductivity")
        k20 = max(1, int(round(EVERY / a.every)))
        runs[nc]["g20"] = gauges(t[::k20], xs[::k20], ps[::k20], Wc)
        e = common.read_series(h5)
        bal = np.max(np.abs(e["balance"])) / abs(e["kinetic"][0] + e["internal"][0])
        runs[nc]["balance"] = bal
        runs[nc]["balance_end"] = abs(e["balance"][-1]) / abs(e["kinetic"][0] + e["internal"][0])
        runs[nc]["steps"] = int(e["step"][-1])
    ok = True
    main_nc = max(a.nc)
    print(f"\nKingery-Bulmash free air, tolerance {100 * TOL:.0f} % on Pso (judged at nc = {main_nc}; the others "
          "show convergence)")
    for nc in a.nc:
        r = runs[nc]
        print(f"\nnc = {nc}: dx = {1e3 * (3 / (4 * math.pi * RHO_TNT)) ** (1 / 3) / nc:.3f} mm, W = {r['W']:.4f} kg, "
              f"{r['steps']} steps, max |balance|/E0 = {r['balance']:.2e} (end {r['balance_end']:.2e})")
        print("   Z    R [m]   KB Pso [kPa]  Pso [kPa]   error   KB ta [ms]  ta [ms]  error   verdict   "
              f"(frame readings, nearest particle: every {1e6 * a.every:g} us; every 20 us)")
        for g, gf, g20 in zip(r["g"], r["gf"], r["g20"]):
            kb = kb_pso(g["Z"])
            err = (g["peak"] - kb) / kb
            ta_kb = kb_ta(g["Z"], r["W"])
            eta = (g["ta"] - ta_kb) / ta_kb
            verdict = "PASS" if abs(err) <= TOL else "FAIL"
            if nc == main_nc and abs(err) > TOL:
                ok = False
            print(f"  {g['Z']:3.1f}  {g['R']:6.3f}   {kb / 1e3:9.1f}   {g['peak'] / 1e3:9.1f}  {100 * err:+6.1f} %"
                  f"   {1e3 * ta_kb:7.3f}   {1e3 * g['ta']:7.3f}  {100 * eta:+6.1f} %   "
                  f"{verdict if nc == main_nc else '(' + verdict + ')'}   "
                  f"({gf['peak'] / 1e3:.1f}, {100 * (gf['peak'] - kb) / kb:+.1f} %; "
                  f"{g20['peak'] / 1e3:.1f}, {100 * (g20['peak'] - kb) / kb:+.1f} %)")
    figure(runs, a.nc, os.path.join(HERE, "charge_in_air_1d.png"), fd=a.fd, refine=a.charge_refine)
    common.energy_figure(runs[main_nc]["h5"], os.path.join(HERE, "charge_in_air_1d_energy.png"),
                         title=f"1 kg TNT in air, 1D spherical, nc = {main_nc}: energy budget")
    print(f"\n{'PASS' if ok else 'FAIL'}: peak incident overpressure within {100 * TOL:.0f} % of Kingery-Bulmash at "
          f"every Z (nc = {main_nc})")
    return 0 if ok else 1


def figure(runs, ncs, png, fd=(), refine=1):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
    Zc = np.logspace(np.log10(0.8), np.log10(6), 100)
    ax[0].loglog(Zc, [kb_pso(z) / 1e3 for z in Zc], "k-", label="Kingery-Bulmash (free air)")
    ax[0].fill_between(Zc, [0.8 * kb_pso(z) / 1e3 for z in Zc], [1.2 * kb_pso(z) / 1e3 for z in Zc], color="0.85",
                       label="±20 %")
    for nc, mk in zip(ncs, "osd^v"):
        r = runs[nc]
        ax[0].loglog([g["Z"] for g in r["g"]], [g["peak"] / 1e3 for g in r["g"]], mk, ms=7, mfc="none",
                     label=f"ejecta sph 1D spherical, r0/dx = {nc} (charge {nc * refine})")
    for path, mk in zip(fd, "+x*12"):
        d = np.load(path)
        ax[0].loglog(d["Z"], d["peak"] / 1e3, mk, ms=8, label=f"Lagrangian FD (lagrange1d.py) {os.path.basename(path)}")
    ax[0].set_xlabel("Z [m/kg$^{1/3}$]")
    ax[0].set_ylabel("peak incident overpressure [kPa]")
    ax[0].legend()
    ax[0].grid(True, which="both", alpha=0.3)
    r = runs[max(ncs)]
    for g in r["g"]:
        line, = ax[1].plot(1e3 * g["t"], g["hist"] / 1e3, label=f"Z = {g['Z']:g}")
        ax[1].axvline(1e3 * kb_ta(g["Z"], r["W"]), color=line.get_color(), ls=":", lw=1)
        ax[1].plot([1e3 * kb_ta(g["Z"], r["W"])], [kb_pso(g["Z"]) / 1e3], "x", color=line.get_color())
    ax[1].set_yscale("symlog", linthresh=10)
    ax[1].set_xlabel("t [ms]")
    ax[1].set_ylabel("overpressure at the gauge [kPa]")
    ax[1].set_title(f"r0/dx = {max(ncs)}, gauges every step; x, dotted: KB peak and arrival")
    ax[1].legend(fontsize=8)
    ax[1].grid(True, alpha=0.3)
    fig.suptitle("1 kg TNT sphere in free air (JWL, digest 001 with erratum), 1D spherical SPH")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    print("wrote", png)


if __name__ == "__main__":
    sys.exit(main())
