#!/usr/bin/python3
"""Where the shape tensor's air shock overshoot comes from (validation/c4_air README, "The shape
tensor at a density contact"): the ideal-gas analog of C4 | air (check.py's gas_scene: 1601 kg/m^3
at 1 GPa | rho_R at 101325 Pa, gamma 1.4 on both sides, two sph sets coupled by `continuum`,
spacing 0.25 mm on both sides) for three density ratios (rho_R = 1601, 12, 1.2 kg/m^3) and five
gradient variants of sph:

  * kernel gradient (the defaults);
  * shape tensor with its defaults (shape_energy: own, shape_continuity: symmetric);
  * shape tensor with shape_continuity: own;
  * shape tensor with shape_energy: symmetric;
  * shape tensor with both (shape_continuity: own, shape_energy: symmetric).

The shock position is the largest x where p > (p* + p_R)/2 (over both sets); the exact one is
U_s t from validation/sod/exact.py's star state. Each run ends when the exact shock has travelled
40 mm; the steady speed is fitted between the first output (a quarter of the run) and the last,
so that the start-up transient of the sharp initial jump does not enter it. Prints a table and
draws c4_air_shape_ratio.png (shock position against time, one panel per ratio).

    /usr/bin/python3 validation/c4_air/shape_ratio.py --build build [--reuse] [--threads 2]
"""
import argparse
import concurrent.futures
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "sod"))
import common  # noqa: E402
import exact  # noqa: E402

RHO_L, P_L, P_R, GAMMA, DX = 1601.0, 1e9, 101325.0, 1.4, 2.5e-4
RATIOS = (1601.0, 12.0, 1.2)
VARIANTS = [("kernel", ""),
            ("shape", "gradient: shape_tensor, "),
            ("shape_cown", "gradient: shape_tensor, shape_continuity: own, "),
            ("shape_esym", "gradient: shape_tensor, shape_energy: symmetric, "),
            ("shape_cown_esym", "gradient: shape_tensor, shape_continuity: own, shape_energy: symmetric, ")]


def reference(rho_r):
    p_star, u_star = exact.star_state((RHO_L, 0.0, P_L), (rho_r, 0.0, P_R), g=GAMMA)
    c_r = (GAMMA * P_R / rho_r) ** 0.5
    u_s = c_r * ((GAMMA + 1) / (2 * GAMMA) * (p_star / P_R - 1) + 1) ** 0.5
    return p_star, u_star, u_s


def scene(rho_r, opt, t_end, out):
    return f"""ejecta: 1
dimension: 1
time: {{end: {t_end:.6g}, cfl: 0.3}}
output: {{file: {out}, every: {t_end / 4:.6g}, fields: [v, m, rho, p, e]}}
materials:
  heavy: {{rho0: {RHO_L:g}, eos: {{model: ideal_gas, gamma: {GAMMA:g}}}}}
  light: {{rho0: {rho_r:g}, eos: {{model: ideal_gas, gamma: {GAMMA:g}}}}}
sets:
  hp: {{method: sph, material: heavy, {opt}shape: {{box: {{min: [-0.05], max: [0]}}}}, spacing: {DX:g}, p: {P_L:g}}}
  air: {{method: sph, material: light, {opt}shape: {{box: {{min: [0], max: [0.15]}}}}, spacing: {DX:g}, p: {P_R:g}}}
interactions:
  - {{model: continuum, sets: [hp, air]}}
boundaries:
  - symmetry: {{point: [-0.05], normal: [1]}}
  - symmetry: {{point: [0.15], normal: [-1]}}
"""


def shock_track(path, p_half):
    import h5py
    out = []
    with h5py.File(path, "r") as f:
        for fr in sorted(f["frames"].keys())[1:]:
            g = f["frames"][fr]
            x = np.concatenate([g[s]["x"][:, 0] for s in g])
            p = np.concatenate([g[s]["p"][()] for s in g])
            out.append((float(g.attrs["time"]), float(x[p > p_half].max())))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(common.ROOT, "out", "validation", "c4_air_ratio"))
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--threads", type=int, default=2, help="runs at the same time (one thread each)")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    jobs = []
    for rho_r in RATIOS:
        p_star, u_star, u_s = reference(rho_r)
        t_end = 0.04 / u_s
        for tag, opt in VARIANTS:
            name = f"ratio_{RHO_L / rho_r:.0f}_{tag}"
            jobs.append((rho_r, tag, name, scene(rho_r, opt, t_end, name + ".h5")))
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.threads)) as ex:
        paths = list(ex.map(lambda j: common.run(exe, j[3], j[2], args.out, 1, args.reuse, log=lambda *a: None)[0],
                            jobs))
    tracks = {}
    print(f"ideal gas 1601 kg/m^3, 1 GPa | rho_R, 101325 Pa; spacing {DX * 1e3:g} mm; shock position at the four "
          "outputs [mm] (exact), steady speed from the first to the last output")
    for (rho_r, tag, name, _), path in zip(jobs, paths):
        p_star, u_star, u_s = reference(rho_r)
        tr = shock_track(path, 0.5 * (p_star + P_R))
        tracks[(rho_r, tag)] = tr
        speed = (tr[-1][1] - tr[0][1]) / (tr[-1][0] - tr[0][0])
        pos = "  ".join(f"{xs * 1e3:6.2f} ({u_s * t * 1e3:5.2f})" for t, xs in tr)
        print(f"  ratio {RHO_L / rho_r:6.0f}  {tag:16s} {pos}   speed {speed:7.1f} m/s ({100 * (speed / u_s - 1):+5.1f} %)"
              f"   final {100 * (tr[-1][1] / (u_s * tr[-1][0]) - 1):+5.1f} %")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(1, len(RATIOS), figsize=(4.2 * len(RATIOS), 3.8))
    for ax, rho_r in zip(axs, RATIOS):
        u_s = reference(rho_r)[2]
        t_end = 0.04 / u_s
        ax.plot([0, t_end * 1e6], [0, 40], "k-", lw=1, label="exact")
        for tag, _ in VARIANTS:
            tr = tracks[(rho_r, tag)]
            ax.plot([t * 1e6 for t, _ in tr], [xs * 1e3 for _, xs in tr], "o-", ms=3, lw=0.8, label=tag)
        ax.set_title(f"density ratio {RHO_L / rho_r:.0f}")
        ax.set_xlabel("t [us]")
        ax.set_ylabel("shock position [mm]")
    axs[0].legend(fontsize=7)
    fig.tight_layout()
    png = os.path.join(HERE, "c4_air_shape_ratio.png")
    fig.savefig(png, dpi=110)
    print(f"wrote {png}")


if __name__ == "__main__":
    main()
