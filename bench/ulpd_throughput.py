#!/usr/bin/python3
"""ulpd throughput against sph in the same run: particle-steps per second per core and their ratio.

    /usr/bin/python3 bench/ulpd_throughput.py --build build [--n-side 46] [--steps 20] [--repeats 2]

Problem (both methods, one scene text each, otherwise identical): ideal gas (gamma 1.4, rho 1,
p 1) in the periodic unit cube, cubic lattice of n_side^3 particles (46^3 = 97,336), lattice
jitter 0.1 spacing, a mild pressure bump (p = 1.1 in a sphere of radius 0.15 at the centre) so
that the flow is not static. sph: its defaults (cubic spline, h = 1.3 spacings, about 60-80
neighbours); ulpd: its defaults (horizon 3 spacings, about 113 family members, two passes).

Timing, as bench/sph_throughput.py: T(1) is a run of 1 step (start-up, generation, first rebuild
and force evaluation, output), T(N) the same with N steps; the step rate per core is
n (N - 1) / (T(N) - T(1)) / threads, best of --repeats. Each run is a separate `ejecta run`
process with --threads (default 1). The ratio ulpd/sph is the number to quote (it is not
sensitive to the machine's load as long as both runs see the same load). Never a timed test.
"""
import argparse
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "validation"))
import common  # noqa: E402


def scene(method, n_side, steps, out):
    dx = 1.0 / n_side
    return f"""# bench/ulpd_throughput.py: {method}, periodic box, {n_side}^3 particles, {steps} steps
ejecta: 1
dimension: 3
time: {{end: 1.0e6, cfl: 0.3, max_steps: {steps}}}
output: {{file: {out}, every: 1.0e6, fields: [v, rho, p]}}
materials:
  gas: {{rho0: 1, eos: {{model: ideal_gas, gamma: 1.4}}}}
sets:
  gas:
    method: {method}
    material: gas
    shape: {{box: {{min: [0, 0, 0], max: [1, 1, 1]}}}}
    spacing: {dx:.17g}
    jitter: 0.1
    rho: 1
    p: 1
    initial: [{{region: {{sphere: {{center: [0.5, 0.5, 0.5], radius: 0.15}}}}, p: 1.1}}]
boundaries:
  - periodic: {{axis: x, min: 0, max: 1}}
  - periodic: {{axis: y, min: 0, max: 1}}
  - periodic: {{axis: z, min: 0, max: 1}}
"""


def timed(exe, text, path, threads):
    with open(path + ".yaml", "w") as f:
        f.write(text)
    t0 = time.time()
    r = subprocess.run([exe, "run", path + ".yaml", "-o", path + ".h5", "--threads", str(threads)],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.time() - t0
    if r.returncode != 0:
        sys.stdout.write(r.stdout)
        raise RuntimeError(f"{path}: exit {r.returncode}")
    return wall


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--n-side", type=int, default=46)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "bench", "ulpd"))
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    os.makedirs(args.out, exist_ok=True)
    n = args.n_side ** 3
    print(f"ulpd vs sph throughput: periodic gas box, {n} particles, {args.steps} steps, {args.threads} thread(s)")
    rate = {}
    for method in ("sph", "ulpd"):
        best1, bestN = float("inf"), float("inf")
        for _ in range(args.repeats):
            base = os.path.join(args.out, f"{method}_{args.n_side}")
            best1 = min(best1, timed(exe, scene(method, args.n_side, 1, base + "_1.h5"), base + "_1", args.threads))
            bestN = min(bestN, timed(exe, scene(method, args.n_side, args.steps, base + "_N.h5"), base + "_N",
                                     args.threads))
        rate[method] = n * (args.steps - 1) / max(bestN - best1, 1e-9) / args.threads
        print(f"  {method:<5s} T(1) {best1:7.2f} s  T({args.steps}) {bestN:7.2f} s  "
              f"{rate[method]:.3g} particle-steps/s/core")
    print(f"  ratio ulpd / sph = {rate['ulpd'] / rate['sph']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
