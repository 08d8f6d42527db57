#!/usr/bin/python3
"""SPH throughput: particle-steps per second per core, 1 -> 2 thread speed-up, bytes per particle.

    /usr/bin/python3 bench/sph_throughput.py --build build [--n-side 46] [--steps 40] [--repeats 3]

Problem: ideal gas (gamma 1.4, rho 1, p 1) in the periodic unit cube, cubic lattice of
n_side^3 particles (46^3 = 97,336), lattice jitter 0.1 spacing so that neighbour shells are
smeared, h_factor 1.205 (about 60 neighbours inside the 2h support; a perfect cubic lattice
jumps from 56 to 80 at h_factor 1.2247), and a mild pressure bump (p = 1.1 in a sphere of
radius 0.15 at the centre) so that the flow is not static. Default SPH parameters otherwise
(cubic spline, renormalised volume continuity, variable h, Monaghan viscosity).

Measured (best of --repeats wall times, each a separate `ejecta run` process):
  T(1)  a run of 1 step: start-up, particle generation, first rebuild and force evaluation,
        two output frames and the checkpoint (setup + fixed cost);
  T(N)  the same run with N steps. The step rate is n (N - 1) / (T(N) - T(1)).
Memory: peak RSS (GNU time %M, or VmHWM) of the N-step run minus that of a 6^3-particle run, over n.
The neighbour count is measured by brute force (periodic minimum image) on 1000 random
particles of the last frame: pairs with r < 2 hbar (the ones the pair loop evaluates) and the
Verlet-list entries (r < max(2h_i, 2h_j) + skin), which the loop visits.

Targets (issue): >= 1e6 particle-steps/s per core, 1 -> 2 thread speed-up >= 1.8, <= 1 KiB per
particle. They are reported PASS/FAIL but never change the exit status (a benchmark, not a test).
--profile additionally runs `perf record` on a 1-thread run and prints the top symbols.
--compare [--baseline DIR] measures, in one run with the configurations alternated, the CPU time
per step of this build's kernel-gradient SPH against a baseline build and of gradient:
shape_tensor against the kernel gradient (ratios; robust on a shared machine).
"""
import argparse
import os
import resource
import shutil
import subprocess
import sys
import time

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "validation"))
import common  # noqa: E402

TARGET_RATE = 1.0e6      # particle-steps / s / core
TARGET_SPEEDUP = 1.8     # 1 -> 2 threads
TARGET_BYTES = 1024.0    # bytes / particle
H_FACTOR = 1.205
JITTER = 0.1
SKIN = 0.1               # core default (neighbours.skin)


def scene(n_side, steps, out, h_factor=H_FACTOR, jitter=JITTER, gradient="kernel"):
    dx = 1.0 / n_side
    grad_line = "" if gradient == "kernel" else f"\n    gradient: {gradient}"
    return f"""# bench/sph_throughput.py: periodic box, {n_side}^3 particles, {steps} steps
ejecta: 1
dimension: 3
time: {{end: 1.0e6, cfl: 0.3, max_steps: {steps}}}
output: {{file: {out}, every: 1.0e6, fields: [v, rho, p, h]}}
materials:
  gas: {{rho0: 1, eos: {{model: ideal_gas, gamma: 1.4}}}}
sets:
  gas:
    method: sph
    material: gas{grad_line}
    h_factor: {h_factor:g}
    shape: {{box: {{min: [0, 0, 0], max: [1, 1, 1]}}}}
    spacing: {dx:.17g}
    jitter: {jitter:g}
    seed: 1
    rho: 1
    p: 1
    initial: [{{region: {{sphere: {{center: [0.5, 0.5, 0.5], radius: 0.15}}}}, p: 1.1}}]
boundaries:
  - periodic: {{axis: x, min: 0, max: 1}}
  - periodic: {{axis: y, min: 0, max: 1}}
  - periodic: {{axis: z, min: 0, max: 1}}
"""


