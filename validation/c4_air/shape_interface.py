#!/usr/bin/python3
"""The shape tensor at the C4/air interface (validation/c4_air README, "Shape tensor across the
interface"): the scene of check.py at dx = 0.1 mm to 4 us, six variants,

  * sph kernel gradient with renormalize_interfaces (check.py's judged run, the reference row);
  * shape tensor on both sets, continuum `gradient: auto` (M_i over both sets, G_ij on the
    interface pairs: the default since 2026-11-30);
  * the same with continuum `gradient: kernel` (the coupling before: M_i one-sided, kernel pairs);
  * shape tensor in the air only / in the charge only (gradient: auto);
  * shape tensor on both sets with shape_continuity: own (shape_ratio.py).

Prints the air peak pressure and velocity over check.py's window (1.25-3 us) against the Riemann
state (riemann.py) and the mean pressure of the three air particles at the contact at 3 us, and
draws c4_air_shape_interface.png (air pressure at 2 and 3 us).

    /usr/bin/python3 validation/c4_air/shape_interface.py --build build [--reuse]
"""
import argparse
import importlib.util
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402
import riemann  # noqa: E402

_spec = importlib.util.spec_from_file_location("c4_air_check", os.path.join(HERE, "check.py"))
check = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(check)

T_END = 4e-6
SHAPE = "gradient: shape_tensor, "


def variants():
    base = check.c4_scene("sph", 1e-4, t_end=T_END, every=0.25e-6, out="OUT")
    shape = check.c4_scene("sph", 1e-4, t_end=T_END, every=0.25e-6, out="OUT", gradient="shape_tensor")
    kernel_cpl = shape.replace("sets: [charge, air]}", "sets: [charge, air], gradient: kernel}")
    assert kernel_cpl != shape
    air_only = shape.replace("material: c4, " + SHAPE, "material: c4, ")
    charge_only = shape.replace("material: air, " + SHAPE, "material: air, ")
    assert air_only.count(SHAPE) == 1 and charge_only.count(SHAPE) == 1
    # the continuity with g_i instead of G_ij (shape_ratio.py: the symmetric continuity is what runs the
    # shock ahead at a density contact)
    cont_own = shape.replace(SHAPE, SHAPE + "shape_continuity: own, ")
    assert cont_own.count("shape_continuity: own") == 2
    return [("sph kernel gradient (renormalize_interfaces)", "kernel", base),
            ("shape tensor, continuum gradient: auto", "shape_auto", shape),
            ("shape tensor, continuum gradient: kernel (before)", "shape_kcpl", kernel_cpl),
            ("shape tensor in the air only", "shape_air", air_only),
            ("shape tensor in the charge only", "shape_charge", charge_only),
            ("shape tensor, shape_continuity: own", "shape_cown", cont_own)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(common.ROOT, "out", "validation", "c4_air"))
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    ref = riemann.solve()
    print(f"C4 into air, dx 0.1 mm, to {T_END * 1e6:g} us: p* = {ref['p_star'] / 1e6:.2f} MPa, "
          f"u* = {ref['u_star']:.0f} m/s")
    print(f"  {'variant':52s} {'air peak p':>16s} {'air peak v':>16s} {'contact air p at 3 us':>22s} balance")
    prof = {}
    for label, tag, text in variants():
        name = f"c4_air_si_{tag}"
        path, _ = common.run(exe, text.replace("OUT", name + ".h5"), name, args.out, 1, args.reuse)
        rows, bad, rmin, bal, steps = check.scan(path)
        win = [r for r in rows if check.WIN[0] - 1e-12 <= r["t"] <= check.WIN[1] + 1e-12]
        p = max(float(r["air"]["p"].max()) for r in win)
        u = max(float(r["air"]["v"][:, 0].max()) for r in win)
        r3 = min(rows, key=lambda r: abs(r["t"] - 3e-6))
        x3 = r3["air"]["x"][:, 0]
        pc = float(np.mean(r3["air"]["p"][np.argsort(x3)[:3]]))
        print(f"  {label:52s} {p / 1e6:8.2f} ({100 * (p / ref['p_star'] - 1):+5.1f} %) "
              f"{u:7.0f} ({100 * (u / ref['u_star'] - 1):+5.1f} %) {pc / 1e6:14.2f} MPa      {bal:.2e}"
              f"{'' if bad == 0 and rmin > 0 else '  NON-FINITE OR NEGATIVE'}")
        prof[tag] = (label, rows)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, t in zip(axs, (2e-6, 3e-6)):
        for tag, style in (("kernel", "k-"), ("shape_auto", "C0-"), ("shape_kcpl", "C3--"), ("shape_air", "C2:"),
                           ("shape_cown", "C1-")):
            label, rows = prof[tag]
            r = min(rows, key=lambda r: abs(r["t"] - t))
            x = r["air"]["x"][:, 0]
            o = np.argsort(x)
            ax.plot(1e3 * x[o], r["air"]["p"][o] / 1e6, style, lw=1.2, label=label)
        ax.axhline(ref["p_star"] / 1e6, color="0.5", lw=0.8, ls="-.", label="Riemann p*")
        ax.set_xlabel("x [mm]")
        ax.set_title(f"air pressure at t = {t * 1e6:g} us (dx 0.1 mm)")
        ax.set_xlim(9, 32)
    axs[0].set_ylabel("p [MPa]")
    axs[0].legend(fontsize=7)
    fig.tight_layout()
    out = os.path.join(HERE, "c4_air_shape_interface.png")
    fig.savefig(out, dpi=110)
    print(f"  figure {out}")


if __name__ == "__main__":
    main()
