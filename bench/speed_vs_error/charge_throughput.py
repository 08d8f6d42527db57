#!/usr/bin/python3
"""Explosive throughput: particle-steps per second per core of sph (kernel gradient), sph
(gradient: shape_tensor) and ulpd on the same 3D C4 charge with JWL programmed burn, in one run.

    /usr/bin/python3 bench/speed_vs_error/charge_throughput.py --build build [--steps 150]

Problem: a C4 sphere (JWL, digest 001 Table 1, examples/materials/c4_001.yaml; lit at its centre,
D = 8193 m/s), radius 57.6 mm, cubic lattice spacing 2 mm: about 100,000 particles, free surface,
one set. Each method runs its defaults. Timing: CPU time (user + sys of the ejecta child, os.wait4)
of a 1-step run T(1) and an N-step run T(N); rate = n (N - 1) / (T(N) - T(1)) per core (one
thread). CPU time, not wall time: the machine is shared. Never a timed test. Window: 150 steps by
default (since 2026-12-03; 11 before), the whole burn (the front reaches the surface at 7.0 us, the runs
end near 10 us): the cost ratio depends on the window, as the lists are rebuilt more often as the
products accelerate (bench/explosive_throughput.py's docstring).
"""
import argparse
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "validation"))
import common  # noqa: E402

R = 0.0576
DX = 0.002


def scene(method, grad, steps, out):
    g = f"\n    gradient: {grad}" if grad != "kernel" else ""
    return f"""ejecta: 1
dimension: 3
time: {{end: 1.0, cfl: 0.3, max_steps: {steps}}}
output: {{file: {out}, every: 1.0, fields: [v, rho, p]}}
materials:
  c4:
    rho0: 1601
    eos: {{model: jwl, A: 6.098e11 Pa, B: 1.3e10 Pa, R1: 4.5, R2: 1.4, omega: 0.25, rho0: 1601 kg/m^3,
          e0: 5.621e6 J/kg, detonation: {{point: [0, 0, 0], speed: 8193 m/s}}}}
sets:
  charge:
    method: {method}{g}
    material: c4
    shape: {{sphere: {{center: [0, 0, 0], radius: {R:g}}}}}
    spacing: {DX:g}
"""


def cpu_run(exe, text, path):
    with open(path + ".yaml", "w") as f:
        f.write(text)
    with open(path + ".log", "w") as log:
        p = subprocess.Popen([exe, "run", path + ".yaml", "-o", path + ".h5", "--threads", "1"], stdout=log,
                             stderr=subprocess.STDOUT)
        _, status, ru = os.wait4(p.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{path}: failed, see {path}.log")
    return ru.ru_utime + ru.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--steps", type=int, default=150)
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "bench", "charge_throughput"))
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    os.makedirs(args.out, exist_ok=True)
    rate = {}
    n = None
    for key, method, grad in (("sph kernel", "sph", "kernel"), ("sph shape_tensor", "sph", "shape_tensor"),
                              ("ulpd", "ulpd", "kernel")):
        base = os.path.join(args.out, key.replace(" ", "_"))
        t1 = cpu_run(exe, scene(method, grad, 1, base + "_1.h5"), base + "_1")
        tn = cpu_run(exe, scene(method, grad, args.steps, base + "_N.h5"), base + "_N")
        if n is None:
            n = common.read_frame(base + "_N.h5")["x"].shape[0]
        rate[key] = n * (args.steps - 1) / max(tn - t1, 1e-9)
        print(f"  {key:<17s} CPU T(1) {t1:7.2f} s  T({args.steps}) {tn:7.2f} s  {rate[key]:.4g} particle-steps/s/core",
              flush=True)
    print(f"  particles {n}")
    k = rate["sph kernel"]
    print(f"  cost shape_tensor / kernel = {k / rate['sph shape_tensor']:.3f} (target <= 1.5)")
    print(f"  cost ulpd / sph kernel = {k / rate['ulpd']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
