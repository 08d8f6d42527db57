#!/usr/bin/python3
"""RKPM throughput: particle-steps per second per core and the 1 -> 2 thread speed-up.

    /usr/bin/python3 bench/rkpm_throughput.py --build build [--n-side 58] [--steps 12] [--repeats 2]

Problem: semi-Lagrangian RKPM (rkpm defaults: support 1.75, direct nodal integration with the
pairwise stabilisation) on a free 3D elastic block (E = 10 GPa, nu = 0.25, rho 2000) of
n_side^3 points (58^3 = 195,112), lattice jitter 0.1, with a linear initial velocity field
v_x = 10 m/s * z / L so that strains, rotations and the material update are non-trivial.
The elastic material is used (drucker_prager is another helper's plugin, in progress).

T(1) is a 1-step run (start-up, particle generation, first rebuild, first force evaluation,
output); T(N) the N-step run; the step rate is n (N - 1) / (T(N) - T(1)), best of --repeats.
Targets (issue 9): 250,000 particle-steps/s per core, speed-up 1.8 on 2 threads. Reported
PASS/FAIL, never the exit status (a benchmark, not a test).
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "validation"))
import common  # noqa: E402

TARGET_RATE = 2.5e5
TARGET_SPEEDUP = 1.8


def scene(n_side, steps, out):
    L = 1.0
    dx = L / n_side
    return f"""# bench/rkpm_throughput.py: elastic block, {n_side}^3 points, {steps} steps
ejecta: 1
dimension: 3
time: {{end: 1.0e6, cfl: 0.5, max_steps: {steps}}}
output: {{file: {out}, every: 1.0e6, fields: [v]}}
materials:
  rock: {{model: elastic, rho0: 2000, E: 10 GPa, nu: 0.25}}
sets:
  block:
    method: rkpm
    formulation: semi_lagrangian
    material: rock
    shape: {{box: {{min: [0, 0, 0], max: [{L}, {L}, {L}]}}}}
    spacing: {dx!r}
    jitter: 0.1
    initial:
      - {{region: {{box: {{min: [0, 0, 0], max: [{L}, {L}, {L/2}]}}}}, velocity: [-2.5, 0, 0]}}
      - {{region: {{box: {{min: [0, 0, {L/2}], max: [{L}, {L}, {L}]}}}}, velocity: [2.5, 0, 0]}}
"""


def timed(exe, text, threads, tmp, tag):
    path = os.path.join(tmp, tag + ".yaml")
    out = os.path.join(tmp, tag + ".h5")
    with open(path, "w") as f:
        f.write(text)
    t0 = time.time()
    r = subprocess.run([exe, "run", path, "-o", out, "--threads", str(threads)], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True)
    wall = time.time() - t0
    if r.returncode != 0:
        sys.stdout.write(r.stdout)
        raise RuntimeError(f"ejecta exited with {r.returncode}")
    return wall


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--n-side", type=int, default=58)
    ap.add_argument("--steps", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=2)
    a = ap.parse_args()
    exe = common.ejecta_binary(a.build)
    n = a.n_side ** 3
    rates = {}
    with tempfile.TemporaryDirectory(prefix="ej_rkpm_bench_") as tmp:
        for threads in (1, 2):
            t1 = min(timed(exe, scene(a.n_side, 1, "o.h5"), threads, tmp, "s1") for _ in range(a.repeats))
            tn = min(timed(exe, scene(a.n_side, a.steps, "o.h5"), threads, tmp, "sn") for _ in range(a.repeats))
            rate = n * (a.steps - 1) / (tn - t1)
            rates[threads] = rate
            print(f"threads {threads}: n = {n}, T(1) = {t1:.2f} s, T({a.steps}) = {tn:.2f} s, "
                  f"{rate:.4g} particle-steps/s ({rate / threads:.4g} per core)")
    sp = rates[2] / rates[1]
    print(f"per core (1 thread): {rates[1]:.4g} particle-steps/s, target {TARGET_RATE:.3g}: "
          f"{'PASS' if rates[1] >= TARGET_RATE else 'FAIL'}")
    print(f"speed-up 1 -> 2 threads: {sp:.2f}, target {TARGET_SPEEDUP}: {'PASS' if sp >= TARGET_SPEEDUP else 'FAIL'}")


if __name__ == "__main__":
    main()
