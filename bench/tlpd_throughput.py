#!/usr/bin/python3
"""TL-PD throughput: particle-steps per second per core, 1 -> 2 thread speed-up, bytes per particle.

    /usr/bin/python3 bench/tlpd_throughput.py --build build [--n-side 60] [--steps 20]

Problem: a 3D block of n_side^3 particles (60^3 = 216,000 >= 200,000), horizon m = 3 (about 123
bonds per interior particle with the partial-volume shell), sum form with 002 hourglass
control, half of the block moving at 1 m/s (so every step deforms). Material: drucker_prager
(000 Table 2 soil, E 98.5 MPa, nu 0.25, friction 0.74 rad) when the plugin is in the build,
else elastic (said in the output).
Measured: T(1) a 1-step run (setup, families, first force evaluation, output) and T(N) with N
steps; rate = n (N - 1) / (T(N) - T(1)). Memory: peak RSS of the N-step run over n (GNU time).
Target (issue 4): 500,000 particle-steps/s/core. A report, never a test: the exit status is 0.
"""
import argparse
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "validation"))
import common  # noqa: E402

TARGET = 5.0e5


def scene(n, steps, out, material):
    dx = 1.0 / n
    return f"""# bench/tlpd_throughput.py: {n}^3 particles, {steps} steps
ejecta: 1
dimension: 3
time: {{end: 1.0e6, cfl: 0.5, max_steps: {steps}}}
output: {{file: {out}, every: 1.0e6, fields: [v]}}
materials:
  soil: {material}
sets:
  blk:
    method: tlpd
    material: soil
    shape: {{box: {{min: [0, 0, 0], max: [1, 1, 1]}}}}
    spacing: {dx:.17g}
    initial: [{{region: {{box: {{min: [0, 0, 0], max: [0.5, 1, 1]}}}}, velocity: [1, 0, 0]}}]
"""


def run(exe, path, out, threads):
    cmd = ["/usr/bin/time", "-f", "%M", "-o", out + ".rss", exe, "run", path, "-o", out, "--threads", str(threads)]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.perf_counter() - t0
    if r.returncode:
        sys.stdout.write(r.stdout)
        raise RuntimeError("ejecta failed")
    with open(out + ".rss") as f:
        rss = int(f.read().split()[-1]) * 1024
    return wall, rss


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/bench/tlpd")
    ap.add_argument("--n-side", type=int, default=60)
    ap.add_argument("--steps", type=int, default=20)
    a = ap.parse_args()
    exe = common.ejecta_binary(a.build)
    os.makedirs(a.out, exist_ok=True)
    have_dp = os.path.exists(os.path.join(os.path.dirname(os.path.dirname(exe)), "plugins", "ej_drucker_prager.so"))
    if have_dp:
        mat = "{model: drucker_prager, rho0: 1700, E: 98.5 MPa, nu: 0.25, friction_angle: 0.74 rad, cohesion: 10 kPa}"
        print("material: drucker_prager")
    else:
        mat = "{model: elastic, rho0: 1700, E: 98.5 MPa, nu: 0.25}"
        print("material: elastic (drucker_prager plugin not in this build)")
    n = a.n_side ** 3
    res = {}
    for threads in (1, 2):
        walls = []
        for steps in (1, a.steps):
            out = os.path.join(a.out, f"tlpd_{steps}_{threads}.h5")
            p = os.path.join(a.out, f"tlpd_{steps}.yaml")
            with open(p, "w") as f:
                f.write(scene(a.n_side, steps, out, mat))
            w, rss = run(exe, p, out, threads)
            walls.append((w, rss))
        rate = n * (a.steps - 1) / (walls[1][0] - walls[0][0])
        res[threads] = (rate, walls[1][1])
        print(f"threads {threads}: {rate:,.0f} particle-steps/s ({rate / threads:,.0f} per core), peak RSS "
              f"{walls[1][1] / n:,.0f} bytes/particle, setup {walls[0][0]:.1f} s")
    r1 = res[1][0]
    print(f"{n} particles, m = 3: {r1:,.0f} particle-steps/s/core on 1 thread "
          f"({'PASS' if r1 >= TARGET else 'FAIL'} against {TARGET:,.0f}); 2-thread speed-up {res[2][0] / r1:.2f}; "
          f"{res[1][1] / n:,.0f} bytes/particle")
    return 0


if __name__ == "__main__":
    sys.exit(main())
