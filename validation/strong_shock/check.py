#!/usr/bin/python3
"""Strong shock tubes (1D ideal gas, gamma 1.4): the post-shock plateau of SPH's gas options
against the exact Riemann solution.

Reference: the exact solution of the Riemann problem (Toro, "Riemann Solvers and Numerical
Methods for Fluid Dynamics", 3rd ed. 2009, ch. 4; validation/sod/exact.py). Left state rho 1,
u 0, p 1; right state rho 1, u 0, p = 1 / ratio for ratio = 10, 100, 1000 and 1e5 (1e5 is Toro's
test 3 scaled by 1/1000: rho 1 | 1, p 1000 | 0.01). The shock compression is 2.88, 5.34, 5.93 and
6.00 (the strong-shock limit (gamma + 1)/(gamma - 1) = 6). A blast makes the 1000-to-1e5 shocks.

Measure: the mean density and pressure of the particles in the middle 40 % of the shocked region
(between the exact contact and the exact shock) at t = 0.3 / (1.2 u*) (shock near x = 0.3), against
the exact post-shock density and p*. Tolerance: both within 2 %, fixed before the runs.

Options run (one set, spacing 0.0025, [-0.5, 0.5], walls at both ends):
  * sph with its defaults (kernel gradient, `continuity: auto`: the number form, renormalised);
  * sph, kernel gradient, `continuity: volume` (the default before 2026-11-30; shown, not judged);
  * sph, kernel gradient, `continuity: mass` (000 Eq 22), renormalised;
  * sph, kernel gradient, `density: summation`;
  * sph, `gradient: shape_tensor` (with its default continuity);
  * ulpd with its defaults;
and, for the volume and mass forms, the 1e5 tube at half the spacing (convergence).
Verdict: every option but `continuity: volume` within the tolerance at every ratio.
Figure strong_shock.png: density profiles of the ratio-1e5 tube.

    /usr/bin/python3 validation/strong_shock/check.py --build build [--reuse]
"""
import argparse
import os
import sys

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "sod"))
import common  # noqa: E402
import exact  # noqa: E402  (validation/sod/exact.py)

TOL = 0.02
RATIOS = (10.0, 100.0, 1000.0, 1e5)
OPTIONS = [("sph kernel (default: continuity auto = number)", "default", "method: sph, "),
           ("sph kernel, continuity: volume", "volume", "method: sph, continuity: volume, "),
           ("sph kernel, continuity: mass", "mass", "method: sph, continuity: mass, "),
           ("sph kernel, density: summation", "summation", "method: sph, density: summation, "),
           ("sph shape tensor", "shape", "method: sph, gradient: shape_tensor, "),
           ("ulpd (defaults)", "ulpd", "method: ulpd, ")]


def scene(ratio, opts, dx, t_end, out):
    return f"""ejecta: 1
dimension: 1
time: {{end: {t_end:.9g}, cfl: 0.3}}
output: {{file: {out}, every: {t_end:.9g}, fields: [v, m, rho, p, e]}}
materials:
  g: {{rho0: 1, eos: {{model: ideal_gas, gamma: 1.4}}}}
sets:
  tube: {{{opts}material: g, shape: {{box: {{min: [-0.5], max: [0.5]}}}}, spacing: {dx:g}, p: 1,
         initial: [{{region: {{box: {{min: [0], max: [0.5]}}}}, rho: 1, p: {1.0 / ratio:.9g}}}]}}
boundaries:
  - symmetry: {{point: [-0.5], normal: [1]}}
  - symmetry: {{point: [0.5], normal: [-1]}}
"""


