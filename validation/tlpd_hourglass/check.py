#!/usr/bin/python3
"""Zero-energy (hourglass) modes of tlpd on a jittered cloud under dynamic compression.

Problem: plane strain (dimension 2), block 0.2 m x 0.2 m, dx = 5 mm (40 x 40 particles) randomly
perturbed by 20 % of the spacing (`jitter: 0.2`), horizon 3 dx, elastic E = 1 GPa, nu = 0.25,
rho = 2000 kg/m^3, bottom layer fixed, sides free; 10,000 steps of 3.2e-6 s (cfl 0.5).
Loads (--load): impact (default): the whole block thrown at 0.2 m/s onto its fixed base, a
bounded, oscillating compression (peak strain ~ v/c = 2.6e-4, 40 wave transits); push: the top
layer driven down at 0.2 m/s (a load growing linearly to 3.2 % nominal strain).
Runs: hourglass zhu_zhao (c = 0.01, 002 Eq 15) and hourglass none.

Zero-energy mode amplitude (the measure): the non-affine part of the bond deformation,
    A(t) = sqrt( sum_bonds |Y - F_i X|^2 / sum_bonds |X|^2 ),
over all pairs with |X| < delta (X = x0_j - x0_i, Y = x_j - x_i, F_i the particle's nonlocal
deformation gradient, written with output_F). A is exactly 0 for any linear displacement field
(patch test), O(dx |grad F|) for a smooth one, and grows for an unresisted zero-energy mode.
A2 uses (F_i + F_j)/2 (cancels the curvature of a smooth field to first order); it is printed
and equals A here to 3 digits, so A is particle-scale non-affinity, not barrelling.
Criterion: with control, max A over the last half of the run <= 3 x max A over the first tenth
(bounded; for the push load A per unit nominal strain, since a static response grows with the
load); without control A at the end >= 3 x A with control at the end. Also reports the energy
balance of both runs.
"""
import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402

DX, SIDE, VTOP, STEPS = 0.005, 0.2, 0.2, 10000
DT = 3.2e-6  # 0.5 dx / c_p (c_p = 774.6 m/s): cfl 0.5 as a fixed step


def scene(hourglass, out, steps=STEPS, load="push"):
    q = 0.75 * DX
    if load == "impact":
        # the whole block moving at VTOP onto its fixed bottom layer: a bounded, oscillating load
        top = f"    initial: [{{region: {{box: {{min: [-1, -1], max: [2, 2]}}}}, velocity: [0, {-VTOP}]}}]\n"
        bc_top = ""
    else:
        top = ""
        bc_top = f"  - {{set: blk, region: {{box: {{min: [-1, {SIDE - q}], max: [2, 2]}}}}, velocity: [0, {-VTOP}]}}\n"
    return f"""# Hourglass control on a jittered cloud (validation/tlpd_hourglass/check.py)
ejecta: 1
dimension: 2
time: {{end: {steps * DT:.9g}, dt: {DT}}}
output: {{file: {out}, every: {steps * DT / 40:.9g}, fields: [v, x0, F]}}
materials:
  m: {{model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}}
sets:
  blk:
    method: tlpd
    material: m
    hourglass: {hourglass}
    output_F: true
    shape: {{box: {{min: [0, 0], max: [{SIDE}, {SIDE}]}}}}
    spacing: {DX}
    jitter: 0.2
{top}boundaries:
  - {{set: blk, region: {{box: {{min: [-1, -1], max: [2, {q}]}}}}, fix: [x, y]}}
{bc_top}"""


def amplitude(d, pairs):
    i, j = pairs
    X = d["x0"][j] - d["x0"][i]
    Y = d["x"][j] - d["x"][i]
    F = d["F"].reshape(-1, 3, 3)[i][:, :2, :2]
    R = Y - np.einsum("kab,kb->ka", F, X)
    return np.sqrt((R ** 2).sum() / (X ** 2).sum())