def run_once(exe, scene_path, out, threads):
    """Runs ejecta once; returns (wall seconds, peak RSS in bytes).

    The peak RSS comes from GNU time (%M) when /usr/bin/time exists, else from polling VmHWM in
    /proc/PID/status. Not from wait4's ru_maxrss: that keeps the high-water mark of the forked
    Python interpreter (numpy, h5py: tens of MiB) across the exec."""
    cmd = [exe, "run", scene_path, "-o", out, "--threads", str(threads)]
    rss_file = out + ".rss"
    gnu_time = os.access("/usr/bin/time", os.X_OK)
    if gnu_time:
        cmd = ["/usr/bin/time", "-f", "%M", "-o", rss_file] + cmd
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    hwm = 0
    if not gnu_time:
        while proc.poll() is None:
            try:
                with open(f"/proc/{proc.pid}/status") as f:
                    for line in f:
                        if line.startswith("VmHWM:"):
                            hwm = max(hwm, int(line.split()[1]) * 1024)
            except OSError:
                pass
            time.sleep(0.01)
    output = proc.communicate()[0]
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.stdout.write(output.decode(errors="replace"))
        raise RuntimeError(f"{' '.join(cmd)} exited with {proc.returncode}")
    if gnu_time:
        with open(rss_file) as f:
            hwm = int(f.read().split()[-1]) * 1024  # KiB
        os.remove(rss_file)
    return wall, hwm


