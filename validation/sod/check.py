#!/usr/bin/python3
"""Sod shock tube: ejecta (SPH, ideal gas) against the exact Riemann solution at t = 0.2 s.

Reference: G. A. Sod, J. Comput. Phys. 27 (1978) 1-31; exact solution after E. F. Toro,
"Riemann Solvers and Numerical Methods for Fluid Dynamics", 3rd ed., ch. 4 (exact.py).

Error measure: L1(rho) = sum_i V_i |rho_i - rho_exact(x_i)| / sum_i V_i over the particles with
-0.4 <= x_i <= 0.4, V_i = m_i / rho_i (a particle quadrature of the L1 norm of the density
error divided by the length of the window). Runs the 1D tube (examples/sod_1d.yaml) at
spacings 0.005, 0.0025, 0.00125 and the 3D periodic tube (examples/sod_3d.yaml, cross-section
0.04 x 0.04) at spacings 0.02, 0.01, projected on x; one lattice spacing on both sides of the
diaphragm, initial jump smoothed over 1.5 h (see sod_scene). --full adds 0.000625 in 1D and
0.005 in 3D. `--write-examples` regenerates examples/sod_1d.yaml, sod_3d.yaml, sod_3d_shape.yaml and
sod_1d_shape_jitter.yaml.

Tolerances (see README.md): 1D L1(rho) at the finest spacing < 0.01 and observed order >= 0.8;
3D L1(rho) at each spacing < 1.5 x the 1D value at the same left spacing and order >= 0.8.
"""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402
import exact  # noqa: E402

T_END = 0.2
WINDOW = 0.4
TOL_L1_1D = 0.01
TOL_ORDER = 0.8
TOL_3D_RATIO = 1.5

# Monaghan & Gingold (1983) smooth the initial discontinuity over about one kernel width: with
# a sharp jump, the evolved (continuity-equation) density of the first particles across the
# diaphragm collapses and their smoothing lengths run away (see README.md). Here rho and p follow
# rho_L + (rho_R - rho_L) (1 + tanh(x / w)) / 2 with w = 1.5 h, h = h_factor dx with the sph
# method's per-dimension default h_factor (2.0 in 1D, 1.3 in 3D), written as one `initial`
# strip per lattice column with |x| < 5 w; the set-wide values are the left state.
H_FACTOR = {1: 2.0, 2: 1.5, 3: 1.3}
SMOOTH_W = 1.5


