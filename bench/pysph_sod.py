#!/usr/bin/python3
"""Peer comparison: PySPH's own Sod shock tube example against ejecta's 1D Sod, same run.

    /usr/bin/python3 bench/pysph_sod.py --build build [--repeats 3]

PySPH (Debian python3-pysph): pysph/examples/gas_dynamics/sod_shocktube.py at its defaults
(ADKE scheme, Gaussian kernel, hdx 1.2, 640 + 80 = 720 equal-mass particles, fixed dt 1e-4,
PEC integrator, mirrored walls, t = 0.15 s), Cython backend, one thread (OMP_NUM_THREADS=1).
It is run through its own Application class (app.run(), without the example's post_process,
which only draws figures); a first run compiles the generated Cython and is not timed.

ejecta: validation/sod/check.py's sod_scene (SPH, cubic spline, h = 1.3 dx, one spacing on
both sides, initial jump smoothed over 1.5 h, Monaghan viscosity, CFL 0.3), --threads 1, to
the same end time, at (a) the spacing giving the same particle count as PySPH (1/720) and
(b) PySPH's left spacing (0.5/640, 1280 particles).

Error measure for both, as in validation/sod: L1(rho) = sum V_i |rho_i - rho_exact(x_i)| /
sum V_i over |x_i| <= 0.4, V_i = m_i / rho_i, at the last output (t = 0.15 s), exact solution
validation/sod/exact.py. Wall times: best of --repeats; for PySPH both the process wall time
(Python start-up and imports included) and its solver time ("Run took", the .info cpu_time).
Ratios are ejecta / PySPH (time: < 1 means ejecta is faster; L1: < 1 means ejecta is more
accurate). If PySPH cannot run, the reason is printed and ejecta's numbers still are.
"""
import argparse
import glob
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "validation"))
sys.path.insert(0, os.path.join(ROOT, "validation", "sod"))
import common  # noqa: E402
import exact  # noqa: E402
from check import sod_scene  # noqa: E402  (validation/sod/check.py)

WINDOW = 0.4
PYSPH_TF = 0.15        # sod_shocktube.py: tf
PYSPH_N = 640 + 80     # nl = 640 left, nr = nl * 0.125 right

DRIVER = """
import sys
sys.argv = ["sod_shocktube.py"] + sys.argv[1:]
from pysph.examples.gas_dynamics.sod_shocktube import SodShockTube
app = SodShockTube()
app.run()
"""


def l1_density(x, rho, m, t):
    ex, _, _, _ = exact.sample(x, t, exact.SOD_LEFT, exact.SOD_RIGHT)
    vol = m / rho
    w = np.abs(x) <= WINDOW
    return float(np.sum(vol[w] * np.abs(rho[w] - ex[w])) / np.sum(vol[w]))


def pysph_version():
    try:
        import pysph
        return pysph.__version__, os.path.dirname(pysph.__file__)
    except Exception as e:  # noqa: BLE001 (report whatever stops the import)
        return None, f"import pysph failed: {type(e).__name__}: {e}"


def run_pysph_once(outdir, extra=()):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if os.path.isdir(outdir):
        shutil.rmtree(outdir)
    cmd = [sys.executable, "-c", DRIVER, "-d", outdir, "-q"] + list(extra)
    t0 = time.perf_counter()
    res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    wall = time.perf_counter() - t0
    if res.returncode != 0:
        raise RuntimeError(f"PySPH sod_shocktube exited with {res.returncode}:\n" + res.stdout[-3000:])
    return wall


def pysph_result(outdir):
    from pysph.solver.utils import load
    files = sorted(glob.glob(os.path.join(outdir, "sod_shocktube_*.hdf5")) +
                   glob.glob(os.path.join(outdir, "sod_shocktube_*.npz")))
    if not files:
        raise RuntimeError(f"PySPH wrote no output in {outdir}")
    data = load(files[-1])
    pa = data["arrays"]["fluid"]
    t = float(data["solver_data"]["t"])
    steps = int(data["solver_data"]["count"])
    with open(os.path.join(outdir, "sod_shocktube.info")) as f:
        run_time = float(json.load(f)["cpu_time"])
    x, rho, m = np.asarray(pa.x), np.asarray(pa.rho), np.asarray(pa.m)
    return {"n": len(x), "t": t, "steps": steps, "run_time": run_time, "l1": l1_density(x, rho, m, t)}


