#!/usr/bin/python3
"""Compare a field of an ejecta output frame along a line with a reference curve (CSV).

Particles of one set within --width of the line segment A-B are projected on it; their
distance s from A and the field value are compared with the reference y(s), interpolated
linearly at each particle's s (particles outside the reference's s range are left out).
Prints the errors and writes a PNG of both curves:

  L1   = mean |value - ref|              Linf = max |value - ref|
  L1_rel = sum |value - ref| / sum |ref|  (also Linf_rel = Linf / max |ref|)

With --tol-l1 / --tol-linf (relative, unless --absolute) it prints PASS or FAIL and exits 1 on
FAIL, so validation scripts can call it.

The reference CSV has a header; --ref-columns names the s and value columns (default: the
first two). Examples:
  tools/compare.py out/sod_1d.h5 --set tube --field rho --line 0 0 0 0.5 0 0 --ref exact.csv
  tools/compare.py out/run.h5 --set bar --field stress --component xx --axis x --time 20us \\
      --ref ref.csv --ref-columns x,sxx --tol-l1 0.05 -o stress.png
Needs /usr/bin/python3 with h5py, numpy and matplotlib.
"""
import argparse
import os
import re
import sys

import h5py
import numpy as np

VOIGT = {"xx": 0, "yy": 1, "zz": 2, "xy": 3, "yz": 4, "zx": 5, "xz": 5}
UNITS = {"s": 1, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}


def parse_time(text):
    m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*([a-z]*)\s*", text)
    if not m or m.group(2) not in UNITS and m.group(2):
        sys.exit(f"compare: cannot read time '{text}' (e.g. 0.2, 20us, 1.5 ms)")
    return float(m.group(1)) * UNITS.get(m.group(2) or "s")


def pick_frame(f, frame, time):
    names = sorted(f["frames"].keys())
    if not names:
        sys.exit("compare: the file has no frames")
    if time is None:
        return names[frame]
    times = np.array([f["frames"][n].attrs["time"] for n in names])
    return names[int(np.argmin(np.abs(times - time)))]


def field_values(ds, component):
    v = np.asarray(ds[:], dtype=float)
    if v.ndim == 1:
        return v
    if component in (None, "norm"):
        if v.shape[1] == 6 and component is None:
            sys.exit("compare: a symmetric tensor needs --component xx|yy|zz|xy|yz|zx|norm")
        if v.shape[1] == 6:  # Frobenius norm of the full tensor from Voigt storage
            return np.sqrt(np.sum(v[:, :3] ** 2, axis=1) + 2 * np.sum(v[:, 3:] ** 2, axis=1))
        return np.linalg.norm(v, axis=1)
    if component in VOIGT and v.shape[1] == 6:
        return v[:, VOIGT[component]]
    if component in ("x", "y", "z"):
        return v[:, "xyz".index(component)]
    return v[:, int(component)]


