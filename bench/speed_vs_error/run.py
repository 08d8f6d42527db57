#!/usr/bin/python3
"""Speed against error: Sod (1D) and Sedov (3D) with sph (kernel gradient), sph (shape_tensor
gradient) and ulpd, each at several resolutions; CPU time of the ejecta process against error.

    /usr/bin/python3 bench/speed_vs_error/run.py --build build [--jobs 2] [--reuse]

Problems and error measures (the validation cases' own code, imported, not copied):
* Sod: validation/sod/check.py `sod_scene(1, dx, gradient=...)` (smoothed jump, t = 0.2 s),
  error = L1(rho) over |x| <= 0.4 against the exact Riemann solution (validation/sod/exact.py,
  Toro ch. 4) via check.py's `l1_density`. ulpd runs the same scene text with `method: ulpd`.
* Sedov: validation/sedov/check.py `scene(dx, gradient=...)` (octant, E = 1 J, gamma 1.4,
  t_end 0.05 s, frames every 0.01 s), error = mean over the frames t = 0.02..0.05 s of
  |R - R_exact| / R_exact, R the captured front (check.py `front_radius`), R_exact the
  self-similar radius (sedov_exact.py, xi0 = 1.0328).

CPU time = user + sys of the ejecta child alone (os.wait4 rusage), one thread per run, so the
numbers do not depend on how loaded the shared machine is (wall time does). --jobs runs that
many ejecta processes side by side. Never a timed test. Writes speed_vs_error.png and prints
the Markdown tables of README.md.
"""
import argparse
import importlib.util
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "validation"))
sys.path.insert(0, os.path.join(ROOT, "validation", "sod"))
sys.path.insert(0, os.path.join(ROOT, "validation", "sedov"))
import common  # noqa: E402


def _load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


sod = _load("sod_check", os.path.join(ROOT, "validation", "sod", "check.py"))
sedov = _load("sedov_check", os.path.join(ROOT, "validation", "sedov", "check.py"))
import sedov_exact  # noqa: E402

METHODS = [("sph_kernel", "sph", "kernel"), ("sph_shape", "sph", "shape_tensor"), ("ulpd", "ulpd", "kernel")]
LABEL = {"sph_kernel": "sph (kernel gradient)", "sph_shape": "sph (shape_tensor)", "ulpd": "ulpd"}
SOD_DX = [0.01, 0.005, 0.0025, 0.00125, 0.000625]
# validation/sedov deposits the energy within a fixed 0.04 m of the origin (DEPOSIT_R) at every
# spacing, so the coarsest level is 0.04 (one particle inside); 0.05 would hold none
SEDOV_DX = [0.04, 0.0333, 0.025, 0.02]


