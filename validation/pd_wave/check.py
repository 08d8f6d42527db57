#!/usr/bin/python3
"""Long-wave speed of a 1D peridynamic bar (pd, model pmb): bond-based PD against elasticity.

Reference (derivation in README.md): a 1D PMB bar with micromodulus c, horizon delta and
cross-section A has, for waves much longer than delta, the elastic modulus E = c A delta^2 / 2
(Silling, J. Mech. Phys. Solids 48 (2000) 175, 1D micromodulus c = 2E/(A delta^2); Bobaru et
al., Int. J. Numer. Meth. Eng. 77 (2009) 852, Eq 5), so the long-wave speed is
c0 = sqrt(E / rho) = delta sqrt(c A / (2 rho)). The scene sets c = 2E/(A delta^2) for E = 1 GPa,
rho = 2000 kg/m^3: c0 = 707.107 m/s. The discrete lattice sum with LAMMPS's partial-volume
scaling gives the long-wave speed c_h^2 = (c / 2 rho) sum_j V_j beta_j |xi_j| (printed too).

A smooth velocity pulse v = cos^2(pi (x - L/2) / (2 w)) (w = 0.05 m, 1 mm spacing, delta =
3.0001 mm, L = 1 m) splits into two halves running at -c and +c; the speed is the least-squares
slope of the centroid of v^2 over x > L/2 against time, for t >= 1.4 w / c0.
Tolerance: |c_measured / c0 - 1| < 1 %. Also the energy balance error < 0.1 % of the initial energy.
"""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402

RHO, E = 2000.0, 1.0e9
TOL_C, TOL_E = 0.01, 0.001


def scene(dx, out, t_end, L=1.0, w=0.05, m=3.0001):
    delta = m * dx
    A = 1.0  # 1D: vol0 = dx, i.e. a unit cross-section
    c = 2.0 * E / (A * delta * delta)
    n = int(round(L / dx))
    xc = L / 2
    strips = []
    for i in range(n):
        x = (i + 0.5) * dx
        if abs(x - xc) < w:
            v = math.cos(math.pi * (x - xc) / (2 * w)) ** 2
            strips.append(f"      - {{region: {{box: {{min: [{x - dx / 2:.9g}], max: [{x + dx / 2:.9g}]}}}}, "
                          f"velocity: [{v:.9g}]}}")
    text = f"""ejecta: 1
dimension: 1
time: {{end: {t_end:.6g}, cfl: 0.5}}
output: {{file: {out}, every: {t_end / 20:.6g}, fields: [v, damage]}}
materials:
  bar: {{rho0: {RHO}}}
sets:
  bar:
    method: pd
    model: pmb
    material: bar
    shape: {{box: {{min: [0], max: [{L}]}}}}
    spacing: {dx}
    horizon: {delta:.9g}
    c: {c:.12g}
    lattice_spacing: {dx}
    contact: false
    initial:
""" + "\n".join(strips) + "\n"
    return text, delta, c


def discrete_speed(dx, delta, c):
    """Long-wave speed of the discrete lattice: c_h^2 = (c / 2 rho) sum_j V_j beta_j |xi_j|."""
    s = 0.0
    n = int(math.floor(delta / dx + 1e-9))
    for k in range(1, n + 1):
        xi = k * dx
        beta = (delta + dx / 2 - xi) / dx if abs(xi - delta) <= dx / 2 else 1.0
        s += 2 * dx * beta * xi
    return math.sqrt(c * s / (2 * RHO))