def write_scene(outdir, name, text):
    path = os.path.join(outdir, name + ".yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


def neighbour_counts(h5path, sample=1000, skin=SKIN, seed=0):
    """Mean pairs with r < 2 hbar and mean Verlet-list entries per particle (periodic unit cube)."""
    with h5py.File(h5path, "r") as f:
        fr = sorted(f["frames"].keys())[-1]
        g = f["frames"][fr][sorted(f["frames"][fr].keys())[0]]
        x, h = g["x"][()], g["h"][()]
    n = len(h)
    rng = np.random.default_rng(seed)
    sub = rng.choice(n, min(sample, n), replace=False)
    sk = skin * 2.0 * h.max()
    inside, listed = [], []
    for i in sub:
        d = x - x[i]
        d -= np.round(d)  # minimum image, period 1
        r2 = np.einsum("ij,ij->i", d, d)
        hb = 0.5 * (h[i] + h)
        m = r2 < 4.0 * hb * hb
        m[i] = False
        inside.append(int(m.sum()))
        ml = np.sqrt(r2) < np.maximum(2.0 * h[i], 2.0 * h) + sk
        ml[i] = False
        listed.append(int(ml.sum()))
    return float(np.mean(inside)), int(np.min(inside)), int(np.max(inside)), float(np.mean(listed))


def loadavg():
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "?"


def perf_profile(exe, scene_path, outdir, top=25):
    """perf record on one 1-thread run; returns the top lines of `perf report` (or why not)."""
    if not shutil.which("perf"):
        return "perf not found"
    data = os.path.join(outdir, "perf.data")
    rec = subprocess.run(["perf", "record", "-o", data, exe, "run", scene_path, "-o",
                          os.path.join(outdir, "perf.h5"), "--threads", "1"],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if rec.returncode != 0:
        return "perf record failed:\n" + rec.stdout[-2000:]
    rep = subprocess.run(["perf", "report", "-i", data, "--no-children", "--stdio", "--sort", "dso,symbol"],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    lines = [ln for ln in rep.stdout.splitlines() if ln.strip() and not ln.startswith("#")]
    return "\n".join(lines[:top])


def measure(build="build", n_side=46, steps=40, repeats=3, threads=(1, 2), outdir=None, profile=False,
            log=print):
    exe = common.ejecta_binary(build)
    outdir = outdir or os.path.join(ROOT, "out", "bench", "throughput")
    os.makedirs(outdir, exist_ok=True)
    n = n_side ** 3
    res = {"n": n, "n_side": n_side, "steps": steps, "repeats": repeats, "h_factor": H_FACTOR,
           "jitter": JITTER, "load_before": loadavg()}
    log(f"SPH throughput: periodic box {n_side}^3 = {n} particles, {steps} steps, best of {repeats}")
    log(f"  load average before: {res['load_before']}")

    tiny_scene = write_scene(outdir, "tiny", scene(6, 1, os.path.join(outdir, "tiny.h5")))
    _, rss_tiny = run_once(exe, tiny_scene, os.path.join(outdir, "tiny.h5"), 1)
    res["rss_tiny"] = rss_tiny

    one = write_scene(outdir, "box_1", scene(n_side, 1, os.path.join(outdir, "box_1.h5")))
    many = write_scene(outdir, f"box_{steps}", scene(n_side, steps, os.path.join(outdir, f"box_{steps}.h5")))
    res["t1"], res["tN"], res["rss"] = {}, {}, {}
    for th in threads:
        w1 = [run_once(exe, one, os.path.join(outdir, "box_1.h5"), th) for _ in range(repeats)]
        wN = [run_once(exe, many, os.path.join(outdir, f"box_{steps}.h5"), th) for _ in range(repeats)]
        res["t1"][th] = min(w for w, _ in w1)
        res["tN"][th] = min(w for w, _ in wN)
        res["rss"][th] = max(r for _, r in wN)
        log(f"  threads {th}: 1 step {', '.join(f'{w:.2f}' for w, _ in w1)} s; "
            f"{steps} steps {', '.join(f'{w:.2f}' for w, _ in wN)} s")
    res["load_after"] = loadavg()
    log(f"  load average after: {res['load_after']}")

    out_h5 = os.path.join(outdir, f"box_{steps}.h5")
    with h5py.File(out_h5, "r") as f:
        res["n_rebuilds"] = int(f["checkpoint"].attrs["n_rebuilds"])
        res["t_end"] = float(f["checkpoint"].attrs["t"])
    res["nbr_inside"], res["nbr_min"], res["nbr_max"], res["nbr_listed"] = neighbour_counts(out_h5)

    res["rate"], res["rate_core"] = {}, {}
    for th in threads:
        step_time = (res["tN"][th] - res["t1"][th]) / (steps - 1)
        res["rate"][th] = n / step_time
        res["rate_core"][th] = res["rate"][th] / th
    if 1 in threads and 2 in threads:
        res["speedup"] = res["rate"][2] / res["rate"][1]
    th0 = threads[0]
    res["bytes_per_particle"] = (res["rss"][th0] - rss_tiny) / n
    res["setup_fraction"] = res["t1"][th0] / res["tN"][th0]
    if profile:
        res["profile"] = perf_profile(exe, many, outdir)
    report(res, log)
    return res


def verdict(ok):
    return "PASS" if ok else "FAIL"


def report(res, log=print):
    n, steps = res["n"], res["steps"]
    log(f"\n  particles {n}; neighbours inside 2h: mean {res['nbr_inside']:.1f} (min {res['nbr_min']}, "
        f"max {res['nbr_max']}); Verlet-list entries: {res['nbr_listed']:.1f}")
    log(f"  {res['n_rebuilds']} neighbour rebuilds in {steps} steps (t = {res['t_end']:.3g} s)")
    for th in sorted(res["rate"]):
        log(f"  threads {th}: 1-step run {res['t1'][th]:.2f} s, {steps}-step run {res['tN'][th]:.2f} s, "
            f"{res['rate'][th]:.3g} particle-steps/s = {res['rate_core'][th]:.3g} per core  "
            f"(target >= {TARGET_RATE:.0e}/core: {verdict(res['rate_core'][th] >= TARGET_RATE)})")
    if "speedup" in res:
        log(f"  speed-up 1 -> 2 threads: {res['speedup']:.2f}  (target >= {TARGET_SPEEDUP}: "
            f"{verdict(res['speedup'] >= TARGET_SPEEDUP)})")
    th0 = sorted(res["rss"])[0]
    log(f"  peak RSS {res['rss'][th0] / 2**20:.1f} MiB (threads {th0}), tiny run {res['rss_tiny'] / 2**20:.1f} MiB: "
        f"{res['bytes_per_particle']:.0f} bytes/particle  (target <= {TARGET_BYTES:.0f}: "
        f"{verdict(res['bytes_per_particle'] <= TARGET_BYTES)})")
    log(f"  setup (1-step run) is {100 * res['setup_fraction']:.0f} % of the {steps}-step run (threads {th0})")
    if res.get("profile"):
        log("  perf profile of a 1-thread run (self time):\n" + res["profile"])


def cpu_seconds(exe, scene_path, out):
    """User + system CPU seconds of one 1-thread run (getrusage of the children: much less
    sensitive than wall time to other jobs on a shared machine)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([exe, "run", scene_path, "-o", out, "--threads", "1"], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=dict(os.environ, OMP_WAIT_POLICY="passive"))
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def compare(build, baseline=None, n_side=46, steps=40, repeats=2, outdir=None, log=print):
    """Ratios measured in one run, alternating the configurations: this build's kernel-gradient
    SPH against a baseline build (speed-up), and its gradient: shape_tensor against its kernel
    gradient (cost). Per configuration, the step cost is (CPU(N steps) - CPU(1 step)) / (N - 1),
    the minimum over the repeats."""
    outdir = outdir or os.path.join(ROOT, "out", "bench", "throughput")
    os.makedirs(outdir, exist_ok=True)
    configs = [("kernel", common.ejecta_binary(build), "kernel"),
               ("shape_tensor", common.ejecta_binary(build), "shape_tensor")]
    if baseline:
        configs.insert(0, ("baseline kernel", common.ejecta_binary(baseline), "kernel"))
    cost = {c[0]: [] for c in configs}
    for _ in range(repeats):
        for label, exe, grad in configs:
            tag = label.replace(" ", "_")
            one = write_scene(outdir, f"cmp_{tag}_1", scene(n_side, 1, os.path.join(outdir, "cmp_1.h5"), gradient=grad))
            many = write_scene(outdir, f"cmp_{tag}_N", scene(n_side, steps, os.path.join(outdir, "cmp_N.h5"),
                                                            gradient=grad))
            c1 = cpu_seconds(exe, one, os.path.join(outdir, "cmp_1.h5"))
            cN = cpu_seconds(exe, many, os.path.join(outdir, "cmp_N.h5"))
            cost[label].append((cN - c1) / (steps - 1))
            log(f"  {label:<16s} CPU 1 step {c1:6.2f} s, {steps} steps {cN:6.2f} s: "
                f"{n_side ** 3 / cost[label][-1]:.3g} particle-steps/s")
    best = {k: min(v) for k, v in cost.items()}
    n = n_side ** 3
    if baseline:
        f = best["baseline kernel"] / best["kernel"]
        log(f"  speed-up of the kernel-gradient SPH over the baseline build: {f:.3f} "
            f"(baseline {n / best['baseline kernel']:.3g}, this build {n / best['kernel']:.3g} particle-steps/s CPU)")
    r = best["shape_tensor"] / best["kernel"]
    log(f"  cost of gradient: shape_tensor / kernel per step: {r:.2f} (target <= 1.5: {verdict(r <= 1.5)})")
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--n-side", type=int, default=46)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--profile", action="store_true", help="also perf-record a 1-thread run")
    ap.add_argument("--compare", action="store_true",
                    help="instead: CPU-time ratios, shape_tensor vs kernel (and --baseline vs this build)")
    ap.add_argument("--baseline", default=None, help="build directory of the baseline for --compare")
    args = ap.parse_args()
    if args.compare:
        compare(args.build, args.baseline, args.n_side, args.steps, min(args.repeats, 2))
        return 0
    measure(args.build, args.n_side, args.steps, args.repeats, profile=args.profile)
    return 0


if __name__ == "__main__":
    sys.exit(main())
