#!/usr/bin/env python3
"""Render the last frame (or any frame) of an ejecta output, coloured by a field, to a PNG.

Opens the XDMF sidecar that every run writes beside its HDF5 file (NAME.xdmf), as ParaView
does. Run it with ParaView's Python to render through ParaView (Debian: apt-get install paraview
python3-paraview; on a machine without a display, under Xvfb with a 24-bit screen: apt-get install
xvfb xauth):

  pvpython tools/render.py out/sedov_3d.xdmf --field rho -o sedov.png
  xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvpython tools/render.py out/sedov_3d.xdmf -o sedov.png

Without ParaView, /usr/bin/python3 (h5py + matplotlib) follows the same XDMF references and
draws the particles with matplotlib (1D: field against x; 2D: x-y scatter; 3D: 3D scatter):

  /usr/bin/python3 tools/render.py out/sod_1d.xdmf --field p

Checks for tests and scripts: --expect-points N and --expect-range LO HI (relative tolerance
--rtol) make it exit 1 when the frame's point count or the field's range differ. It prints
"render: BACKEND: N points, FIELD range [lo, hi], t = T s, wrote PNG".
"""
import argparse
import os
import sys
import xml.etree.ElementTree as ET

try:  # ParaView when run by pvpython
    from paraview import simple as pv  # noqa: F401
    HAVE_PARAVIEW = True
except ImportError:
    HAVE_PARAVIEW = False


