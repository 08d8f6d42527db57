#!/usr/bin/python3
"""PySPH's taylor_bar example against the same 2D scene in ejecta, both run by this script.

    nice /usr/bin/python3 validation/pysph_taylor_bar/check.py --build build [--tf 2.5e-5]
        [--threads 1] [--variant] [--reuse]

Reference: PySPH (Debian python3-pysph) pysph/examples/solid_mech/taylor_bar.py, run unchanged
(a copy in a temporary directory, /usr/bin/python3, its own --tf, output to a temporary
directory, final output read with pysph.solver.utils.load). 2D plane-strain steel bar 7.6 x 25.4
mm, 21 x 67 = 1407 particles at dx = 0.384848 mm, h = 2 dx, Wendland C2 ("WendlandQuintic"),
Mie-Grueneisen (C 3630, S 1800, gamma 1.81), G 80 GPa, von Mises Y 600 MPa perfectly plastic,
Monaghan viscosity alpha = beta = 0.5, XSPH 0.5, 200 m/s onto a plate with Monaghan's boundary
force, PEC integrator, dt 1e-9 s, tf 25 us.

ejecta: examples/sph_taylor_bar_2d.yaml (this script generates it from the constants of the copied
example and checks that the file in examples/ is the same scene): the same particles (checked to
1e-12 m), the same kernel, h, moduli, yield stress, viscosity, XSPH, velocity and fixed dt, and the
same plate: PySPH's row of plate particles (x = -15.2 mm + i dx, y = 0, mass dx^2 rho0; checked to
1e-12 m) as a fixed rigid_body set acting through ejecta's `repulsive_wall` interaction (Monaghan's
boundary force with PySPH's constants: deltap = dx, 0.02 c^2 / y with PySPH's constant cs, h = 2 dx).
The EOS is ejecta's `polynomial` with PySPH's coefficients and `tension: linear`, T2 = -gamma a0 / 2:
identical in tension, identical in compression up to PySPH's -gamma c0 mu^4 / 2 term.
The differences left (README.md): ejecta's sound speed in the viscosity is max(EOS c, material c)
where PySPH keeps cs = 4699 m/s; velocity Verlet instead of PEC; PySPH's energy equation drops the
(v_ij . grad W) factor of its pressure/viscosity term; PySPH's yield check leaves s22 out of J.
--variant also runs ejecta with mie_gruneisen and the physical S1 = 1.8 (sensitivity only).

Measured on the final particles of each code (same definitions for both):
  L = max y - min y + dx (the initial bar gives 67 dx = 25.78 mm);
  W = max x - min x + dx over the particles within dx of the lowest one (impact-face width);
  Wmax = max x - min x + dx over all particles (mushroom width: PySPH's face curls up, its widest
  particles are a few layers above its lowest one);
  Ltop = max y + dx/2 (top above the plate line y = 0; reported, not a criterion).
Tolerances (PySPH is the reference): |L/L_pysph - 1| <= 2 %, |W/W_pysph - 1| <= 5 %,
|Wmax/Wmax_pysph - 1| <= 5 %.
Also printed: wall-time and CPU-time ratios ejecta / PySPH for the same number of steps and
threads (PySPH's Cython is compiled by an untimed warm-up run first). Writes
pysph_taylor_bar.png (both final shapes and half-width profiles). Exit 0 on PASS, 1 on FAIL.
"""
import argparse
import glob
import importlib.util
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import common  # noqa: E402

PYSPH_EXAMPLE = "/usr/lib/python3/dist-packages/pysph/examples/solid_mech/taylor_bar.py"
EXAMPLE = os.path.join(common.ROOT, "examples", "sph_taylor_bar_2d.yaml")
TOL = {"L": 0.02, "W": 0.05, "Wmax": 0.05}
# Hard-coded inside the example's functions (checked against its source text below).
IN_SOURCE = {"velocity": "pa.v[:]=-200", "alpha": "alpha=0.5, beta=0.5", "xsph": "eps=0.5)",
             "dt": "dt = 1e-9", "tf": "tf = 2.5e-5", "hdx": "hdx = 2.0"}