def plateau(path, ratio):
    """(mean rho / exact - 1, mean p / p* - 1, t, x, rho) over the middle 40 % of the shocked region."""
    L, R = (1.0, 0.0, 1.0), (1.0, 0.0, 1.0 / ratio)
    ps, us = exact.star_state(L, R)
    with h5py.File(path, "r") as f:
        g = f["frames"][sorted(f["frames"].keys())[-1]]
        t = float(g.attrs["time"])
        x = g["tube"]["x"][:, 0]
        o = np.argsort(x)
        x, rho, p = x[o], g["tube"]["rho"][()][o], g["tube"]["p"][()][o]
    xc = us * t
    xe = np.linspace(xc + 1e-9, 0.5, 20001)
    re = exact.sample(xe, t, L, R)[0]
    xs = float(xe[np.argmax(re < R[0] * (1 + 1e-6))])
    sel = (x > xc + 0.3 * (xs - xc)) & (x < xc + 0.7 * (xs - xc))
    return float(rho[sel].mean() / re[0] - 1), float(p[sel].mean() / ps - 1), t, x, rho, int(sel.sum())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(common.ROOT, "out", "validation", "strong_shock"))
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    print("Strong shock tubes, 1D ideal gas: post-shock plateau (middle 40 % of the shocked region) vs exact")
    print(f"  tolerance {100 * TOL:g} % on density and pressure; spacing 0.0025 (400 particles)")
    verdict = {}
    profiles = {}
    for label, tag, opts in OPTIONS:
        print(f"\n  {label}")
        good = True
        for ratio in RATIOS:
            L, R = (1.0, 0.0, 1.0), (1.0, 0.0, 1.0 / ratio)
            ps, us = exact.star_state(L, R)
            t_end = 0.3 / (1.2 * us)
            name = f"strong_{tag}_{ratio:g}"
            path, _ = common.run(exe, scene(ratio, opts, 0.0025, t_end, name + ".h5"), name, args.out, 1,
                                 args.reuse, log=lambda s: None)
            er, ep, t, x, rho, n = plateau(path, ratio)
            ok = abs(er) <= TOL and abs(ep) <= TOL
            good &= ok
            print(f"    p ratio {ratio:8g}: plateau rho {100 * er:+6.2f} %, p {100 * ep:+6.2f} % ({n} particles, "
                  f"t = {t:.4g})  {'PASS' if ok else 'FAIL'}")
            if ratio == 1e5:
                profiles[tag] = (label, x, rho, t)
        if tag in ("volume", "mass"):
            ratio = 1e5
            ps, us = exact.star_state((1.0, 0.0, 1.0), (1.0, 0.0, 1.0 / ratio))
            t_end = 0.3 / (1.2 * us)
            name = f"strong_{tag}_{ratio:g}_fine"
            path, _ = common.run(exe, scene(ratio, opts, 0.00125, t_end, name + ".h5"), name, args.out, 1,
                                 args.reuse, log=lambda s: None)
            er, ep, t, x, rho, n = plateau(path, ratio)
            print(f"    p ratio {ratio:8g}, spacing 0.00125: plateau rho {100 * er:+6.2f} %, p {100 * ep:+6.2f} % "
                  f"(convergence: not a criterion)")
        verdict[label] = good
        print(f"    {label}: {'PASS' if good else 'FAIL'}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 4.5))
    L, R = (1.0, 0.0, 1.0), (1.0, 0.0, 1e-5)
    t = profiles["volume"][3]
    xe = np.linspace(-0.5, 0.5, 4001)
    ax.plot(xe, exact.sample(xe, t, L, R)[0], "r-", lw=1.0, label="exact (Toro)")
    for tag, style in (("volume", "k.-"), ("default", "C0.-"), ("summation", "C2.-"), ("shape", "C1.-"),
                       ("ulpd", "C4.-")):
        label, x, rho, _ = profiles[tag]
        ax.plot(x, rho, style, ms=2, lw=0.6, label=label)
    ax.set_xlim(0.1, 0.35)
    ax.set_xlabel("x")
    ax.set_ylabel("density")
    ax.set_title(f"shock tube p_L/p_R = 1e5, spacing 0.0025, t = {t:.4g}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    png = os.path.join(HERE, "strong_shock.png")
    fig.savefig(png, dpi=110)
    print(f"\n  figure {png}")
    # judged: every option but continuity: volume, which is shown as the former default (README)
    judged = all(v for k, v in verdict.items() if "continuity: volume" not in k)
    print("\n  " + "; ".join(f"{k}: {'PASS' if v else 'FAIL'}" for k, v in verdict.items()))
    print("strong_shock: " + ("PASS" if judged else "FAIL") + " (continuity: volume shown, not judged)")
    return 0 if judged else 1


if __name__ == "__main__":
    sys.exit(main())
