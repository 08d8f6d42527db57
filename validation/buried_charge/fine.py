#!/usr/bin/python3
"""Buried 100 g C4 charge, FINE scenes (issue "coupled blast"): soil-bubble height and width
against time to 0.8 ms for the fine tlpd scenes at DOB 3 cm and 8 cm
(examples/buried_charge_fine.yaml, examples/buried_charge_fine_dob8.yaml) and the fine SPH-soil
scenes at DOB 3 cm and 8 cm (examples/buried_charge_sph_fine.yaml,
examples/buried_charge_sph_fine_dob8.yaml), in one figure (one row per depth of burial) with the
coarse tlpd and SPH-soil scenes (examples/buried_charge.yaml, examples/buried_charge_sph.yaml,
examples/buried_charge_dob8.yaml, 0.5 ms). The tlpd scene at DOB 3 cm has 1.37 M particles (3.75 /
7.5 mm, one lattice for charge and soil, since the README's ninth pass), the tlpd scene at DOB 8 cm
1.13 M (4 / 8 mm, one lattice since the thirteenth pass), the two SPH-soil scenes 1.13 M (4 / 8 mm,
each set's lattice on its own corner).

    /usr/bin/python3 validation/buried_charge/fine.py --full [--build build] [--outdir /tmp/bc_fine]
        [--threads 2] [--reuse] [--fine-sph OUT.h5] [--fine-sph-dob8 OUT.h5[,RESTART.h5]]
        [--fine-tlpd OUT.h5] [--fine-tlpd-dob8 OUT.h5] [--prior-csv CSV] [--png F] [--csv F]

Without --full (and without any --fine-* output) it only says so and exits 0: `make validate` (run_all.py
--full) runs it, the quick validation does not.

Runs what is missing (on 2 cores: the fine SPH scenes about 40 min at DOB 3 cm and 80 min at
8 cm; the fine tlpd scenes about 101 min at DOB 3 cm (1.37 M particles, twelfth pass; 138 min in
the ninth) and 61 min at 8 cm (thirteenth pass, with tlpd's break_skip; 116 min in the sixth),
measured on 2 threads), or reads the outputs given (--fine-sph, --fine-sph-dob8,
--fine-tlpd, --fine-tlpd-dob8; an unfinished run's OUT.h5.partial is read up to its last frame;
"A,B" reads a run A and its restart B from A's checkpoint as one curve), or takes a fine curve
from an earlier CSV of this script (--prior-csv: the outputs are 2-4 GB each and are not kept).
Bubble height and width: tools/bubble.py (all soil above the surface, and the coherent dome,
--min-nbrs 3). No measured reference: Bergeron, Walker & Coffey 1998 (000 Fig. 18) is not in the
sources (README). Prints the curves and, for the runs it made, wall time, CPU time and
particle-steps per second per core. Exit status 1 if a fine run did not reach 0.8 ms.
"""
import argparse
import csv
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import check  # noqa: E402  (run(), curve(), finish_figure())


def ensure(exe, scene, out, threads, reuse):
    """Runs examples/<scene> into out unless it (or its .partial) exists and reuse is set; returns
    (path to read, perf dict or None)."""
    if reuse:
        for p in (out, out + ".partial"):
            if os.path.exists(p):
                return p, None
    text = open(os.path.join(ROOT, "examples", scene)).read()
    text = text.replace("file: out/", "file: " + os.path.dirname(out) + "/", 1)
    stem = os.path.splitext(os.path.basename(scene))[0]
    assert os.path.basename(out) == stem + ".h5", (out, stem)
    perf = check.run(exe, text, os.path.join(os.path.dirname(out), stem + ".yaml"), out, threads, False)
    return (out if os.path.exists(out) else out + ".partial"), perf


