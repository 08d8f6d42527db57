#!/usr/bin/python3
"""RKPM essential boundaries: the mixed transformation method (`essential: transformation`)
against holding the nodal coefficients (`essential: coefficients`, the default).

    /usr/bin/python3 validation/rkpm_essential_bc/check.py --build build

Scene: a 2D elastic plate [0, 1] x [0, 0.5] (E = 1, nu = 0.25, rho = 1), semi-Lagrangian RKPM
with MSNNI (the method's defaults), its bottom row of nodes held (`fix: all`), an initial
velocity v = V (sin(2 pi x) y/H, cos(2 pi x) (y/H)^2), V = 1e-3, that varies along the held row's
neighbours, run to t = 0.2.

1. The boundary value (reference: the prescribed value, zero). At every held node K the RK field
   v^h(x_K) = sum_J Psi_J(x_K) d_J is evaluated here, independently of the plugin (numpy: linear
   basis, cubic B-spline, support 1.75 h), from the coefficients d of the last force evaluation
   (rk_vc with the transformation; v itself with `coefficients`). Spacings h = 1/16, 1/32, 1/64.
   Tolerance: max |v^h(x_K)| <= 1e-12 max |v| with the transformation at every spacing; the miss of
   `coefficients` and its order in h are reported.
2. The transformed forces (reference: the energy of the semi-discrete system is conserved, so the
   core's balance must fall as dt^2). h = 1/32 at cfl 0.1, 0.05, 0.025. Tolerance: the balance falls
   by at least 3 per halving of dt with the transformation.
Writes rkpm_essential_bc.png. Prints PASS/FAIL; exit 1 on FAIL.
"""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402

H, V, SUPPORT = 0.5, 1e-3, 1.75


def scene(h, essential, cfl=0.4, t_end=0.2):
    nx, ny = round(1 / h), round(H / h)
    lines = []
    for j in range(ny):
        for i in range(nx):
            xc, yc = (i + 0.5) * h, (j + 0.5) * h
            vx = V * math.sin(2 * math.pi * xc) * yc / H
            vy = V * math.cos(2 * math.pi * xc) * (yc / H) ** 2
            lines.append(f"      - {{region: {{box: {{min: [{i * h!r}, {j * h!r}], max: [{(i + 1) * h!r}, {(j + 1) * h!r}]}}}}, "
                         f"velocity: [{vx!r}, {vy!r}]}}")
    fields = "v, rk_vc" if essential == "transformation" else "v"
    return f"""ejecta: 1
dimension: 2
time: {{end: {t_end}, cfl: {cfl}}}
output: {{file: plate.h5, every: {t_end}, fields: [{fields}]}}
materials:
  m: {{model: elastic, rho0: 1, E: 1, nu: 0.25}}
sets:
  plate:
    method: rkpm
    essential: {essential}
    material: m
    shape: {{box: {{min: [0, 0], max: [1, {H}]}}}}
    spacing: {h!r}
    initial:
""" + "\n".join(lines) + f"""
boundaries:
  - {{set: plate, region: {{box: {{min: [-1, -1], max: [2, {h!r}]}}}}, fix: all}}
"""


def phi(z):
    t = 1 - z
    return np.where(z >= 1, 0.0, np.where(z <= 0.5, 2 / 3 - 4 * z * z + 4 * z ** 3, 4 / 3 * t ** 3))


def field_at(X, d, a, K):
    """RK field of the coefficients d at node K (all nodes, no images: the plate has none)."""
    h = (X[K] - X) / a
    w = phi(np.linalg.norm(X[K] - X, axis=1) / a)
    Hm = np.hstack([np.ones((len(X), 1)), h])
    M = (Hm * w[:, None]).T @ Hm
    psi = (Hm @ np.linalg.solve(M, np.eye(3)[:, 0])) * w
    return psi @ d


def boundary_miss(path, h):
    fr = common.read_frame(path)
    X, v = fr["x"][:, :2], fr["v"][:, :2]
    d = fr["rk_vc"][:, :2] if "rk_vc" in fr else v
    held = np.where(X[:, 1] < h)[0]
    miss = max(np.abs(field_at(X, d, SUPPORT * h, K) - v[K]).max() for K in held)
    return miss / np.abs(v).max(), len(held)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--no-figures", action="store_true")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    ok = True
    hs = [1 / 16, 1 / 32, 1 / 64]
    miss = {}
    print("1. field at the held nodes, t = 0.2 (max |v^h(x_K) - v_K| / max |v|)")
    for ess in ("coefficients", "transformation"):
        miss[ess] = []
        for h in hs:
            path, _ = common.run(exe, scene(h, ess), f"plate_{ess}_{round(1 / h)}", args.out, reuse=args.reuse)
            m, nh = boundary_miss(path, h)
            miss[ess].append(m)
            print(f"  {ess:<15s} h = 1/{round(1 / h):<3d} {nh:3d} held nodes  miss {m:.3e}")
    slope, pairs = common.order(hs, miss["coefficients"])
    print(f"  coefficients: order {slope:.2f} (pairwise {', '.join(f'{p:.2f}' for p in pairs)})")
    good = all(m <= 1e-12 for m in miss["transformation"])
    ok &= good
    print(f"  transformation: max miss {max(miss['transformation']):.2e} (tolerance 1e-12): {'PASS' if good else 'FAIL'}")

    print("2. energy balance against dt (h = 1/32, |balance| / E0 at t = 0.2)")
    cfls = [0.1, 0.05, 0.025]
    bal = {}
    for ess in ("coefficients", "transformation"):
        bal[ess] = []
        for cfl in cfls:
            path, _ = common.run(exe, scene(1 / 32, ess, cfl), f"bal_{ess}_{cfl}", args.out, reuse=args.reuse)
            s = common.read_series(path)
            e0 = s["kinetic"][0] + s["internal"][0]
            bal[ess].append(abs(s["balance"][-1]) / e0)
        print(f"  {ess:<15s} " + "  ".join(f"cfl {c}: {b:.3e}" for c, b in zip(cfls, bal[ess])))
    r = [bal["transformation"][i] / bal["transformation"][i + 1] for i in range(2)]
    good = all(x >= 3 for x in r)
    ok &= good
    print(f"  transformation: balance falls by {r[0]:.2f}, {r[1]:.2f} per halving of dt (>= 3): {'PASS' if good else 'FAIL'}")

    if not args.no_figures:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        for ess, mk in (("coefficients", "o-"), ("transformation", "s-")):
            ax[0].loglog(hs, np.maximum(miss[ess], 1e-17), mk, label=ess)
            ax[1].loglog(cfls, bal[ess], mk, label=ess)
        ax[0].loglog(hs, [miss["coefficients"][0] * (h / hs[0]) ** 2 for h in hs], "k:", label="h^2")
        ax[0].set_xlabel("spacing h")
        ax[0].set_ylabel("max |v^h(x_K) - v_K| / max |v| at held nodes")
        ax[0].set_title("field at the held nodes (t = 0.2)")
        ax[1].loglog(cfls, [bal["transformation"][0] * (c / cfls[0]) ** 2 for c in cfls], "k:", label="dt^2")
        ax[1].set_xlabel("cfl (h = 1/32)")
        ax[1].set_ylabel("|energy balance| / E0 at t = 0.2")
        ax[1].set_title("energy balance")
        for a in ax:
            a.legend()
            a.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        png = os.path.join(HERE, "rkpm_essential_bc.png")
        fig.savefig(png, dpi=110)
        print(f"  wrote {png}")
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
