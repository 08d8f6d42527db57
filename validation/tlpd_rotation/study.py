#!/usr/bin/python3
"""Source of the tangential forces in the rotating tlpd cylinder/disc (issue 4, README "Study").

One run per option set: a free disc (dimension 2, sphere section of radius R) or the cylinder
of check.py (dimension 3), elastic soil of 000 Table 2 (E = 98.5 MPa, nu = 0.25, rho 1700) or
another E, spinning at 1000 rad/s for t_end. Printed for the probes of check.py (top layer, r
nearest R/2, 3R/4, R) and over all particles: max over t of | |v|/(w r0) - 1 |, | r/r0 - 1 | and
| h/(w r0^2) - 1 | with h = x v_y - y v_x (kept exactly by an axisymmetric force field).
Example: study.py --build B --dim 2 --dx 0.001 --lattice hcp --hourglass none
"""
import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402

R, H, OMEGA = 0.025, 0.05, 1000.0


def scene(a, out, sites, t_end):
    hw = 0.2 * a.dx
    lines = []
    for p in sites:
        if a.dim == 2:
            lo, hi = f"[{p[0] - hw:.9g}, {p[1] - hw:.9g}]", f"[{p[0] + hw:.9g}, {p[1] + hw:.9g}]"
            vel = f"[{-OMEGA * p[1]:.9g}, {OMEGA * p[0]:.9g}]"
        else:
            lo, hi = f"[{p[0] - hw:.9g}, {p[1] - hw:.9g}, -1]", f"[{p[0] + hw:.9g}, {p[1] + hw:.9g}, 1]"
            vel = f"[{-OMEGA * p[1]:.9g}, {OMEGA * p[0]:.9g}, 0]"
        lines.append(f"      - {{region: {{box: {{min: {lo}, max: {hi}}}}}, velocity: {vel}}}")
    init = ("    initial:\n" + "\n".join(lines) + "\n") if lines else ""
    shape = (f"{{sphere: {{center: [0, 0], radius: {R}}}}}" if a.dim == 2 else
             f"{{cylinder: {{base: [0, 0, 0], axis: [0, 0, 1], radius: {R}, height: {a.H}}}}}")
    obj = "true" if a.objective else "false\n    nonobjective: rate"
    return f"""# validation/tlpd_rotation/study.py
ejecta: 1
dimension: {a.dim}
time: {{end: {t_end}, dt: {a.dt}}}
output: {{file: {out}, every: {a.every}, fields: [v]}}
materials:
  soil: {{model: elastic, rho0: 1700, E: {a.E}, nu: 0.25}}
sets:
  cyl:
    method: tlpd
    material: soil
    objective: {obj}
    hourglass: {a.hourglass}
    hourglass_coefficient: {a.c}
    influence: {a.influence}
    horizon: {a.horizon}
    partial_volume: {str(a.partial_volume).lower()}
    lattice: {a.lattice}
    shape: {shape}
    spacing: {a.dx}
""" + init


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/validation/tlpd_rotation_study")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--dim", type=int, default=2)
    ap.add_argument("--dx", type=float, default=0.001)
    ap.add_argument("--dt", type=float, default=5e-7)
    ap.add_argument("--t_end", default="1 ms")
    ap.add_argument("--every", default="0.01 ms")
    ap.add_argument("--E", default="98.5 MPa")
    ap.add_argument("--lattice", default="cubic")
    ap.add_argument("--hourglass", default="zhu_zhao")
    ap.add_argument("--c", type=float, default=0.01)
    ap.add_argument("--influence", default="constant")
    ap.add_argument("--horizon", type=float, default=3.0)
    ap.add_argument("--no-partial-volume", dest="partial_volume", action="store_false")
    ap.add_argument("--nonobjective", dest="objective", action="store_false")
    ap.add_argument("--layer", default="top", choices=["top", "mid"],
                    help="3-D: probes in the top layer (check.py, 000) or the layer nearest H/2")
    ap.add_argument("--H", type=float, default=H, help="3-D: cylinder height (m)")
    ap.add_argument("--reuse", action="store_true", help="analyse an existing output of the same options")
    ap.add_argument("--tag", default=None)
    a = ap.parse_args()
    exe = common.ejecta_binary(a.build)
    tag = a.tag or (f"d{a.dim}_dx{a.dx:g}_{a.lattice}_{a.hourglass}{a.c:g}_{a.influence}_m{a.horizon:g}_dt{a.dt:g}"
                    f"_E{a.E.replace(' ', '')}{'' if a.H == H else f'_H{a.H:g}'}{'' if a.t_end == '1 ms' else '_t' + a.t_end.replace(' ', '')}_{'obj' if a.objective else 'rate'}{'' if a.partial_volume else '_nopv'}")
    p0, _ = common.run(exe, scene(a, f"{a.out}/{tag}_pos.h5", [], "1e-9"), tag + "_pos", a.out, threads=1, log=lambda s: None)
    d0 = common.read_frame(p0, common.frames(p0)[0])
    sites = sorted(set(map(tuple, np.round(d0["x"][:, :2], 9))))
    out, _ = common.run(exe, scene(a, f"{a.out}/{tag}.h5", sites, a.t_end), tag, a.out, threads=a.threads, reuse=a.reuse,
                        log=lambda s: None)
    fr = common.frames(out)
    f0 = common.read_frame(out, fr[0])
    x0, ids = f0["x"], f0["id"]
    order0 = np.argsort(ids)
    x0 = x0[order0]
    r0 = np.hypot(x0[:, 0], x0[:, 1])
    top = np.ones(len(x0), bool)
    if a.dim == 3:
        zl = x0[:, 2].max() if a.layer == "top" else x0[np.argmin(np.abs(x0[:, 2] - H / 2)), 2]
        top = np.abs(x0[:, 2] - zl) < 0.25 * a.dx
    probes = []
    for frac in (0.5, 0.75, 1.0):
        cand = np.where(top)[0]
        probes.append(cand[np.argmin(np.abs(r0[cand] - frac * R))])
    mv = np.zeros(len(x0))
    mr = np.zeros(len(x0))
    mh = np.zeros(len(x0))
    T, vp = [], []
    # axisymmetric part of a probe's h: the mean over its ring (same layer, |r0 - r0_probe| < dx/2,
    # all angles); the rest is the non-axisymmetric (lattice) part
    lay = np.abs(x0[:, 2] - x0[probes[0], 2]) < 0.25 * a.dx if a.dim == 3 else np.ones(len(x0), bool)
    rings = [np.where(lay & (np.abs(r0 - r0[k]) < 0.5 * a.dx))[0] for k in probes]
    hax = np.zeros(3)
    hna = np.zeros(3)
    ok = r0 > 0.1 * R
    for name in fr:
        d = common.read_frame(out, name)
        o = np.argsort(d["id"])
        x, v = d["x"][o], d["v"][o]
        r = np.hypot(x[:, 0], x[:, 1])
        sp = np.linalg.norm(v[:, :2], axis=1) if a.dim == 2 else np.linalg.norm(v, axis=1)
        hh = x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            mv = np.maximum(mv, np.where(ok, np.abs(sp / (OMEGA * r0) - 1), 0))
            mr = np.maximum(mr, np.where(ok, np.abs(r / r0 - 1), 0))
            mh = np.maximum(mh, np.where(ok, np.abs(hh / (OMEGA * r0 ** 2) - 1), 0))
        for q, k in enumerate(probes):
            with np.errstate(divide="ignore", invalid="ignore"):
                dh = hh[rings[q]] / (OMEGA * r0[rings[q]] ** 2) - 1
                dk = hh[k] / (OMEGA * r0[k] ** 2) - 1
            hax[q] = max(hax[q], abs(dh.mean()))
            hna[q] = max(hna[q], abs(dk - dh.mean()))
        T.append(d["time"])
        vp.append([sp[k] / (OMEGA * r0[k]) - 1 for k in probes])
    vp = np.array(vp)
    T = np.array(T)
    print(f"{tag}: n = {len(x0)}, probes in the {a.layer if a.dim == 3 else 'whole'} layer")
    for k, frac in zip(probes, (0.5, 0.75, 1.0)):
        print(f"  probe {frac:4.2f} R (r0 {r0[k]*1e3:6.3f} mm): speed {100*mv[k]:.3f} %, radius {100*mr[k]:.3f} %, "
              f"ang. mom. {100*mh[k]:.3f} %")
    print("  probe ang. mom. dev, ring mean (axisymmetric): " + ", ".join(f"{100*x:.3f}" for x in hax) +
          " %; probe minus ring mean (non-axisymmetric): " + ", ".join(f"{100*x:.3f}" for x in hna) +
          f" % (rings of {', '.join(str(len(g)) for g in rings)} particles)")
    # oscillation amplitude of the probe speeds: first 0.3 ms vs last 0.3 ms
    e1, e2 = T <= 0.3 * T[-1], T >= 0.7 * T[-1]
    amp1 = np.max(np.abs(vp[e1]), axis=0) if e1.any() else np.zeros(3)
    amp2 = np.max(np.abs(vp[e2]), axis=0) if e2.any() else np.zeros(3)
    print("  probe speed dev first 30 %: " + ", ".join(f"{100*x:.3f}" for x in amp1) +
          " %; last 30 %: " + ", ".join(f"{100*x:.3f}" for x in amp2) + " %")
    inner = ok & (r0 < 0.8 * R)
    print(f"  all (r0 > 0.1 R): speed max {100*mv[ok].max():.3f} % (median {100*np.median(mv[ok]):.3f}), ang. mom. max "
          f"{100*mh[ok].max():.3f} % (median {100*np.median(mh[ok]):.3f}), radius max {100*mr[ok].max():.3f} %; "
          f"r0 < 0.8 R: speed max {100*mv[inner].max():.3f} %, ang. mom. max {100*mh[inner].max():.3f} %")
    print(f"SUMMARY {tag}{'_mid' if a.layer == 'mid' else ''} probes_speed {' '.join(f'{100*mv[k]:.3f}' for k in probes)} probes_h "
          f"{' '.join(f'{100*mh[k]:.3f}' for k in probes)} h_axi {' '.join(f'{100*x:.3f}' for x in hax)} "
          f"h_nonaxi {' '.join(f'{100*x:.3f}' for x in hna)} all_speed {100*mv[ok].max():.3f} all_h {100*mh[ok].max():.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
