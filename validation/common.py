"""Helpers shared by the validation checkers: locate the build, write scenes, run ejecta, read
frames and series from its HDF5 output. Only /usr/bin/python3 has numpy, h5py and matplotlib."""
import os
import subprocess
import sys
import time

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def ejecta_binary(build):
    """build/bin/ejecta, with build relative to the working directory or the repository root."""
    for base in (os.getcwd(), ROOT):
        exe = os.path.join(base, build, "bin", "ejecta")
        if os.path.isfile(exe) and os.access(exe, os.X_OK):
            return exe
    sys.exit(f"error: no ejecta executable under '{build}/bin' (build it first: make build)")


def run(exe, scene_text, name, outdir, threads=2, reuse=False, log=print):
    """Writes outdir/name.yaml, runs it into outdir/name.h5 (unless reuse and the file exists)
    and returns (h5 path, wall seconds; 0 when reused)."""
    os.makedirs(outdir, exist_ok=True)
    scene = os.path.join(outdir, name + ".yaml")
    out = os.path.join(outdir, name + ".h5")
    if reuse and os.path.exists(out):
        return out, 0.0
    with open(scene, "w") as f:
        f.write(scene_text)
    t0 = time.time()
    cmd = [exe, "run", scene, "-o", out, "--threads", str(threads)]
    # libgomp's default wait policy spins at every barrier: on a loaded (shared) machine a
    # 2-thread run then burns ~9x the CPU of the 1-thread one (validation/taylor_bar README).
    env = dict(os.environ)
    env.setdefault("OMP_WAIT_POLICY", "passive")
    res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    wall = time.time() - t0
    if res.returncode != 0:
        sys.stdout.write(res.stdout)
        raise RuntimeError(f"{' '.join(cmd)} exited with {res.returncode}")
    log(f"  ran {name:<24s} {wall:7.1f} s")
    return out, wall


def frames(path):
    """Names of the frames in time order."""
    with h5py.File(path, "r") as f:
        return sorted(f["frames"].keys())


def read_frame(path, frame=None, set_name=None):
    """Fields of one set in one frame (the last by default) as a dict of arrays, plus 'time'
    and 'step'."""
    with h5py.File(path, "r") as f:
        names = sorted(f["frames"].keys())
        g = f["frames"][names[-1] if frame is None else frame]
        s = g[set_name] if set_name else g[sorted(g.keys())[0]]
        d = {k: s[k][()] for k in s.keys()}
        d["time"] = float(g.attrs["time"])
        d["step"] = int(g.attrs["step"])
    return d


def read_series(path, name="energy"):
    with h5py.File(path, "r") as f:
        g = f["series"][name]
        return {k: g[k][()] for k in g.keys()}


def order(h, err):
    """Least-squares slope of log(err) against log(h), and the pairwise slopes."""
    lh, le = np.log(np.asarray(h)), np.log(np.asarray(err))
    slope = np.polyfit(lh, le, 1)[0]
    pairs = [(le[i + 1] - le[i]) / (lh[i + 1] - lh[i]) for i in range(len(h) - 1)]
    return slope, pairs


def _tool(name):
    """tools/<name>.py as a module: the validation figures are drawn by the user-facing tools."""
    tools = os.path.join(ROOT, "tools")
    if tools not in sys.path:
        sys.path.insert(0, tools)
    return __import__(name)


def energy_figure(h5, png, title=None, series=None):
    """The run's energy budget (or the named series) against time, by tools/plot_series.py:
    every validation case shows the energy budget of its reference run this way."""
    argv = [h5] + list(series or []) + ["-o", png]
    if not series:
        argv += ["--preset", "energy"]
    if title:
        argv += ["--title", title]
    rc = _tool("plot_series").main(argv)
    if rc:
        raise RuntimeError(f"tools/plot_series.py {' '.join(argv)} exited with {rc}")
    return png


def profile_figure(h5, set_name, field, ref_csv, png, component=None, axis=None, line=None, width=None,
                   time=None, ref_columns=None):
    """A field along a line against a reference curve (CSV), by tools/compare.py. Returns the
    relative L1 and Linf errors that compare.py printed (the case applies its own tolerance)."""
    import contextlib
    import io
    argv = [h5, "--set", set_name, "--field", field, "--ref", ref_csv, "-o", png]
    if component:
        argv += ["--component", component]
    argv += ["--axis", axis] if axis else ["--line"] + [str(v) for v in line]
    if width is not None:
        argv += ["--width", str(width)]
    if time is not None:
        argv += ["--time", f"{time!r}"]
    if ref_columns:
        argv += ["--ref-columns", ref_columns]
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = _tool("compare").main(argv)
    text = buf.getvalue()
    if rc:
        sys.stdout.write(text)
        raise RuntimeError(f"tools/compare.py {' '.join(argv)} exited with {rc}")
    for ln in text.splitlines():
        if "L1_rel =" in ln:
            parts = dict(p.split(" = ") for p in ln.replace("compare: ", "").split("  "))
            return float(parts["L1_rel"]), float(parts["Linf_rel"])
    raise RuntimeError("tools/compare.py printed no errors")


def pairs_within(x, r, chunk=512):
    """All pairs (i < j) of the 2-D points x (n x 2, or more columns: the first two count) closer
    than r (brute force in chunks of rows) and their distances."""
    n = len(x)
    ii, jj, dd = [], [], []
    for a in range(0, n, chunk):
        b = min(n, a + chunk)
        d = np.hypot(x[a:b, None, 0] - x[None, :, 0], x[a:b, None, 1] - x[None, :, 1])
        i, j = np.nonzero(d < r)
        keep = (i + a) < j
        ii.append(i[keep] + a)
        jj.append(j[keep])
        dd.append(d[i[keep], j[keep]])
    return np.concatenate(ii), np.concatenate(jj), np.concatenate(dd)


def cluster_count(n, i, j):
    """Connected components of n points linked by the pairs (i[k], j[k]) (union-find): their
    number and the largest one's share of n."""
    parent = np.arange(n)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in zip(i, j):
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb
    roots = np.array([find(a) for a in range(n)])
    _, counts = np.unique(roots, return_counts=True)
    return len(counts), counts.max() / n
