#!/usr/bin/python3
"""Plot time series of an ejecta output file (HDF5) to a PNG.

Every run writes /series/energy/<column> (t, step, dt, kinetic, internal, viscous, plastic,
hourglass, external, balance, momentum_x|y|z), each plugin's per-step series as
/series/<set or interaction>/<name>, the scene's probes as /series/probe/<name>/<column> and, with
output.set_series, /series/set/<set>/<column>. This tool plots any of them against time (or step).

Examples:
  tools/plot_series.py out/sedov_3d.h5                       # energy budget -> out/sedov_3d_energy.png
  tools/plot_series.py out/run.h5 --preset momentum -o mom.png
  tools/plot_series.py out/run.h5 energy/dt --log -o dt.png  # any series by owner/name
  tools/plot_series.py out/run.h5 plate/mean_damage indenter/force --x step
  tools/plot_series.py out/run.h5 probe/z1/p probe/z2/p         # the scene's probes (gauges, tracers)
  tools/plot_series.py out/run.h5 set/soil/kinetic set/charge/kinetic   # output.set_series
  tools/plot_series.py out/run.h5 --list                     # what the file holds

Works on a failed run's NAME.h5.partial as well (series up to the last checkpoint or failure).
Needs /usr/bin/python3 with h5py, numpy and matplotlib.
"""
import argparse
import os
import sys

import h5py
import numpy as np

PRESETS = {
    "energy": ["energy/kinetic", "energy/internal", "energy/viscous", "energy/plastic", "energy/hourglass",
               "energy/external", "energy/balance"],
    "momentum": ["energy/momentum_x", "energy/momentum_y", "energy/momentum_z"],
    "dt": ["energy/dt"],
}
UNITS = {"kinetic": "J", "internal": "J", "viscous": "J", "plastic": "J", "hourglass": "J", "external": "J",
         "balance": "J", "momentum_x": "kg m/s", "momentum_y": "kg m/s", "momentum_z": "kg m/s", "dt": "s", "t": "s"}


def list_series(f):
    """owner/name of every 1-D dataset under /series (owner may be nested: probe/<name>, set/<set>)."""
    out = []
    if "series" not in f:
        return out

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.ndim == 1 and "/" in name:
            out.append(name)

    f["series"].visititems(visit)
    return sorted(out)


def time_axis(f, owner, kind):
    """The time (or step) column that goes with /series/<owner>: its own t/step, else energy's."""
    for grp in (f["series"].get(owner), f["series"].get("energy")):
        if grp is not None and kind in grp:
            return np.asarray(grp[kind][:], dtype=float)
    sys.exit(f"plot_series: no '{kind}' column for series owner '{owner}'")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file", help="ejecta output (.h5 or .h5.partial)")
    ap.add_argument("series", nargs="*", help="series as OWNER/NAME (e.g. energy/kinetic, plate/mean_damage); "
                    "a bare NAME is looked up under every owner")
    ap.add_argument("--preset", choices=sorted(PRESETS), help="a predefined group (default: energy when no series "
                    "is named)")
    ap.add_argument("-o", "--output", help="PNG to write (default: FILE stem + _<preset or series>.png)")
    ap.add_argument("--x", choices=["t", "step"], default="t", help="abscissa: time (default) or step")
    ap.add_argument("--log", action="store_true", help="logarithmic y axis (absolute values)")
    ap.add_argument("--title", help="plot title (default: the file name)")
    ap.add_argument("--list", action="store_true", help="list the series in the file and exit")
    ap.add_argument("--csv", help="also write the plotted columns to this CSV file")
    a = ap.parse_args(argv)

    with h5py.File(a.file, "r") as f:
        avail = list_series(f)
        if a.list:
            print("\n".join(avail))
            return 0
        wanted = list(a.series)
        if a.preset or not wanted:
            wanted += PRESETS[a.preset or "energy"]
        names = []
        for w in wanted:
            if w in avail:
                names.append(w)
                continue
            hits = [s for s in avail if s.rsplit("/", 1)[1] == w]
            if not hits:
                sys.exit(f"plot_series: no series '{w}' in {a.file} (--list shows them)")
            names += hits
        names = [n for n in names if n.rsplit("/", 1)[1] not in ("t", "step")]
        if not names:
            sys.exit("plot_series: nothing to plot")

        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 5))
        columns = {}
        for n in names:
            owner, name = n.rsplit("/", 1)
            y = np.asarray(f["series"][owner][name][:], dtype=float)
            x = time_axis(f, owner, a.x)
            m = min(len(x), len(y))
            x, y = x[:m], y[:m]
            unit = UNITS.get(name, f["series"][owner][name].attrs.get("unit", ""))
            if isinstance(unit, bytes):
                unit = unit.decode()
            label = n + (f" [{unit}]" if unit else "")
            ax.plot(x, np.abs(y) if a.log else y, label=label)
            columns[n] = (x, y)
        if a.log:
            ax.set_yscale("log")
        ax.set_xlabel("time [s]" if a.x == "t" else "step")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
        ax.set_title(a.title or os.path.basename(a.file))
        stem = a.file[:-len(".partial")] if a.file.endswith(".partial") else a.file
        stem = os.path.splitext(stem)[0]
        tag = a.preset or ("energy" if not a.series else names[0].replace("/", "_"))
        out = a.output or f"{stem}_{tag}.png"
        fig.tight_layout()
        fig.savefig(out, dpi=120)
        print(f"plot_series: wrote {out} ({len(names)} series, {len(next(iter(columns.values()))[0])} rows)")
        if a.csv:
            with open(a.csv, "w") as fo:
                fo.write(",".join(["series", a.x, "value"]) + "\n")
                for n, (x, y) in columns.items():
                    for xi, yi in zip(x, y):
                        fo.write(f"{n},{xi:.17g},{yi:.17g}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