def read_ref(path, columns):
    with open(path) as fh:
        header = fh.readline().strip()
    names = [h.strip() for h in header.split(",")]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if columns:
        cs, cv = [c.strip() for c in columns.split(",")]
        if cs not in names or cv not in names:
            sys.exit(f"compare: reference columns {columns} not in header {names}")
        i, j = names.index(cs), names.index(cv)
    else:
        i, j = 0, 1
    s, y = data[:, i], data[:, j]
    order = np.argsort(s)
    return s[order], y[order], names[i], names[j]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file", help="ejecta output (.h5 or .h5.partial)")
    ap.add_argument("--set", required=True, help="particle set name")
    ap.add_argument("--field", required=True, help="field name (rho, p, v, stress, ...)")
    ap.add_argument("--component", help="vector component x|y|z|index, tensor xx|yy|zz|xy|yz|zx, or norm")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--frame", type=int, default=-1, help="frame index (default -1: the last)")
    g.add_argument("--time", type=parse_time, help="the frame nearest to this time (e.g. 20us)")
    ln = ap.add_mutually_exclusive_group(required=True)
    ln.add_argument("--line", type=float, nargs=6, metavar=("AX", "AY", "AZ", "BX", "BY", "BZ"),
                    help="segment from A to B; s is the distance from A")
    ln.add_argument("--axis", choices=["x", "y", "z"], help="the whole coordinate axis: s is that coordinate")
    ap.add_argument("--width", type=float, default=np.inf,
                    help="keep particles within this distance of the line (m; default: all)")
    ap.add_argument("--ref", required=True, help="reference CSV with a header line")
    ap.add_argument("--ref-columns", help="S,VALUE column names of the reference (default: first two)")
    ap.add_argument("--tol-l1", type=float, help="PASS/FAIL threshold on L1 (relative unless --absolute)")
    ap.add_argument("--tol-linf", type=float, help="PASS/FAIL threshold on Linf (relative unless --absolute)")
    ap.add_argument("--absolute", action="store_true", help="tolerances are absolute errors")
    ap.add_argument("-o", "--output", help="PNG (default: FILE stem + _compare_<field>.png)")
    a = ap.parse_args(argv)

    with h5py.File(a.file, "r") as f:
        fname = pick_frame(f, a.frame, a.time)
        fr = f["frames"][fname]
        if a.set not in fr:
            sys.exit(f"compare: no set '{a.set}' in frame {fname} (sets: {', '.join(fr.keys())})")
        grp = fr[a.set]
        if a.field not in grp:
            sys.exit(f"compare: no field '{a.field}' in set '{a.set}' (fields: {', '.join(grp.keys())})")
        x = np.asarray(grp["x"][:], dtype=float)
        val = field_values(grp[a.field], a.component)
        t = float(fr.attrs["time"])
        unit = grp[a.field].attrs.get("unit", "")
        unit = unit.decode() if isinstance(unit, bytes) else str(unit)

    if a.axis:
        k = "xyz".index(a.axis)
        s, dist = x[:, k], np.zeros(len(x))
        if np.isfinite(a.width):
            others = [c for c in range(3) if c != k]
            dist = np.linalg.norm(x[:, others], axis=1)
    else:
        A, B = np.array(a.line[:3]), np.array(a.line[3:])
        L = np.linalg.norm(B - A)
        if L == 0:
            sys.exit("compare: --line needs two different points")
        u = (B - A) / L
        s = (x - A) @ u
        dist = np.linalg.norm((x - A) - np.outer(s, u), axis=1)
        keep = (s >= 0) & (s <= L)
        dist = np.where(keep, dist, np.inf)
    rs, ry, rsn, ryn = read_ref(a.ref, a.ref_columns)
    sel = (dist <= a.width) & (s >= rs[0]) & (s <= rs[-1])
    if not np.any(sel):
        sys.exit("compare: no particle within --width of the line inside the reference's range")
    s, val = s[sel], val[sel]
    order = np.argsort(s, kind="stable")
    s, val = s[order], val[order]
    ref = np.interp(s, rs, ry)
    err = val - ref
    l1, linf = float(np.mean(np.abs(err))), float(np.max(np.abs(err)))
    sref = float(np.sum(np.abs(ref)))
    l1_rel = float(np.sum(np.abs(err)) / sref) if sref > 0 else float("inf")
    linf_rel = linf / float(np.max(np.abs(ref))) if np.max(np.abs(ref)) > 0 else float("inf")
    name = a.field + (f".{a.component}" if a.component else "")
    print(f"compare: {a.file} frame {fname} t = {t:.6g} s, set '{a.set}', {name}: {len(s)} particles")
    print(f"compare: L1 = {l1:.6g}  Linf = {linf:.6g}  L1_rel = {l1_rel:.6g}  Linf_rel = {linf_rel:.6g}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(rs, ry, "k-", lw=1.5, label=f"reference ({os.path.basename(a.ref)}: {ryn})")
    ax.plot(s, val, "o", ms=3, mfc="none", label=f"ejecta {name}")
    ax.set_xlabel(f"s along the line [m] ({rsn})" if not a.axis else f"{a.axis} [m]")
    ax.set_ylabel(name + (f" [{unit}]" if unit and unit != "1" else ""))
    ax.set_title(f"{os.path.basename(a.file)}, t = {t:.4g} s: L1_rel = {l1_rel:.3g}, Linf_rel = {linf_rel:.3g}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    stem = os.path.splitext(a.file[:-len(".partial")] if a.file.endswith(".partial") else a.file)[0]
    out = a.output or f"{stem}_compare_{name.replace('.', '_')}.png"
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(f"compare: wrote {out}")

    ok = True
    if a.tol_l1 is not None:
        m = l1 if a.absolute else l1_rel
        ok &= m <= a.tol_l1
        print(f"compare: L1{'' if a.absolute else '_rel'} {m:.6g} vs tolerance {a.tol_l1:g}")
    if a.tol_linf is not None:
        m = linf if a.absolute else linf_rel
        ok &= m <= a.tol_linf
        print(f"compare: Linf{'' if a.absolute else '_rel'} {m:.6g} vs tolerance {a.tol_linf:g}")
    if a.tol_l1 is not None or a.tol_linf is not None:
        print("PASS" if ok else "FAIL")
        return 0 if ok else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
