#!/usr/bin/python3
"""Taylor bar, Armco iron at 220 m/s (examples/sph_taylor_bar.yaml; reference: shared/reference
README §4 = Chen et al. 2021 Table 4 "Experiment", citing Johnson & Holmquist 1988): final
length L = 19.8 mm, impact-face (mushroom) diameter D = 13.7 mm, W = 8.6 mm (diameter at
0.2 L0 from the impact face, digest 001 §3.2 [X, likely]). Tolerances: 2 % on L, 5 % on D and W.
Measured on the particles of the quarter model at the end time (r = sqrt(x^2 + y^2)):
  L = max z + dx/2 (the wall surface is z = 0),
  D = 2 (max r over the face layer z < min z + dx/2, + dx/2),
  W = 2 (max r over |z - 0.2 L0| < dx/2, + dx/2),
  Dmax = 2 (max r over all particles + dx/2) (envelope; reported only).
Runs each spacing given (default: L0/34, L0/40, L0/50, L0/67, whole numbers of layers along the
bar), one thread each, OMP_WAIT_POLICY=passive (see README "Cost"), prints every number, the CPU
time and step count, and PASS/FAIL for the finest; writes taylor_bar.png (final profiles r(z))."""
import argparse
import os
import re
import resource
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import common  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
REF = {"L": 19.8e-3, "D": 13.7e-3, "W": 8.6e-3}
TOL = {"L": 0.02, "D": 0.05, "W": 0.05}
L0 = 25.4e-3
R0 = 3.8e-3


def measure(x, dx):
    r = np.hypot(x[:, 0], x[:, 1])
    z = x[:, 2]
    L = z.max() + 0.5 * dx
    face = z < z.min() + 0.5 * dx
    D = 2 * (r[face].max() + 0.5 * dx)
    band = np.abs(z - 0.2 * L0) < 0.5 * dx
    W = 2 * (r[band].max() + 0.5 * dx) if band.any() else float("nan")
    return {"L": L, "D": D, "W": W, "Dmax": 2 * (r.max() + 0.5 * dx)}


def scene(base, dx, slip):
    """The example at spacing dx: bar and wall spacing, wall thickness 3 dx, slip condition."""
    text = base.replace("spacing: 0.37910 mm", f"spacing: {dx * 1e3:.6g} mm")
    w = f"-{3 * dx * 1e3:.6g} mm"
    text = text.replace("min: [-1.1373 mm, -1.1373 mm, -1.1373 mm]", f"min: [{w}, {w}, {w}]")
    text = text.replace("slip: free_slip", f"slip: {slip}")
    assert text.count(f"spacing: {dx * 1e3:.6g} mm") == 2 and w in text
    return text


def run(exe, text, name, outdir, reuse):
    """Runs the scene on one thread; returns (h5 path, CPU s of the child, wall s, steps)."""
    os.makedirs(outdir, exist_ok=True)
    path, out = os.path.join(outdir, name + ".yaml"), os.path.join(outdir, name + ".h5")
    if reuse and os.path.exists(out):
        return out, float("nan"), float("nan"), -1
    open(path, "w").write(text)
    env = dict(os.environ, OMP_WAIT_POLICY="passive")
    r0, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.time()
    res = subprocess.run([exe, "run", path, "-o", out, "--threads", "1"], env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        sys.stdout.write(res.stdout)
        raise RuntimeError(f"{exe} run {path} exited with {res.returncode}")
    m = re.search(r"\((\d+) steps", res.stdout)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return out, cpu, time.time() - t0, int(m.group(1)) if m else -1


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--spacing", type=float, nargs="+", default=[L0 / 34, L0 / 40, L0 / 50, L0 / 67])
    ap.add_argument("--slip", default="free_slip", choices=["free_slip", "no_slip"])
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    base = open(os.path.join(common.ROOT, "examples", "sph_taylor_bar.yaml")).read()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 6))
    res = None
    for dx in sorted(args.spacing, reverse=True):
        name = f"taylor_dx{dx * 1e6:.0f}um" + ("" if args.slip == "free_slip" else "_" + args.slip)
        path, cpu, wall, steps = run(exe, scene(base, dx, args.slip), name, args.out, args.reuse)
        d = common.read_frame(path, None, "bar")
        res = measure(d["x"], dx)
        mass = 4 * len(d["x"]) * dx ** 3 / (np.pi * R0 ** 2 * L0) - 1  # lattice mass rho0 dx^3
        errs = {k: res[k] / REF[k] - 1 for k in REF}
        print(f"  dx {dx * 1e3:.4f} mm, n = {len(d['x'])} (mass {mass * 100:+.1f} % of the cylinder), "
              f"{steps} steps, CPU {cpu:.1f} s, wall {wall:.0f} s, t = {d['time'] * 1e6:.1f} us: "
              + ", ".join(f"{k} = {res[k] * 1e3:.2f} mm ({errs[k] * 100:+.1f} %)" for k in REF)
              + f", Dmax = {res['Dmax'] * 1e3:.2f} mm", flush=True)
        r = np.hypot(d["x"][:, 0], d["x"][:, 1])
        ax.plot(r * 1e3, d["x"][:, 2] * 1e3, ".", ms=2, label=f"dx {dx * 1e3:.3g} mm")
    ax.axhline(REF["L"] * 1e3, color="k", ls="--", lw=0.8, label="exp. L 19.8 mm")
    ax.axvline(REF["D"] * 0.5e3, color="k", ls=":", lw=0.8, label="exp. D/2 6.85 mm")
    ax.plot([REF["W"] * 0.5e3], [0.2 * L0 * 1e3], "k+", ms=10, label="exp. W/2 at 0.2 L0")
    ax.set_xlabel("r [mm]")
    ax.set_ylabel("z [mm]")
    ax.set_title(f"Taylor bar, Armco iron 220 m/s, sph + JC + MG, {args.slip} dummy wall")
    ax.legend(fontsize=8)
    fig.savefig(os.path.join(HERE, "taylor_bar.png" if args.slip == "free_slip" else f"taylor_bar_{args.slip}.png"),
                dpi=120)
    if args.slip == "free_slip":
        common.energy_figure(path, os.path.join(HERE, "taylor_bar_energy.png"),
                             title=f"Taylor bar, dx {min(args.spacing) * 1e3:.3g} mm: energy budget")
    ok = all(abs(res[k] / REF[k] - 1) <= TOL[k] for k in REF)
    print("PASS" if ok else "FAIL", "(finest spacing; tolerances L 2 %, D 5 %, W 5 %)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