def centroid_speed(path, L, w, c0):
    ts, xs = [], []
    for fr in common.frames(path):
        d = common.read_frame(path, fr)
        t = d["time"]
        if t < 1.4 * w / c0:
            continue
        x = d["x"].reshape(len(d["x"]), -1)[:, 0]
        v = d["v"].reshape(len(d["v"]), -1)[:, 0]
        sel = x > L / 2
        wgt = v[sel] ** 2
        ts.append(t)
        xs.append(np.sum(x[sel] * wgt) / np.sum(wgt))
    ts, xs = np.array(ts), np.array(xs)
    slope = np.polyfit(ts, xs, 1)[0]
    return slope, ts, xs


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/validation/pd_wave")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    L, w, dx = 1.0, 0.05, 1.0e-3
    c0 = math.sqrt(E / RHO)
    t_end = 0.5 * (L / 2 - 2 * w) / c0
    os.makedirs(args.out, exist_ok=True)
    text, delta, c = scene(dx, os.path.join(args.out, "pd_wave.h5"), t_end, L, w)
    path, wall = common.run(exe, text, "pd_wave", args.out, threads=args.threads)
    speed, ts, xs = centroid_speed(path, L, w, c0)
    ch = discrete_speed(dx, delta, c)
    err = speed / c0 - 1
    ser = common.read_series(path) if hasattr(common, "read_series") else None
    import h5py
    with h5py.File(path, "r") as f:
        bal = f["series/energy/balance"][()]
        e0 = f["series/energy/kinetic"][0] + f["series/energy/internal"][0]
    eerr = float(np.max(np.abs(bal)) / e0)
    ok_c, ok_e = abs(err) < TOL_C, eerr < TOL_E
    print(f"pd_wave (1D PMB, dx = {dx * 1e3:g} mm, delta = {delta * 1e3:.4f} mm, c = {c:.6g} N/m^6)")
    print(f"  long-wave speed: analytic c0 = sqrt(E/rho) = {c0:.3f} m/s, discrete lattice sum {ch:.3f} m/s "
          f"({ch / c0 - 1:+.4%})")
    print(f"  measured {speed:.3f} m/s, error {err:+.4%} (tolerance 1 %): {'PASS' if ok_c else 'FAIL'}")
    print(f"  energy balance error {eerr:.2e} of the initial energy (tolerance 1e-3): {'PASS' if ok_e else 'FAIL'}")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    frs = common.frames(path)
    for fr in (frs[0], frs[len(frs) // 2], frs[-1]):
        d = common.read_frame(path, fr)
        x = d["x"].reshape(len(d["x"]), -1)[:, 0]
        v = d["v"].reshape(len(d["v"]), -1)[:, 0]
        o = np.argsort(x)
        ax[0].plot(x[o], v[o], label=f"t = {d['time'] * 1e6:.0f} us")
    ax[0].set_xlabel("x [m]"), ax[0].set_ylabel("v [m/s]"), ax[0].legend(), ax[0].set_title("velocity pulse")
    ax[1].plot(ts * 1e6, xs, "o", label="ejecta: centroid of v^2, x > L/2")
    ax[1].plot(ts * 1e6, xs[0] + c0 * (ts - ts[0]), "-", label=f"c0 = sqrt(E/rho) = {c0:.1f} m/s")
    ax[1].set_xlabel("t [us]"), ax[1].set_ylabel("centroid [m]"), ax[1].legend()
    ax[1].set_title(f"speed {speed:.2f} m/s, error {err:+.3%}")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "pd_wave.png"), dpi=110)
    print(f"  figure {os.path.join(HERE, 'pd_wave.png')}")
    # The run through the user tools: v along x at the last frame against d'Alembert's solution
    # with c0 (tools/compare.py) and the energy budget (tools/plot_series.py).
    t_last = common.read_frame(path)["time"]
    xe = np.linspace(0, L, 4001)

    def pulse(x):
        return np.where(np.abs(x - L / 2) < w, np.cos(np.pi * (x - L / 2) / (2 * w)) ** 2, 0.0)

    ref_csv = os.path.join(args.out, "pd_wave_exact.csv")
    np.savetxt(ref_csv, np.column_stack([xe, 0.5 * (pulse(xe - c0 * t_last) + pulse(xe + c0 * t_last))]),
               delimiter=",", header="x,v", comments="")
    l1r, linfr = common.profile_figure(path, "bar", "v", ref_csv, os.path.join(HERE, "pd_wave_compare.png"),
                                       component="x", axis="x")
    common.energy_figure(path, os.path.join(HERE, "pd_wave_energy.png"), title="pd_wave (1D PMB, dx = 1 mm): energy budget")
    print(f"  tools/compare.py, v(x) at t = {t_last * 1e6:.1f} us against d'Alembert with c0: L1_rel = {l1r:.4f}, "
          f"Linf_rel = {linfr:.3f} (shown, not a criterion); figures pd_wave_compare.png, pd_wave_energy.png")
    print("PASS" if ok_c and ok_e else "FAIL")
    return 0 if ok_c and ok_e else 1


if __name__ == "__main__":
    sys.exit(main())