def measure_pysph(outdir, repeats, log=print):
    version, where = pysph_version()
    if version is None:
        return {"error": where}
    log(f"  PySPH {version} ({where}), example gas_dynamics/sod_shocktube.py, defaults, 1 thread")
    try:
        t0 = time.perf_counter()
        run_pysph_once(os.path.join(outdir, "warmup"), ["--tf", "0.0002", "--disable-output"])
        warm = time.perf_counter() - t0
        log(f"  warm-up run (Cython compilation when not cached): {warm:.1f} s")
        walls, runs = [], []
        for _ in range(repeats):
            walls.append(run_pysph_once(os.path.join(outdir, "pysph")))
            runs.append(pysph_result(os.path.join(outdir, "pysph"))["run_time"])
            log(f"  ran PySPH sod_shocktube   {walls[-1]:6.2f} s (solver {runs[-1]:.2f} s)")
        r = pysph_result(os.path.join(outdir, "pysph"))
        r.update(wall=min(walls), run_time=min(runs), warmup=warm, version=version)
        return r
    except Exception as e:  # noqa: BLE001
        return {"error": f"{type(e).__name__}: {e}", "version": version}


def measure_ejecta(exe, outdir, dx, t_end, repeats, name, log=print):
    walls = []
    for _ in range(repeats):
        path, wall = common.run(exe, sod_scene(1, dx, t_end=t_end, out=os.path.join(outdir, name + ".h5")),
                                name, outdir, threads=1, log=lambda s: None)
        walls.append(wall)
    log(f"  ran ejecta {name:<14s} {', '.join(f'{w:.2f}' for w in walls)} s")
    d = common.read_frame(path)
    steps = int(common.read_series(path)["step"][-1])
    return {"n": len(d["rho"]), "t": d["time"], "steps": steps, "wall": min(walls), "dx": dx,
            "l1": l1_density(d["x"][:, 0], d["rho"], d["m"], d["time"])}


def measure(build="build", repeats=3, outdir=None, log=print):
    exe = common.ejecta_binary(build)
    outdir = outdir or os.path.join(ROOT, "out", "bench", "pysph_sod")
    os.makedirs(outdir, exist_ok=True)
    log("Sod shock tube: PySPH example vs ejecta, L1(rho) over |x| <= 0.4 against the exact solution")
    res = {"pysph": measure_pysph(outdir, repeats, log)}
    tf = res["pysph"].get("t", PYSPH_TF)
    n = res["pysph"].get("n", PYSPH_N)
    res["ejecta_same_n"] = measure_ejecta(exe, outdir, 1.0 / n, tf, repeats, "ejecta_same_n", log)
    res["ejecta_same_dxl"] = measure_ejecta(exe, outdir, 0.5 / 640, tf, repeats, "ejecta_same_dxl", log)
    report(res, log)
    return res


def report(res, log=print):
    p = res["pysph"]
    log(f"\n  {'code':<28} {'particles':>9} {'steps':>6} {'t [s]':>6} {'wall [s]':>9} {'L1(rho)':>9} "
        f"{'time ratio':>10} {'L1 ratio':>9}")
    if "error" in p:
        log(f"  PySPH could not run: {p['error']}")
    else:
        log(f"  {'PySPH ' + p['version'] + ' (ADKE)':<28} {p['n']:9d} {p['steps']:6d} {p['t']:6.3f} "
            f"{p['run_time']:9.2f} {p['l1']:9.5f} {'':>10} {'':>9}")
        log(f"  {'  (process wall)':<28} {'':>9} {'':>6} {'':>6} {p['wall']:9.2f}")
    for key, label in (("ejecta_same_n", "ejecta, same count"), ("ejecta_same_dxl", "ejecta, PySPH left dx")):
        e = res[key]
        tr = lr = ""
        if "error" not in p:
            tr, lr = f"{e['wall'] / p['run_time']:.3f}", f"{e['l1'] / p['l1']:.3f}"
        log(f"  {label:<28} {e['n']:9d} {e['steps']:6d} {e['t']:6.3f} {e['wall']:9.2f} {e['l1']:9.5f} "
            f"{tr:>10} {lr:>9}")
    if "error" not in p:
        log("  time ratio = ejecta process wall / PySPH solver time; L1 ratio = ejecta / PySPH")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    measure(args.build, args.repeats)
    return 0


if __name__ == "__main__":
    sys.exit(main())