def amplitude2(d, pairs):
    """rms |Y - (F_i + F_j)/2 X| / rms |X|: the bond deformation not explained by the mean
    gradient of its two ends. O(|X|^2 |grad^2 F|) for a smooth field (the curvature of a
    barrelling block cancels to first order), so it isolates particle-scale (zero-energy) modes."""
    i, j = pairs
    X = d["x0"][j] - d["x0"][i]
    Y = d["x"][j] - d["x"][i]
    F = d["F"].reshape(-1, 3, 3)[:, :2, :2]
    Fm = 0.5 * (F[i] + F[j])
    R = Y - np.einsum("kab,kb->ka", Fm, X)
    return np.sqrt((R ** 2).sum() / (X ** 2).sum())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/validation/tlpd_hourglass")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=STEPS)
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--load", choices=("push", "impact"), default="impact",
                    help="push: top layer driven down at 0.2 m/s (growing load); impact: the block thrown onto its fixed base")
    a = ap.parse_args()
    exe = common.ejecta_binary(a.build)
    res = {}
    for hg in ("zhu_zhao", "none"):
        name = f"hg_{hg}" + ("" if a.load == "push" else "_" + a.load)
        out = os.path.join(a.out, name + ".h5")
        try:
            common.run(exe, scene(hg, out, a.steps, a.load), name, a.out, threads=a.threads, reuse=a.reuse)
        except RuntimeError as e:
            print(f"  {name}: {e}")
        path = out if os.path.exists(out) else out + ".partial"
        fr = common.frames(path)
        d0 = common.read_frame(path, fr[0])
        x0 = d0["x0"][:, :2]
        dd = np.linalg.norm(x0[None, :, :] - x0[:, None, :], axis=2)
        pairs = np.nonzero((dd > 0) & (dd < 3 * DX))
        T, A, S = [], [], []
        for f in fr:
            d = common.read_frame(path, f)
            d["x0"], d["x"] = d["x0"][:, :2], d["x"][:, :2]
            T.append(round(d["time"] / DT))
            A.append(amplitude(d, pairs))
            S.append(amplitude2(d, pairs))
        print(f"  {hg}: A2 (mean-F residual) " + " ".join(f"{t}:{x:.2e}" for t, x in list(zip(T, S))[::4]))
        print(f"  {hg}: A  (own-F residual)  " + " ".join(f"{t}:{x:.2e}" for t, x in list(zip(T, A))[::4]))
        s = common.read_series(path)
        e_scale = max(np.max(np.abs(s["external"])), np.max(s["kinetic"] + s["internal"]))
        res[hg] = (np.array(T), np.array(A), np.max(np.abs(s["balance"])) / e_scale)
        print(f"hourglass {hg:8s}: A at step {T[1]} = {A[1]:.3e}, max A = {max(A):.3e}, A at step {T[-1]} = {A[-1]:.3e}; "
              f"energy |balance| / max(|W_ext|, E) = {res[hg][2]:.2e}")
    T, A, _ = res["zhu_zhao"]
    n = len(A)
    # push: the load (nominal strain VTOP t / SIDE) grows linearly, and so does any static
    # non-affine response; the amplitude per unit applied strain is what must stay bounded
    An = A if a.load == "impact" else A / np.maximum(VTOP * T * DT / SIDE, 1e-30)
    if a.load == "push":
        print("push load: A / nominal strain, controlled: " + " ".join(f"{t}:{x:.3f}" for t, x in list(zip(T, An))[1::4]) +
              "; uncontrolled: " + " ".join(f"{t}:{x:.2f}" for t, x in list(zip(T, res['none'][1] / np.maximum(VTOP * T * DT / SIDE, 1e-30)))[1::4]))
    early = np.max(An[1:max(2, n // 10 + 1)])
    late = np.max(An[n // 2:])
    bounded = late <= 3 * early
    grows = res["none"][1][-1] >= 3 * A[-1]
    what = "A" if a.load == "impact" else "A / nominal strain"
    print(f"with control ({a.load} load): max {what} over the first tenth {early:.3e}, over the last half {late:.3e} "
          f"(ratio {late / early:.2f}, tol 3)  {'PASS' if bounded else 'FAIL'}")
    print(f"without control: A_end = {res['none'][1][-1]:.3e} = {res['none'][1][-1] / A[-1]:.1f} x controlled (must be >= 3)  "
          f"{'PASS' if grows else 'FAIL'}")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for hg, (T, A, _) in res.items():
        ax.semilogy(T[1:], A[1:], "o-", ms=3, label=f"hourglass: {hg}")
    ax.set_xlabel("step")
    ax.set_ylabel("A = rms|Y - F X| / rms|X| over bonds")
    ax.set_title(f"zero-energy mode amplitude, jitter 0.2, {a.load} load")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "tlpd_hourglass.png" if a.load == "impact" else "tlpd_hourglass_push.png"), dpi=110)
    # the controlled run's energy budget (hourglass-control energy included) through tools/plot_series.py
    hg_name = "hg_zhu_zhao" + ("" if a.load == "push" else "_" + a.load)
    hg_path = os.path.join(a.out, hg_name + ".h5")
    common.energy_figure(hg_path if os.path.exists(hg_path) else hg_path + ".partial",
                         os.path.join(HERE, "tlpd_hourglass_energy.png" if a.load == "impact" else "tlpd_hourglass_push_energy.png"),
                         title=f"tlpd hourglass control (zhu_zhao, {a.load} load): energy budget")
    ok = bounded and grows
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