def sod_scene(dim, dx, t_end=T_END, width=0.04, out="out/sod.h5", every=0.05, header="", gradient="kernel",
              jitter=0.0, density=None, jitter_volume=None):
    """Scene text of the Sod tube: dim 1, or 3 with a periodic square cross-section [0, width]^2.
    gradient "kernel": the kernel gradient (with the correction in 3D); "shape_tensor": the
    consistent SPH of digest 000 Eqs 29-37 (sph gradient: shape_tensor)."""
    w = SMOOTH_W * H_FACTOR[dim] * dx
    n = int(round(1.0 / dx))
    lo3 = ", 0, 0" if dim == 3 else ""
    hi3 = f", {width:g}, {width:g}" if dim == 3 else ""
    z3 = ", 0, 0" if dim == 3 else ""
    strips = []
    for i in range(n):
        x = -0.5 + (i + 0.5) * dx
        if abs(x) >= 5 * w:
            continue
        f = 0.5 * (1.0 + math.tanh(x / w))
        rho, p = 1.0 + (0.125 - 1.0) * f, 1.0 + (0.1 - 1.0) * f
        strips.append(f"      - {{region: {{box: {{min: [{x - dx / 2:.8g}{lo3}], max: [{x + dx / 2:.8g}{hi3}]}}}}, "
                      f"rho: {rho:.8g}, p: {p:.8g}}}")
    x_right = -0.5 + (n // 2 + 0.5) * dx  # first column right of the diaphragm
    lines = [header.rstrip("\n")] if header else []
    lines += [
        "ejecta: 1",
        f"dimension: {dim}",
        f"time: {{end: {t_end:g}, cfl: 0.3}}",
        f"output: {{file: {out}, every: {every:g}, fields: [v, m, rho, p, e, h]}}",
        "materials:",
        "  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}",
        "sets:",
        "  tube:",
        "    method: sph",
    ] + (["    # consistent SPH (digest 000 Eqs 29-37): current shape tensor gradient",
          "    gradient: shape_tensor"] if gradient == "shape_tensor" else
         ["    # one-sided compression of a 3D lattice: the kernel gradient correction keeps the",
          "    # pressure gradient and the density rate exact (without it the star state is 7 % off)",
          "    correction: true"] if dim > 1 else []) + [
        "    material: gas",
        f"    shape: {{box: {{min: [-0.5{lo3}], max: [0.5{hi3}]}}}}",
        f"    spacing: {dx:g}",
    ] + ([f"    jitter: {jitter:g}", "    seed: 7"] if jitter > 0 else []) + (
        [f"    jitter_volume: {jitter_volume}"] if jitter > 0 and jitter_volume else []) + (
        [f"    density: {density}"] if density else []) + [
        "    rho: 1",
        "    p: 1",
        "    initial:",
        f"      - {{region: {{box: {{min: [0{lo3}], max: [0.5{hi3}]}}}}, rho: 0.125, p: 0.1}}",
    ] + strips + [
        "boundaries:",
        f"  - symmetry: {{point: [-0.5{z3}], normal: [1{z3}]}}",
        f"  - symmetry: {{point: [0.5{z3}], normal: [-1{z3}]}}",
    ]
    if dim == 3:
        lines += [f"  - periodic: {{axis: y, min: 0, max: {width:g}}}",
                  f"  - periodic: {{axis: z, min: 0, max: {width:g}}}"]
    assert x_right > 0
    return "\n".join(lines) + "\n"


EXAMPLE_COMMON = """#
# Reference: G. A. Sod, J. Comput. Phys. 27 (1978) 1-31; exact solution by the Riemann solver of
# E. F. Toro, "Riemann Solvers and Numerical Methods for Fluid Dynamics", 3rd ed., ch. 4
# (validation/sod/exact.py). validation/sod/check.py compares with it at t = 0.2 s.
#
# Left (x < 0): rho = 1, p = 1; right (x > 0): rho = 0.125, p = 0.1; gamma = 1.4. One lattice
# spacing on both sides (the right particles are 8x lighter). As in Monaghan & Gingold,
# J. Comput. Phys. 52 (1983) 374, the initial jump is smoothed over about one kernel width:
# rho and p follow (1 + tanh(x / w)) / 2 with w = 1.5 h (3 spacings in 1D, 1.95 in 3D: sph's default
# h is 2 spacings in 1D, 1.3 in 3D), one `initial` strip per particle column (a sharp jump makes the
# first particles across it blow up in this SPH formulation: evolved density and
# h = h_factor (m/rho)^(1/dim)). Symmetry planes (mirror walls)
# close the tube at x = -0.5 and 0.5; the waves do not reach them by t = 0.2 s.
# Generated by `validation/sod/check.py --write-examples`.
"""
EXAMPLE_1D = """# Sod shock tube in one dimension (SPH, ideal gas): shock, contact and rarefaction from one
# diaphragm, captured with the Monaghan artificial viscosity. 400 particles, spacing 2.5 mm.
""" + EXAMPLE_COMMON
EXAMPLE_3D = """# Sod shock tube in three dimensions: the 1D problem solved by the 3D code path (cubic lattice,
# periodic ghost images in y and z, symmetry planes closing the tube in x). Projected on x, the
# particles follow the exact 1D solution. Spacing 10 mm, cross-section 40 x 40 mm periodic:
# 100 x 4 x 4 = 1600 particles.
""" + EXAMPLE_COMMON
EXAMPLE_3D_SHAPE = """# Sod shock tube in three dimensions with the consistent SPH of Fan & Li (digest 000 Eqs 29-37):
# gradients from the current shape tensor M_i = sum_j V_j w_ij x_ij (x) x_ij (sph gradient:
# shape_tensor, default shape_form symmetric: momentum and energy conserved). Same tube as
# sod_3d.yaml (100 x 4 x 4 = 1600 particles); the run prints the shape-tensor fallbacks and
# writes their per-step count to /series/tube/gradient_fallbacks.
""" + EXAMPLE_COMMON

EXAMPLE_1D_SHAPE_JITTER = """# Sod shock tube in one dimension on a jittered lattice (issue 3's hard case): every particle moved
# by up to +-15 % of the spacing (jitter: 0.3, seed 7), the consistent SPH of Fan & Li (gradient:
# shape_tensor) with the continuity density, and jitter_volume: kernel, which gives each particle
# the volume (and mass) its neighbourhood holds instead of its lattice cell's (docs/core.md,
# "Geometry"). validation/sod/check.py: L1(rho) 1.30 x the regular lattice's at this spacing (2.40 x
# with the cells' volumes). 400 particles, spacing 2.5 mm.
""" + EXAMPLE_COMMON


def l1_density(d):
    x = d["x"][:, 0]
    rho = d["rho"]
    vol = d["m"] / rho
    ex, _, _, _ = exact.sample(x, d["time"], exact.SOD_LEFT, exact.SOD_RIGHT)
    w = np.abs(x) <= WINDOW
    return float(np.sum(vol[w] * np.abs(rho[w] - ex[w])) / np.sum(vol[w]))


def plot_profiles(d, title, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    x = d["x"][:, 0]
    xe = np.linspace(-0.5, 0.5, 2001)
    rho_e, u_e, p_e, e_e = exact.sample(xe, d["time"], exact.SOD_LEFT, exact.SOD_RIGHT)
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    for ax, (key, ye, label) in zip(axes.flat, [("rho", rho_e, r"density $\rho$ [kg/m$^3$]"),
                                                ("v", u_e, r"velocity $u$ [m/s]"),
                                                ("p", p_e, r"pressure $p$ [Pa]"),
                                                ("e", e_e, r"specific internal energy $e$ [J/kg]")]):
        y = d[key][:, 0] if key == "v" else d[key]
        ax.plot(x, y, ".", ms=3, color="C0", label="ejecta (SPH)")
        ax.plot(xe, ye, "-", lw=1, color="k", label="exact (Toro ch. 4)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("x [m]")
    axes[0, 0].legend()
    fig.suptitle(f"{title}, t = {d['time']:.3f} s")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_convergence(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for key, marker in (("1d", "o"), ("3d", "s")):
        if not res.get(key):
            continue
        h = np.array([r[0] for r in res[key]])
        e = np.array([r[1] for r in res[key]])
        ax.loglog(h, e, marker + "-", label=f"{key.upper()} (slope {common.order(h, e)[0]:.2f})")
    h = np.array([r[0] for r in res["1d"]])
    e0 = res["1d"][0][1]
    ax.loglog(h, e0 * h / h[0], "k--", lw=0.8, label="first order")
    ax.axhline(TOL_L1_1D, color="r", lw=0.8, ls=":", label=f"tolerance {TOL_L1_1D}")
    ax.set_xlabel("left particle spacing [m]")
    ax.set_ylabel(r"L1($\rho$) over $|x| \leq 0.4$ at t = 0.2 s")
    ax.set_title("Sod shock tube: convergence")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def series_drift(path):
    """Momentum and energy drift of a run: (P_x(end) - P_x exact) / P_x exact, where P_x exact =
    (p_L - p_R) t_end times the cross-section (the walls at x = +-0.5 are not reached by t_end),
    and max |balance| / initial total from /series/energy."""
    es = common.read_series(path)
    d = common.read_frame(path)
    area = 1.0 if d["x"].shape[1] == 1 or np.ptp(d["x"][:, 1]) == 0 else None
    if area is None:
        area = float(np.sum(d["m"]) / (0.5 * 1.0 + 0.5 * 0.125))  # total mass / mean density per length
    px_exact = (1.0 - 0.1) * float(es["t"][-1]) * area
    total0 = es["kinetic"][0] + es["internal"][0]
    return ((es["momentum_x"][-1] - px_exact) / px_exact, float(np.max(np.abs(es["balance"])) / total0))


def run_gradient(gradient, exe, args, spacings_1d, spacings_3d):
    tag = "" if gradient == "kernel" else "_shape"
    print(f"\n== gradient: {gradient}" + (" (3D: with the kernel gradient correction)" if gradient == "kernel" else
                                          " (consistent SPH, digest 000 Eqs 29-37; sph shape_form: symmetric)"))
    res = {"1d": [], "3d": []}
    last = {}
    drift = []
    for dx in spacings_1d:
        name = f"sod_1d{tag}_{dx:g}"
        path, wall = common.run(exe, sod_scene(1, dx, gradient=gradient),
                                name, args.out, args.threads, args.reuse)
        d = common.read_frame(path)
        assert abs(d["time"] - T_END) < 1e-9, f"{path}: last frame at t = {d['time']}"
        res["1d"].append((dx, l1_density(d), len(d["rho"]), wall))
        drift.append(series_drift(path))
        last["1d"] = d
    for dx in spacings_3d:
        name = f"sod_3d{tag}_{dx:g}"
        path, wall = common.run(exe, sod_scene(3, dx, width=0.04, gradient=gradient),
                                name, args.out, args.threads, args.reuse)
        d = common.read_frame(path)
        assert abs(d["time"] - T_END) < 1e-9, f"{path}: last frame at t = {d['time']}"
        res["3d"].append((dx, l1_density(d), len(d["rho"]), wall))
        drift.append(series_drift(path))
        last["3d"] = d

    ok = True
    print(f"\n  gradient: {gradient}")
    print(f"  {'case':<4} {'spacing':>9} {'particles':>9} {'L1(rho)':>10} {'order':>6} {'run [s]':>8}")
    for key in ("1d", "3d"):
        for k, (dx, err, n, wall) in enumerate(res[key]):
            o = "" if k == 0 else f"{np.log(res[key][k - 1][1] / err) / np.log(res[key][k - 1][0] / dx):6.2f}"
            print(f"  {key:<4} {dx:9.6f} {n:9d} {err:10.5f} {o:>6} {wall:8.1f}")
    h1 = [r[0] for r in res["1d"]]
    e1 = [r[1] for r in res["1d"]]
    slope1, _ = common.order(h1, e1)
    c1 = e1[-1] < TOL_L1_1D
    c2 = slope1 >= TOL_ORDER
    print(f"\n  1D L1(rho) at spacing {h1[-1]:g}: {e1[-1]:.5f} (tolerance < {TOL_L1_1D})  {'PASS' if c1 else 'FAIL'}")
    print(f"  1D observed order (least squares): {slope1:.2f} (tolerance >= {TOL_ORDER})  {'PASS' if c2 else 'FAIL'}")
    ok &= c1 and c2
    if res["3d"]:
        h3 = [r[0] for r in res["3d"]]
        e3 = [r[1] for r in res["3d"]]
        slope3, _ = common.order(h3, e3)
        ref = dict((r[0], r[1]) for r in res["1d"])
        for dx, err in zip(h3, e3):
            if dx in ref:
                c = err < TOL_3D_RATIO * ref[dx]
                print(f"  3D L1(rho) at spacing {dx:g}: {err:.5f} vs 1D {ref[dx]:.5f} "
                      f"(tolerance < {TOL_3D_RATIO} x 1D)  {'PASS' if c else 'FAIL'}")
                ok &= c
        c3 = slope3 >= TOL_ORDER
        print(f"  3D observed order (least squares): {slope3:.2f} (tolerance >= {TOL_ORDER})  {'PASS' if c3 else 'FAIL'}")
        ok &= c3

    worst_p = max(abs(q[0]) for q in drift)
    worst_e = max(abs(q[1]) for q in drift)
    print(f"  conservation over the runs: max |P_x(end) - P_x exact| / P_x exact = {worst_p:.2e}, "
          f"max |energy balance| / total0 = {worst_e:.2e}")
    gl = "" if gradient == "kernel" else ", gradient: shape_tensor"
    plot_profiles(last["1d"], f"Sod 1D{gl}, left spacing {h1[-1]:g} m", os.path.join(HERE, f"sod_1d{tag}.png"))
    if res["3d"]:
        plot_profiles(last["3d"], f"Sod 3D periodic tube projected on x{gl}, left spacing {res['3d'][-1][0]:g} m",
                      os.path.join(HERE, f"sod_3d{tag}.png"))
    plot_convergence(res, os.path.join(HERE, f"sod_convergence{tag}.png"))
    # The finest 1D run through the user tools: density along x against the exact solution
    # (tools/compare.py) and the energy budget (tools/plot_series.py).
    finest = os.path.join(args.out, f"sod_1d{tag}_{h1[-1]:g}.h5")
    xe = np.linspace(-0.5, 0.5, 2001)
    ref_csv = os.path.join(args.out, "sod_exact.csv")
    np.savetxt(ref_csv, np.column_stack([xe, exact.sample(xe, T_END, exact.SOD_LEFT, exact.SOD_RIGHT)[0]]),
               delimiter=",", header="x,rho", comments="")
    l1r, linfr = common.profile_figure(finest, "tube", "rho", ref_csv, os.path.join(HERE, f"sod_1d{tag}_compare.png"),
                                       axis="x")
    common.energy_figure(finest, os.path.join(HERE, f"sod_1d{tag}_energy.png"),
                         title=f"Sod 1D{gl}, spacing {h1[-1]:g} m: energy budget")
    print(f"  tools/compare.py on the finest 1D run: L1_rel(rho) = {l1r:.4f}, Linf_rel = {linfr:.3f}")
    print(f"  figures: validation/sod/sod_1d{tag}.png, sod_3d{tag}.png, sod_convergence{tag}.png, "
          f"sod_1d{tag}_compare.png, sod_1d{tag}_energy.png")
    print(f"  gradient {gradient}: {'PASS' if ok else 'FAIL'}")
    return ok


JITTER = 0.3
TOL_JITTER_RATIO = 2.0


def run_jitter(exe, args, spacings):
    """Hard case of issue 3: the 1D lattice perturbed by 30 % of the spacing (jitter 0.3: uniform
    in +-0.15 dx, seed 7); L1(rho) must stay below 2 x the regular lattice's at the same settings.
    Judged for each gradient with the setting that makes the initial density follow the particle
    arrangement: the kernel gradient with density: summation, the shape tensor (whose summation
    density is not usable, README) with the continuity density and jitter_volume: kernel (the
    particles' volumes from the jittered arrangement, docs/core.md "Geometry"). The rows with
    the lattice cells' volumes (jitter_volume: cell, the default) are printed beside."""
    print("\n== hard case: jittered lattice (jitter 0.3, seed 7), 1D")
    print(f"  {'gradient':<13} {'density':<11} {'volume':<7} {'spacing':>8} {'regular':>9} {'jittered':>9} {'ratio':>6}")
    ok = True
    for gradient, density, volume, judged in (("kernel", "continuity", "cell", False),
                                              ("kernel", "continuity", "kernel", False),
                                              ("kernel", "summation", "cell", True),
                                              ("shape_tensor", "continuity", "cell", False),
                                              ("shape_tensor", "continuity", "kernel", True)):
        tag = ("" if gradient == "kernel" else "_shape") + ("" if density == "continuity" else "_sum") + (
            "" if volume == "cell" else "_kvol")
        for dx in spacings:
            err = []
            for jit in (0.0, JITTER):
                name = f"sod_jit{tag}_{jit:g}_{dx:g}"
                path, _ = common.run(exe, sod_scene(1, dx, gradient=gradient, jitter=jit, density=density,
                                                    jitter_volume=volume if volume != "cell" else None),
                                     name, args.out, args.threads, args.reuse)
                err.append(l1_density(common.read_frame(path)))
            ratio = err[1] / err[0]
            c = ratio < TOL_JITTER_RATIO
            verdict = ("PASS" if c else "FAIL") if judged else ("pass" if c else "fail") + " (not judged)"
            print(f"  {gradient:<13} {density:<11} {volume:<7} {dx:8.5f} {err[0]:9.5f} {err[1]:9.5f} {ratio:6.2f}  {verdict}")
            if judged:
                ok &= c
    print(f"  hard case (kernel gradient with density: summation; shape tensor with jitter_volume: kernel; "
          f"ratio < {TOL_JITTER_RATIO}): {'PASS' if ok else 'FAIL'}")
    return ok


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--full", action="store_true", help="one more resolution in 1D and 3D")
    ap.add_argument("--out", default=os.path.join(common.ROOT, "out", "validation", "sod"))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reuse", action="store_true", help="read existing outputs instead of running")
    ap.add_argument("--no-3d", action="store_true")
    ap.add_argument("--no-jitter", action="store_true", help="skip the jittered-lattice hard case")
    ap.add_argument("--gradient", choices=["kernel", "shape_tensor", "both"], default="both",
                    help="sph gradient operator(s) to validate (default both, one table each)")
    ap.add_argument("--write-examples", action="store_true", help="regenerate the example scenes and exit")
    args = ap.parse_args()
    if args.write_examples:
        for name, dim, dx, head, grad, jit in (("sod_1d", 1, 0.0025, EXAMPLE_1D, "kernel", 0.0),
                                               ("sod_3d", 3, 0.01, EXAMPLE_3D, "kernel", 0.0),
                                               ("sod_3d_shape", 3, 0.01, EXAMPLE_3D_SHAPE, "shape_tensor", 0.0),
                                               ("sod_1d_shape_jitter", 1, 0.0025, EXAMPLE_1D_SHAPE_JITTER,
                                                "shape_tensor", JITTER)):
            with open(os.path.join(common.ROOT, "examples", name + ".yaml"), "w") as f:
                f.write(sod_scene(dim, dx, out=f"out/{name}.h5", header=head, gradient=grad, jitter=jit,
                                  jitter_volume="kernel" if jit > 0 else None))
        return 0
    exe = common.ejecta_binary(args.build)

    spacings_1d = [0.005, 0.0025, 0.00125] + ([0.000625] if args.full else [])
    spacings_3d = [] if args.no_3d else [0.02, 0.01] + ([0.005] if args.full else [])
    print("Sod shock tube (Sod 1978; exact Riemann solver, Toro ch. 4), t = 0.2 s")
    grads = ["kernel", "shape_tensor"] if args.gradient == "both" else [args.gradient]
    ok = True
    for g in grads:
        ok &= run_gradient(g, exe, args, spacings_1d, spacings_3d)
    if not args.no_jitter:
        ok &= run_jitter(exe, args, [0.0025, 0.00125])
    print(f"sod: {'PASS' if ok else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