def curve_chain(path):
    """check.curve of one output, or of a run and its restarts given as "A,B,...": each later file
    (a run restarted from the checkpoint of the one before, `ejecta run --restart`) supplies the
    frames from its first time on. Steps of the last file, largest |balance| / E0 of all."""
    rows, n, steps, bal = None, None, 0, 0.0
    ref = check.surface(path.split(",")[0])  # a restart measures from the first run's surface
    for p in path.split(","):
        r, n1, s1, b1 = check.curve(p, ref=ref)
        rows = r if rows is None else np.vstack([rows[rows[:, 0] < r[0, 0] - 1e-9], r])
        n = n or n1
        steps = s1
        bal = max(bal, b1) if np.isfinite(b1) else bal
    return rows, n, steps, bal


# CSV columns: check.curve's (an earlier CSV without the last two reads them as nan)
COLS = check.CURVE_COLS


def prior_curves(csv_path):
    """Curves of an earlier fine.py CSV (label -> rows of COLS)."""
    out = {}
    with open(csv_path, newline="") as f:
        for r in csv.DictReader(f):
            out.setdefault(r["run"], []).append([float(r.get(k) or "nan") for k in COLS])
    return {k: np.array(v) for k, v in out.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--outdir", default="/tmp/bc_fine")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reuse", action="store_true", help="reuse outputs already in --outdir")
    ap.add_argument("--fine-sph", default=None, help="output of examples/buried_charge_sph_fine.yaml to read")
    ap.add_argument("--fine-sph-dob8", default=None, help="output of examples/buried_charge_sph_fine_dob8.yaml to read")
    ap.add_argument("--fine-tlpd", default=None, help="output of examples/buried_charge_fine.yaml to read")
    ap.add_argument("--fine-tlpd-dob8", default=None, help="output of examples/buried_charge_fine_dob8.yaml to read")
    ap.add_argument("--prior-csv", default=None,
                    help="take the fine curves not given nor run from this earlier CSV of fine.py")
    ap.add_argument("--png", default=os.path.join(HERE, "buried_charge_fine.png"))
    ap.add_argument("--csv", default=os.path.join(HERE, "buried_charge_fine.csv"))
    ap.add_argument("--full", action="store_true",
                    help="run the fine scenes not given (on 2 cores: SPH soil about 40 and 80 min, tlpd at most 138 and 116 min)")
    a = ap.parse_args()
    prior = prior_curves(a.prior_csv) if a.prior_csv else {}
    if not a.full and not (a.fine_sph or a.fine_sph_dob8 or a.fine_tlpd or a.fine_tlpd_dob8):
        print("buried_charge/fine.py: the fine scenes need --full (make validate); skipped")
        return 0
    os.makedirs(a.outdir, exist_ok=True)
    exe = os.path.join(a.build, "bin", "ejecta")

    runs = []  # (label, path, perf, style)
    for label, scene, style in (("tlpd, coarse (6 mm)", "buried_charge.yaml", "C0--"),
                                ("SPH soil, coarse (6 mm)", "buried_charge_sph.yaml", "C1--"),
                                ("tlpd, coarse (6 mm), DOB 8 cm", "buried_charge_dob8.yaml", "C0--")):
        p, perf = ensure(exe, scene, os.path.join(a.outdir, scene[:-5] + ".h5"), a.threads, a.reuse)
        runs.append((label, p, perf, style))
    for label, scene, given, style in (("SPH soil, fine (4 mm)", "buried_charge_sph_fine.yaml", a.fine_sph, "C1-"),
                                       ("SPH soil, fine (4 mm), DOB 8 cm", "buried_charge_sph_fine_dob8.yaml",
                                        a.fine_sph_dob8, "C1-"),
                                       ("tlpd, fine (3.75 mm)", "buried_charge_fine.yaml", a.fine_tlpd, "C0-"),
                                       ("tlpd, fine (4 mm), DOB 8 cm", "buried_charge_fine_dob8.yaml",
                                        a.fine_tlpd_dob8, "C0-")):
        if given:
            runs.append((label, given, None, style))
        elif label in prior:
            runs.append((label, None, None, style))
        elif a.full:
            p, perf = ensure(exe, scene, os.path.join(a.outdir, scene[:-5] + ".h5"), a.threads, a.reuse)
            runs.append((label, p, perf, style))
    # fine curves of the earlier CSV that no scene of today makes (the DOB 3 cm tlpd scene before the
    # README's ninth pass, 4 / 8 mm, lattices off): drawn dotted for comparison, and kept in the CSV
    known = {r[0] for r in runs}
    for label in list(prior):
        if "fine" in label and label not in known:
            runs.append((label if "earlier" in label else label + ", earlier scene", None, None,
                         "C1:" if label.startswith("SPH") else "C0:"))
            prior[runs[-1][0]] = prior[label]

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(2, 2, figsize=(12, 8.4))
    table = []
    fine_end = []
    for label, path, perf, style in runs:
        if path is None:
            rows = prior[label]
            print(f"{label}: the curve of {a.prior_csv} (an earlier run, not read again)")
        else:
            rows, n, steps, bal = curve_chain(path)
        if "fine" in label and "earlier" not in label:
            fine_end.append((label, rows[-1, 0]))
        ax = axs[1 if "DOB 8 cm" in label else 0]
        ax[0].plot(rows[:, 0], rows[:, 1], style, marker="o", ms=3, label=f"{label}: all soil")
        ax[0].plot(rows[:, 0], rows[:, 3], style, marker="x", ms=4, alpha=0.6, label=f"{label}: coherent dome")
        if np.isfinite(rows[:, 6]).any():  # not in the CSVs written before the ninth pass
            ax[0].plot(rows[:, 0], rows[:, 6], style.rstrip("-:") + ":", marker="+", ms=4, alpha=0.8,
                       label=f"{label}: 90 % front within 30 mm")
        ax[1].plot(rows[:, 0], rows[:, 2], style, marker="o", ms=3, label=f"{label}: all soil")
        ax[1].plot(rows[:, 0], rows[:, 4], style, marker="x", ms=4, alpha=0.6, label=f"{label}: coherent dome")
        if path is not None:
            ntot = sum(n.values())
            print(f"{label}: {path}\n  {ntot} particles, {steps} steps to {rows[-1, 0]:.3f} ms, "
                  f"max |balance| / E0 {bal:.2e}")
        if perf:
            rate = ntot * steps / perf["cpu"] if perf["cpu"] > 0 else float("nan")
            print(f"  wall {perf['wall']:.0f} s, CPU {perf['cpu']:.0f} s ({a.threads} threads): "
                  f"{rate:.3g} particle-steps per CPU-second (set-up included), max RSS {perf['maxrss_mb']:.0f} MB"
                  + (f"; STOPPED: {perf['crash']}" if perf["crash"] else ""))
        print("   t [ms]  height  width  coherent height, width  within 30 mm of the axis: highest, 90 % front [mm]")
        for r in rows:
            print(f"  {r[0]:7.3f} {r[1]:7.1f} {r[2]:7.1f} {r[3]:7.1f} {r[4]:7.1f} {r[5]:7.1f} {r[6]:7.1f}")
            table.append((label, f"{r[0]:.4f}") + tuple(f"{v:.2f}" for v in r[1:7]))
    for ax, dob in zip(axs, ("3 cm", "8 cm")):
        ax[0].set_ylabel(f"DOB {dob}: bubble height above the surface (mm)")
        ax[1].set_ylabel(f"DOB {dob}: bubble width (mm)")
    check.finish_figure(fig, axs.ravel(), "Buried 100 g C4, DOB 3 cm (top) and 8 cm (bottom): fine and coarse "
                        "scenes (no measured reference available)", a.png)
    with open(a.csv, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(("run",) + COLS)
        w.writerows(table)
    print(f"wrote {a.png}, {a.csv}")
    short = [(lb, te) for lb, te in fine_end if te < 0.8 - 1e-6]
    for lb, te in short:
        print(f"{lb}: the run ends at {te:.3f} ms, before 0.8 ms")
    return 1 if short else 0


if __name__ == "__main__":
    sys.exit(main())