def parse_args(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("xdmf", help="the run's XDMF sidecar (NAME.xdmf)")
    ap.add_argument("--field", default="rho", help="point field to colour by (default rho)")
    ap.add_argument("--component", type=int, default=-1,
                    help="component of a vector/tensor field (default -1: magnitude)")
    ap.add_argument("--frame", type=int, default=-1, help="frame index (default -1: the last)")
    ap.add_argument("-o", "--output", help="PNG (default: NAME_<field>.png beside the XDMF)")
    ap.add_argument("--size", type=int, nargs=2, default=[1024, 768], metavar=("W", "H"), help="image size")
    ap.add_argument("--point-size", type=float, default=4, help="point size in pixels")
    ap.add_argument("--expect-points", type=int, help="exit 1 unless the frame has this many points")
    ap.add_argument("--expect-range", type=float, nargs=2, metavar=("LO", "HI"),
                    help="exit 1 unless the field's range is [LO, HI] within --rtol")
    ap.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance of --expect-range")
    ap.add_argument("--backend", choices=["auto", "paraview", "matplotlib"], default="auto")
    return ap.parse_args(argv)


def render_paraview(a, out):
    """Through ParaView: XDMF 3 reader, merged blocks, points coloured by the field."""
    from paraview import simple as pv
    reader = pv.Xdmf3ReaderS(registrationName="ejecta", FileName=[os.path.abspath(a.xdmf)])
    reader.UpdatePipelineInformation()
    times = list(reader.TimestepValues) if hasattr(reader.TimestepValues, "__len__") else [reader.TimestepValues]
    t = times[a.frame] if times else 0.0
    merged = pv.MergeBlocks(Input=reader)
    merged.UpdatePipeline(t)
    info = merged.GetDataInformation()
    npts = info.GetNumberOfPoints()
    if info.GetNumberOfCells() != npts:  # a point without its vertex cell is not drawn
        sys.exit(f"render: the frame has {npts} points but {info.GetNumberOfCells()} vertex cells")
    arr = merged.PointData[a.field] if a.field in merged.PointData.keys() else None
    if arr is None:
        sys.exit(f"render: no point field '{a.field}' (fields: {', '.join(merged.PointData.keys())})")
    lo, hi = arr.GetRange(a.component)
    view = pv.CreateView("RenderView")
    view.ViewSize = a.size
    view.ViewTime = t
    view.OrientationAxesVisibility = 1
    disp = pv.Show(merged, view)
    disp.SetRepresentationType("Points")
    disp.PointSize = a.point_size
    pv.ColorBy(disp, ("POINTS", a.field) if a.component < 0 else ("POINTS", a.field, str(a.component)))
    disp.RescaleTransferFunctionToDataRange(True, False)
    disp.SetScalarBarVisibility(view, True)
    view.ResetCamera()
    pv.SaveScreenshot(out, view, ImageResolution=a.size)
    # Release the render window now: torn down at interpreter exit, Debian's ParaView 5.11 under
    # Xvfb raises GLXBadContext and the process would exit 1 after a successful render.
    pv.Delete(disp)
    pv.Delete(view)
    return npts, lo, hi, t


def _hdf_item(item, base):
    """numpy array of an XDMF DataItem 'file.h5:/path' (relative to the XDMF's directory)."""
    import h5py
    import numpy as np
    fname, path = item.text.strip().split(":", 1)
    with h5py.File(os.path.join(base, fname), "r") as f:
        return np.asarray(f[path][()])


def render_matplotlib(a, out):
    """Without ParaView: the same XDMF references read with h5py, drawn with matplotlib."""
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    base = os.path.dirname(os.path.abspath(a.xdmf))
    root = ET.parse(a.xdmf).getroot()
    temporal = root.find("Domain/Grid")
    frames = [g for g in temporal.findall("Grid")]
    if not frames:
        sys.exit("render: the XDMF file has no frames")
    frame = frames[a.frame]
    t = float(frame.find("Time").get("Value"))
    xs, vs = [], []
    for grid in frame.iter("Grid"):
        if grid.get("GridType") != "Uniform":
            continue
        n = int(grid.find("Topology").get("NumberOfElements"))
        x = _hdf_item(grid.find("Geometry/DataItem"), base).reshape(n, 3)
        attr = [at for at in grid.findall("Attribute") if at.get("Name") == a.field]
        if not attr:
            continue  # a set without this field
        v = _hdf_item(attr[0].find("DataItem"), base).astype(float).reshape(n, -1)
        v = np.linalg.norm(v, axis=1) if (a.component < 0 and v.shape[1] > 1) else v[:, max(a.component, 0)]
        xs.append(x)
        vs.append(v)
    if not xs:
        sys.exit(f"render: no set of frame {a.frame} has the field '{a.field}'")
    x, v = np.concatenate(xs), np.concatenate(vs)
    dim = 1 if np.all(x[:, 1:] == 0) else (2 if np.all(x[:, 2] == 0) else 3)
    fig = plt.figure(figsize=(a.size[0] / 100, a.size[1] / 100), dpi=100)
    if dim == 1:
        ax = fig.add_subplot(111)
        ax.plot(x[:, 0], v, "o", ms=a.point_size / 2)
        ax.set_xlabel("x [m]")
        ax.set_ylabel(a.field)
    else:
        ax = fig.add_subplot(111, projection="3d" if dim == 3 else None)
        pts = (x[:, 0], x[:, 1], x[:, 2]) if dim == 3 else (x[:, 0], x[:, 1])
        sc = ax.scatter(*pts, c=v, s=a.point_size ** 2 / 2, cmap="viridis")
        fig.colorbar(sc, ax=ax, label=a.field)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        if dim == 2:
            ax.set_aspect("equal")
    ax.set_title(f"{os.path.basename(a.xdmf)}: {a.field}, t = {t:.4g} s")
    fig.savefig(out)
    return len(x), float(np.min(v)), float(np.max(v)), t


def close(a, b, rtol):
    return abs(a - b) <= rtol * max(abs(a), abs(b)) + 1e-300


def main(argv=None):
    a = parse_args(argv)
    backend = a.backend
    if backend == "auto":
        backend = "paraview" if HAVE_PARAVIEW else "matplotlib"
    if backend == "paraview" and not HAVE_PARAVIEW:
        sys.exit("render: the paraview backend needs pvpython (ParaView's Python)")
    out = a.output or os.path.splitext(a.xdmf)[0] + f"_{a.field}.png"
    npts, lo, hi, t = (render_paraview if backend == "paraview" else render_matplotlib)(a, out)
    print(f"render: {backend}: {npts} points, {a.field} range [{lo:.17g}, {hi:.17g}], t = {t:.6g} s, wrote {out}")
    ok = True
    if a.expect_points is not None and npts != a.expect_points:
        print(f"render: expected {a.expect_points} points, got {npts}")
        ok = False
    if a.expect_range is not None and not (close(lo, a.expect_range[0], a.rtol) and close(hi, a.expect_range[1], a.rtol)):
        print(f"render: expected {a.field} range [{a.expect_range[0]:.17g}, {a.expect_range[1]:.17g}]")
        ok = False
    if not os.path.exists(out) or os.path.getsize(out) == 0:
        print(f"render: {out} was not written")
        ok = False
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