def load_constants(path):
    """The module-level constants of the copied PySPH example (imports pysph)."""
    spec = importlib.util.spec_from_file_location("pysph_taylor_bar_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    src = open(path).read()
    missing = [k for k, s in IN_SOURCE.items() if s not in src]
    if missing:
        sys.exit(f"error: {path} differs from the example this check was written for ({missing})")
    return mod


def eos_coefficients(k):
    """PySPH's MieGruneisenEOS (pysph/sph/solid_mech/hvi.py), mu = rho/r0 - 1:
    p = (1 - gamma mu / 2) P_H + gamma rho e, P_H = a0 mu + b0 mu^2 + c0 mu^3 for mu > 0 and a0 mu
    for mu <= 0, a0 = r0 C^2, b0 = a0 (1 + 2 (S - 1)), c0 = a0 (2 (S - 1) + 3 (S - 1)^2) (the
    Hugoniot expanded to third order). As ejecta's polynomial EOS p = C1 mu + C2 mu^2 + C3 mu^3 +
    (C4 + C5 mu) rho0 e: C1 = a0, C2 = b0 - gamma a0 / 2, C3 = c0 - gamma b0 / 2, C4 = C5 = gamma
    (gamma rho e = gamma rho0 (1 + mu) e); PySPH's -gamma c0 mu^4 / 2 term has no counterpart. In
    tension `tension: linear` with T2 = -gamma a0 / 2 gives p = (1 - gamma mu / 2) a0 mu + gamma rho e,
    PySPH's tension branch exactly."""
    a0 = k.r0 * k.C * k.C
    b0 = a0 * (1 + 2 * (k.S - 1))
    c0 = a0 * (2 * (k.S - 1) + 3 * (k.S - 1) ** 2)
    return {"C1": a0, "C2": b0 - 0.5 * k.gamma * a0, "C3": c0 - 0.5 * k.gamma * b0, "C4": k.gamma, "C5": k.gamma,
            "T2": -0.5 * k.gamma * a0}


def plate_x(k):
    """PySPH's plate particles (get_plate_particles): x = arange(plate_start, plate_end + dx, dx), y = 0."""
    return np.arange(k.plate_start, k.plate_end + k.dx, k.dx)


def scene(k, out="out/sph_taylor_bar_2d.h5", t_end=None, eos="polynomial"):
    dx = k.dx
    nx = len(np.arange(-k.bar_width / 2.0, k.bar_width / 2.0 + dx, dx))
    ny = len(np.arange(4 * dx, 0.0254 + 4 * dx, dx))
    x0, y0 = -k.bar_width / 2.0, 4 * dx  # first lattice point; ejecta fills box cells at lo + (i + 1/2) dx
    lo = (float(x0 - 0.5 * dx), float(y0 - 0.5 * dx))
    hi = (float(x0 + (nx - 0.5) * dx), float(y0 + (ny - 0.5) * dx))
    # Material sound speed sqrt((K + 4G/3)/rho0) = PySPH's constant cs (ss); K enters nothing else
    # (volumetric: eos).
    K = float(k.r0 * k.ss ** 2 - 4.0 / 3.0 * k.G)
    px = plate_x(k)
    plo, phi = float(px[0] - 0.5 * dx), float(px[0] + (len(px) - 0.5) * dx)
    if eos == "polynomial":
        c = eos_coefficients(k)
        eos_line = (f"{{model: polynomial, rho0: {k.r0!r}, C1: {c['C1']!r}, C2: {c['C2']!r}, "
                    f"C3: {c['C3']!r}, C4: {c['C4']!r}, C5: {c['C5']!r}, tension: linear, T2: {c['T2']!r}}}")
    else:  # sensitivity variant: the closed-form Mie-Grueneisen with steel's physical S1 = 1.8
        eos_line = (f"{{model: mie_gruneisen, rho0: {k.r0!r}, C0: {k.C!r}, S1: 1.8, "
                    f"gamma0: {k.gamma!r}, a: {k.gamma!r}}}")
    t_end = 2.5e-5 if t_end is None else t_end
    return f"""# PySPH's solid_mech/taylor_bar.py example (Debian python3-pysph) as an ejecta scene: 2D plane
# strain steel bar 7.6 x 25.4 mm, {nx} x {ny} = {nx * ny} particles on PySPH's lattice (x = -3.8 mm + i dx,
# y = 4 dx + j dx, dx = {dx * 1e3:g} mm), 200 m/s onto a rigid plate at y = 0.
# Generated by validation/pysph_taylor_bar/check.py --write-example (which compares the two codes);
# see validation/pysph_taylor_bar/README.md for every difference from PySPH. In short:
# * plate: PySPH's row of {len(px)} plate particles (x = {px[0] * 1e3:g} mm + i dx, y = 0, mass dx^2 rho0), a
#   fixed rigid body, with Monaghan's repulsive boundary force (repulsive_wall: PySPH's
#   MonaghanBoundaryForce with deltap = dx, 0.02 c^2 / y, c = PySPH's constant cs, range 2h);
# * EOS: polynomial with PySPH's MieGruneisenEOS coefficients (C 3630, S 1800, gamma 1.81 expanded to
#   third order in mu, identical in compression up to PySPH's -gamma c0 mu^4/2 term; in tension
#   `tension: linear` with T2 = -gamma a0 / 2 gives PySPH's a0 mu - gamma a0 mu^2/2 + gamma rho e).
#   ejecta's mie_gruneisen is the closed form, whose denominator vanishes at mu = 1/(S - 1) = 5.6e-4
#   with S = 1800: not usable here;
# * K is chosen so that the material sound speed sqrt((K + 4G/3)/rho0) = {k.ss:g} m/s, PySPH's
#   constant cs (the viscosity uses max(EOS c, material c); with volumetric: eos K enters nothing else);
# * artificial stress off: PySPH's example never computes its r_ij (no MonaghanArtificialStress);
# * Jaumann stress rate, von Mises perfectly plastic, Monaghan viscosity alpha = beta = 0.5 (eta 0.1
#   as PySPH's EPS = 0.01 h^2), XSPH 0.5, Wendland C2 with h = 2 dx fixed, fixed dt = 1e-9 s as PySPH.
ejecta: 1
dimension: 2
time: {{end: {t_end:.6g}, dt: 1e-9}}
output: {{file: {out}, every: 5e-6, fields: [v, rho, p, stress, eps_p]}}
materials:
  steel:
    model: von_mises
    rho0: {k.r0!r}
    K: {K!r}
    G: {k.G!r}
    yield_stress: {k.Yo!r}
    H: 0
    volumetric: eos
    eos: {eos_line}
  plate_mat: {{rho0: {k.r0!r}}}
sets:
  bar:
    method: sph
    strength: true
    stress_rate: jaumann
    art_stress: false
    xsph: 0.5
    kernel: wendland_c2
    h_factor: {k.hdx:g}
    variable_h: false
    alpha: 0.5
    beta: 0.5
    eta: 0.1
    material: steel
    shape: {{box: {{min: [{lo[0]!r}, {lo[1]!r}], max: [{hi[0]!r}, {hi[1]!r}]}}}}
    spacing: {dx!r}
    velocity: [0, -200]
  plate:
    method: rigid_body
    material: plate_mat
    fix_translation: [1, 1, 1]
    fix_rotation: [1, 1, 1]
    shape: {{box: {{min: [{plo!r}, {-0.5 * dx!r}], max: [{phi!r}, {0.5 * dx!r}]}}}}
    spacing: {dx!r}
interactions:
  - {{model: repulsive_wall, sets: [bar, plate], normal: [0, 1, 0], spacing: {dx!r}, coefficient: 0.02,
     sound_speed: {k.ss!r}}}
"""


def measure(x, y, dx):
    L = y.max() - y.min() + dx
    face = y < y.min() + dx
    W = x[face].max() - x[face].min() + dx
    return {"L": L, "W": W, "Wmax": x.max() - x.min() + dx, "Ltop": y.max() + 0.5 * dx}


def half_width(x, y, dx, edges):
    """Max |x| + dx/2 of the particles in each y bin (nan for empty bins)."""
    w = np.full(len(edges) - 1, np.nan)
    idx = np.digitize(y, edges) - 1
    for b in range(len(w)):
        m = idx == b
        if m.any():
            w[b] = np.abs(x[m]).max() + 0.5 * dx
    return w


def timed(cmd, env=None, cwd=None):
    """(wall seconds, CPU seconds of the children, completed process)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, cwd=cwd)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if res.returncode != 0:
        sys.stdout.write(res.stdout[-4000:])
        raise RuntimeError(f"{' '.join(cmd)} exited with {res.returncode}")
    return wall, cpu, res


def run_pysph(script, outdir, tf, threads):
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    extra = ["--openmp"] if threads > 1 else []
    # untimed warm-up: compiles (or finds in ~/.pysph) the generated Cython
    timed([sys.executable, script, "-d", os.path.join(outdir, "warmup"), "--tf", "2e-9", "-q"] + extra, env)
    wall, cpu, _ = timed([sys.executable, script, "-d", outdir, "--tf", repr(tf), "--pfreq", "1000000", "-q"] + extra,
                         env)
    from pysph.solver.utils import load
    files = sorted(glob.glob(os.path.join(outdir, "taylor_bar_*.hdf5")) + glob.glob(os.path.join(outdir, "taylor_bar_*.npz")))
    first, last = load(files[0]), load(files[-1])
    with open(os.path.join(outdir, "taylor_bar.info")) as f:
        solver = float(json.load(f)["cpu_time"])
    b0, b = first["arrays"]["bar"], last["arrays"]["bar"]
    # copies: the arrays of a ParticleArray share memory that is freed with it
    return {"x0": np.c_[b0.x, b0.y], "x": np.array(b.x), "y": np.array(b.y), "rho": np.array(b.rho),
            "p": np.array(b.p), "t": float(last["solver_data"]["t"]), "steps": int(last["solver_data"]["count"]),
            "wall": wall, "cpu": cpu, "solver": solver}


def run_ejecta(exe, text, name, outdir, threads, reuse=False):
    os.makedirs(outdir, exist_ok=True)
    path = os.path.join(outdir, name + ".yaml")
    out = os.path.join(outdir, name + ".h5")
    with open(path, "w") as f:
        f.write(text)
    times = os.path.join(outdir, name + ".times.json")
    if reuse and os.path.exists(out) and os.path.exists(times):
        with open(times) as f:
            wall, cpu = json.load(f)
    else:
        wall, cpu, _ = timed([exe, "run", path, "-o", out, "--threads", str(threads)])
        with open(times, "w") as f:
            json.dump([wall, cpu], f)
    d = common.read_frame(out, None, "bar")
    d0 = common.read_frame(out, common.frames(out)[0], "bar")
    pl = common.read_frame(out, common.frames(out)[0], "plate")
    return {"x0": d0["x"][:, :2], "x": d["x"][:, 0], "y": d["x"][:, 1], "rho": d["rho"], "p": d["p"],
            "t": d["time"], "steps": d["step"], "wall": wall, "cpu": cpu, "plate0": pl["x"][:, :2]}


def same_lattice(a, b):
    ka = np.lexsort((np.round(a[:, 0], 9), np.round(a[:, 1], 9)))
    kb = np.lexsort((np.round(b[:, 0], 9), np.round(b[:, 1], 9)))
    return len(a) == len(b) and float(np.abs(a[ka] - b[kb]).max()) < 1e-12


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--tf", type=float, default=2.5e-5, help="end time for both codes (PySPH's default 25 us)")
    ap.add_argument("--threads", type=int, default=1, help="threads for both codes (PySPH: --openmp when > 1)")
    ap.add_argument("--variant", action="store_true", help="also run ejecta with mie_gruneisen S1 = 1.8")
    ap.add_argument("--reuse", action="store_true", help="reuse the saved outputs and timings of both codes")
    ap.add_argument("--write-example", action="store_true", help=f"(re)write {os.path.relpath(EXAMPLE, common.ROOT)}")
    args = ap.parse_args()

    tmp = tempfile.mkdtemp(prefix="pysph_taylor_bar_")
    try:
        script = os.path.join(tmp, "taylor_bar.py")
        shutil.copy(PYSPH_EXAMPLE, script)
        k = load_constants(script)
        example_text = scene(k)
        if args.write_example:
            with open(EXAMPLE, "w") as f:
                f.write(example_text)
            print(f"wrote {EXAMPLE}")
        elif not os.path.exists(EXAMPLE) or open(EXAMPLE).read() != example_text:
            print(f"WARNING: {EXAMPLE} is not the scene generated from PySPH's constants (--write-example)")
        exe = common.ejecta_binary(args.build)

        saved = os.path.join(args.out, "pysph_final.npz")
        if args.reuse and os.path.exists(saved):
            with np.load(saved) as z:
                py = {key: (z[key][()] if z[key].ndim == 0 else z[key]) for key in z.files}
            print(f"PySPH: reusing {saved}")
        else:
            print(f"PySPH {PYSPH_EXAMPLE}: tf = {args.tf:g} s, {args.threads} thread(s) ...", flush=True)
            py = run_pysph(script, os.path.join(tmp, "pysph"), args.tf, args.threads)
            os.makedirs(args.out, exist_ok=True)
            np.savez(saved, **py)
        print(f"  {len(py['x'])} particles, {py['steps']} steps to t = {py['t']:.4g} s: process {py['wall']:.1f} s "
              f"wall, {py['cpu']:.1f} s CPU (solver 'Run took' {py['solver']:.1f} s)", flush=True)
        runs = [("ejecta", "polynomial")] + ([("ejecta MG S1=1.8", "mie_gruneisen")] if args.variant else [])
        ej = {}
        for label, eos in runs:
            name = "taylor2d_" + eos
            text = scene(k, out=os.path.join(args.out, name + ".h5"), t_end=args.tf, eos=eos)
            r = run_ejecta(exe, text, name, args.out, args.threads, args.reuse)
            ej[label] = r
            print(f"  {label}: {len(r['x'])} particles, {r['steps']} steps to t = {r['t']:.4g} s: {r['wall']:.1f} s wall, "
                  f"{r['cpu']:.1f} s CPU", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    e = ej["ejecta"]
    lattice_ok = same_lattice(py["x0"], e["x0"])
    print(f"  same initial particles (to 1e-12 m): {lattice_ok}")
    px = plate_x(k)
    plate_ok = same_lattice(np.c_[px, np.zeros_like(px)], e["plate0"])
    print(f"  same plate particles as PySPH's get_plate_particles ({len(px)}, to 1e-12 m): {plate_ok}")
    lattice_ok = lattice_ok and plate_ok
    dx = k.dx
    res = {"PySPH": measure(py["x"], py["y"], dx)}
    for label, r in ej.items():
        res[label] = measure(r["x"], r["y"], dx)
    mu = {"PySPH": py["rho"] / k.r0 - 1}
    mu.update({label: r["rho"] / k.r0 - 1 for label, r in ej.items()})
    L0 = (np.ptp(py["x0"][:, 1]) + dx)
    print(f"\n  initial length {L0 * 1e3:.2f} mm (67 dx), width {(np.ptp(py['x0'][:, 0]) + dx) * 1e3:.2f} mm (21 dx)")
    for label, m in res.items():
        extra = ""
        if label != "PySPH":
            extra = "\n" + " " * 21 + ", ".join(f"d{q} {100 * (m[q] / res['PySPH'][q] - 1):+.2f} %" for q in m)
        print(f"  {label:<18s} L = {m['L'] * 1e3:6.2f} mm, face width W = {m['W'] * 1e3:6.2f} mm, max width Wmax = "
              f"{m['Wmax'] * 1e3:6.2f} mm, top Ltop = {m['Ltop'] * 1e3:6.2f} mm, "
              f"mu in [{mu[label].min():+.2e}, {mu[label].max():+.2e}]{extra}")

    # profiles and figure
    edges = np.arange(min(py["y"].min(), e["y"].min()) - dx, max(py["y"].max(), e["y"].max()) + 2 * dx, dx)
    wp = half_width(py["x"], py["y"], dx, edges)
    we = half_width(e["x"], e["y"], dx, edges)
    both = ~np.isnan(wp) & ~np.isnan(we)
    rms = float(np.sqrt(np.mean((we[both] - wp[both]) ** 2)))
    print(f"  half-width profile (bins of dx): RMS difference ejecta - PySPH {rms * 1e3:.3f} mm = {rms / dx:.2f} dx")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 6.5), gridspec_kw={"width_ratios": [1.3, 1]})
    a1.plot(py["x0"][:, 0] * 1e3, py["x0"][:, 1] * 1e3, ".", color="0.85", ms=2, label="initial")
    a1.plot(py["x"] * 1e3, py["y"] * 1e3, "o", mfc="none", mec="C0", ms=4, mew=0.6, label="PySPH")
    a1.plot(e["x"] * 1e3, e["y"] * 1e3, ".", color="C3", ms=3, label="ejecta")
    a1.axhline(0, color="k", lw=1)
    a1.set_aspect("equal")
    a1.set_xlabel("x [mm]")
    a1.set_ylabel("y [mm]")
    a1.set_title(f"final particles, t = {py['t'] * 1e6:.1f} us")
    a1.legend(fontsize=8, loc="upper right")
    yc = 0.5 * (edges[1:] + edges[:-1])
    a2.plot(wp * 1e3, yc * 1e3, "-o", ms=3, color="C0", label=f"PySPH  L {res['PySPH']['L'] * 1e3:.2f}, W {res['PySPH']['W'] * 1e3:.2f} mm")
    a2.plot(we * 1e3, yc * 1e3, "-", color="C3", label=f"ejecta L {res['ejecta']['L'] * 1e3:.2f}, W {res['ejecta']['W'] * 1e3:.2f} mm")
    for i, label in enumerate(ej):
        if label != "ejecta":
            wv = half_width(ej[label]["x"], ej[label]["y"], dx, edges)
            a2.plot(wv * 1e3, yc * 1e3, "--", color=f"C{i + 1}",
                    label=f"{label} L {res[label]['L'] * 1e3:.2f}, W {res[label]['W'] * 1e3:.2f} mm")
    a2.set_xlabel("half width max|x| + dx/2 [mm]")
    a2.set_ylabel("y [mm]")
    ratio_w = e["wall"] / py["wall"] if e["wall"] > 0 else float("nan")
    a2.set_title(f"half-width profiles; wall time ejecta/PySPH {ratio_w:.2f}")
    a2.legend(fontsize=8)
    fig.suptitle("PySPH taylor_bar example vs ejecta, 2D plane strain, 200 m/s, same particles and parameters")
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.09, top=0.88, wspace=0.25)
    png = os.path.join(HERE, "pysph_taylor_bar.png")
    fig.savefig(png, dpi=120)
    print(f"  wrote {os.path.relpath(png)}")
    # the ejecta run's energy budget through tools/plot_series.py
    common.energy_figure(os.path.join(args.out, "taylor2d_polynomial.h5"), os.path.join(HERE, "pysph_taylor_bar_energy.png"),
                         title="ejecta side of the PySPH taylor_bar comparison: energy budget")
    print(f"  wrote {os.path.relpath(os.path.join(HERE, 'pysph_taylor_bar_energy.png'))}")

    if e["wall"] > 0:
        print(f"  time ejecta / PySPH ({args.threads} thread(s), {e['steps']} vs {py['steps']} steps): wall "
              f"{e['wall']:.1f} / {py['wall']:.1f} s = {e['wall'] / py['wall']:.3f}; CPU {e['cpu']:.1f} / {py['cpu']:.1f} s "
              f"= {e['cpu'] / py['cpu']:.3f}; vs PySPH solver time {e['wall'] / py['solver']:.3f}")
    try:
        with open("/proc/loadavg") as f:
            print(f"  load average after: {' '.join(f.read().split()[:3])}")
    except OSError:
        pass
    d = {q: res["ejecta"][q] / res["PySPH"][q] - 1 for q in TOL}
    ok = lattice_ok and all(abs(d[q]) <= TOL[q] for q in TOL)
    print(("PASS" if ok else "FAIL") + " (" + ", ".join(f"{q} {100 * d[q]:+.2f} % [tol {100 * TOL[q]:g} %]" for q in TOL)
          + f", same particles {lattice_ok}; Ltop {100 * (res['ejecta']['Ltop'] / res['PySPH']['Ltop'] - 1):+.2f} % "
          "reported only)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