def sph_supports_shape_tensor(exe):
    r = subprocess.run([exe, "describe", "sph"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return "shape_tensor" in r.stdout


def to_ulpd(text):
    text = text.replace("    method: sph\n", "    method: ulpd\n")
    # ulpd has no `h` field; its own viscosity and horizon defaults are used
    return text.replace("fields: [v, m, rho, p, e, h]", "fields: [v, m, rho, p, e]")


def run_cpu(exe, text, path):
    """Runs ejecta on text into path.h5 with one thread; returns (cpu seconds, wall seconds)."""
    with open(path + ".yaml", "w") as f:
        f.write(text)
    t0 = time.time()
    with open(path + ".log", "w") as log:
        proc = subprocess.Popen([exe, "run", path + ".yaml", "-o", path + ".h5", "--threads", "1"], stdout=log,
                                stderr=subprocess.STDOUT)
        _, status, ru = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.time() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{path}: ejecta exited with {proc.returncode} (see {path}.log)")
    return ru.ru_utime + ru.ru_stime, wall


def count(path):
    with __import__("h5py").File(path, "r") as f:
        g = f["frames"][sorted(f["frames"].keys())[0]]
        return int(sum(g[s]["x"].shape[0] for s in g.keys()))


def sod_case(exe, out, key, method, grad, dx):
    text = sod.sod_scene(1, dx, gradient=grad, out="x.h5")
    if method == "ulpd":
        text = to_ulpd(text)
    path = os.path.join(out, f"sod_{key}_{dx:g}")
    cpu, wall = run_cpu(exe, text, path)
    d = common.read_frame(path + ".h5")
    return dict(problem="sod", key=key, dx=dx, n=count(path + ".h5"), cpu=cpu, wall=wall, err=sod.l1_density(d))


def sedov_case(exe, out, key, method, grad, dx):
    text = sedov.scene(dx, gradient=grad)
    if method == "ulpd":
        text = to_ulpd(text)
    path = os.path.join(out, f"sedov_{key}_{dx:g}")
    cpu, wall = run_cpu(exe, text, path)
    xi0 = sedov_exact.profile(1.4)[0]
    errs = []
    for fr in common.frames(path + ".h5"):
        d = common.read_frame(path + ".h5", fr)
        if d["time"] < sedov.T_MIN - 1e-9:
            continue
        R, _ = sedov.front_radius(d, dx)
        Re = sedov_exact.shock_radius(d["time"], 1.0, 1.0, xi0)
        errs.append(abs(R - Re) / Re)
    return dict(problem="sedov", key=key, dx=dx, n=count(path + ".h5"), cpu=cpu, wall=wall,
                err=float(np.mean(errs)), err_last=float(errs[-1]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "bench", "speed_vs_error"))
    ap.add_argument("--reuse", action="store_true", help="reuse results.json rows already computed")
    ap.add_argument("--only", choices=["sod", "sedov"], default=None)
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    os.makedirs(args.out, exist_ok=True)
    methods = list(METHODS)
    if not sph_supports_shape_tensor(exe):
        print("sph has no `gradient: shape_tensor` in this build: that curve is missing")
        methods = [m for m in methods if m[0] != "sph_shape"]
    jpath = os.path.join(args.out, "results.json")
    done = json.load(open(jpath)) if (args.reuse and os.path.exists(jpath)) else []
    have = {(r["problem"], r["key"], r["dx"]) for r in done}
    tasks = []
    for prob, dxs, fn in (("sod", SOD_DX, sod_case), ("sedov", SEDOV_DX, sedov_case)):
        if args.only and prob != args.only:
            continue
        for key, method, grad in methods:
            for dx in dxs:
                if (prob, key, dx) not in have:
                    tasks.append((fn, key, method, grad, dx))
    # largest first so the pool stays busy to the end
    tasks.sort(key=lambda t: (t[0] is sod_case, t[4]))
    results = list(done)
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futs = [pool.submit(fn, exe, args.out, key, method, grad, dx) for fn, key, method, grad, dx in tasks]
        for f in futs:
            try:
                r = f.result()
            except RuntimeError as e:
                print(f"  FAILED: {e}")
                continue
            results.append(r)
            print(f"  {r['problem']:<5s} {r['key']:<10s} dx {r['dx']:<7g} n {r['n']:>6d}  cpu {r['cpu']:8.2f} s  "
                  f"wall {r['wall']:7.1f} s  error {r['err']:.4g}", flush=True)
            with open(jpath, "w") as fj:
                json.dump(results, fj, indent=1)
    report(results, methods)
    plot(results, methods)
    return 0


def report(results, methods):
    for prob, title in (("sod", "Sod, 1D, t = 0.2 s: L1(rho) against the exact solution"),
                        ("sedov", "Sedov, 3D octant, t = 0.02-0.05 s: mean |R - R_exact| / R_exact")):
        rows = [r for r in results if r["problem"] == prob]
        if not rows:
            continue
        print(f"\n{title}\n")
        print("| method | spacing | particles | CPU time (s) | error |")
        print("|---|---|---|---|---|")
        for key, _, _ in methods:
            for r in sorted((r for r in rows if r["key"] == key), key=lambda r: -r["dx"]):
                print(f"| {LABEL[key]} | {r['dx']:g} | {r['n']} | {r['cpu']:.2f} | {r['err']:.4g} |")


def plot(results, methods):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    for ax, prob, ylabel in ((axes[0], "sod", r"L1($\rho$) vs exact [kg/m$^3$]"),
                             (axes[1], "sedov", r"mean $|R - R_{exact}| / R_{exact}$")):
        for (key, _, _), mk in zip(methods, "osd"):
            rows = sorted((r for r in results if r["problem"] == prob and r["key"] == key), key=lambda r: r["cpu"])
            if not rows:
                continue
            ax.loglog([r["cpu"] for r in rows], [r["err"] for r in rows], "-" + mk, label=LABEL[key])
            for r in rows:
                ax.annotate(f"{r['n']}", (r["cpu"], r["err"]), fontsize=7, textcoords="offset points", xytext=(3, 3))
        ax.set_xlabel("CPU time of the run [s] (user + sys, 1 thread)")
        ax.set_ylabel(ylabel)
        ax.set_title("Sod 1D (t = 0.2 s)" if prob == "sod" else "Sedov 3D octant (t = 0.02-0.05 s)")
        ax.grid(alpha=0.3, which="both")
        ax.legend()
    fig.suptitle("Speed against error (labels: particle count)")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "speed_vs_error.png"), dpi=110)
    plt.close(fig)
    print("\nfigure: bench/speed_vs_error/speed_vs_error.png")


if __name__ == "__main__":
    sys.exit(main())
