#!/usr/bin/python3
"""Where does the SPH air hold its energy? Split of the air's energy (kinetic / internal) into the
contact layer (the innermost air mass of `--layer` SPH particles, the same mass in FD) and the
shocked shell beyond it, with the shock's position, peak and 10-90 % rise width (in mm and in air
particles), SPH frame against the lagrange1d.py profile at the same time.

    /usr/bin/python3 validation/charge_in_air/diag_shell.py SPH.h5 FD.npz [--nc-fd 80] [--layer 3]

FD.npz: lagrange1d.py --nc 80 --dr-air 2.5e-3 --grade 1000 --save (zone masses rebuilt from its mesh).
"""
import argparse
import math
import os
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lagrange1d as L  # noqa: E402

P0 = 101325.0
G = 1.4


def sph_air(h5, t):
    with h5py.File(h5, "r") as f:
        cp = f["checkpoint"]["air"]
        mass = dict(zip(cp["id"][()].tolist(), cp["m"][()].tolist()))
        names = sorted(f["frames"].keys())
        ts = np.array([float(f["frames"][n].attrs["time"]) for n in names])
        k = int(np.argmin(np.abs(ts - t)))
        g = f["frames"][names[k]]
        x = g["air"]["x"][()][:, 0]
        o = np.argsort(x)
        m = np.array([mass[i] for i in g["air"]["id"][()].tolist()])[o]
        xc = float(g["charge"]["x"][()][:, 0].max())
        return dict(r=x[o], p=g["air"]["p"][()][o], rho=g["air"]["rho"][()][o], u=g["air"]["v"][()][o, 0], m=m,
                    rc=xc, t=ts[k])


def fd_air(npz, k, nc, dr_air, grade, r_out=7.0):
    d = np.load(npz)
    _, _, r = L.mesh(nc, dr_air, r_out, grade)
    vol = 4 * math.pi / 3 * (r[1:] ** 3 - r[:-1] ** 3)
    ch = d[f"prof{k}_charge"].astype(bool)
    rho0 = np.where(ch, L.JWL["rho0"], L.RHO_AIR)
    m = (rho0 * vol)[~ch]
    rr = d[f"prof{k}_r"]
    return dict(r=rr[~ch], p=d[f"prof{k}_p"][~ch], rho=d[f"prof{k}_rho"][~ch], u=d[f"prof{k}_u"][~ch], m=m,
                rc=float(rr[ch].max()), t=float(d[f"prof{k}_t"]))


def analyse(a, mlayer):
    """Energies (relative to ambient) of layer (innermost air mass mlayer) and shell; shock front."""
    ek = 0.5 * a["m"] * a["u"] ** 2
    ei = a["m"] * (a["p"] / ((G - 1) * a["rho"]) - P0 / ((G - 1) * L.RHO_AIR))
    cm = np.cumsum(a["m"])
    lay = cm <= mlayer * (1 + 1e-9)
    po = a["p"] - P0
    # shock: largest overpressure more than 3 cm outside the contact
    far = a["r"] > a["rc"] + 0.03
    j = int(np.argmax(np.where(far, po, -np.inf)))
    pk = po[j]
    # front side: first index beyond j where po < 10 % / 50 % / 90 % of the peak
    def cross(frac):
        i = j
        while i + 1 < len(po) and po[i + 1] > frac * pk:
            i += 1
        # linear between i and i+1
        if i + 1 >= len(po):
            return a["r"][i], i
        f = (po[i] - frac * pk) / (po[i] - po[i + 1])
        return a["r"][i] + f * (a["r"][i + 1] - a["r"][i]), i
    r90, i90 = cross(0.9)
    r50, _ = cross(0.5)
    r10, i10 = cross(0.1)
    shell = (~lay) & (a["r"] <= r10)
    return dict(t=a["t"], rc=a["rc"], rlay=float(a["r"][lay].max()) if lay.any() else float("nan"),
                nlay=int(lay.sum()), Ek_lay=ek[lay].sum(), Ei_lay=ei[lay].sum(), Ek_sh=ek[shell].sum(),
                Ei_sh=ei[shell].sum(), E_tot=(ek + ei).sum(), rpk=a["r"][j], pk=pk, r50=r50,
                w1090=r10 - r90, npart=i10 - i90, dxloc=float(np.median(np.diff(a["r"][max(j - 5, 0):j + 6]))),
                p_lay=float(np.median(a["p"][lay])), rho_lay=float(np.median(a["rho"][lay])))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sph")
    ap.add_argument("fd")
    ap.add_argument("--nc-fd", type=int, default=80)
    ap.add_argument("--dr-air", type=float, default=2.5e-3)
    ap.add_argument("--grade", type=float, default=1000)
    ap.add_argument("--layer", type=int, default=3, help="contact layer = mass of this many innermost SPH air particles")
    ap.add_argument("--times", default="0.3e-3,0.6e-3,1.2e-3")
    a = ap.parse_args(argv)
    d = np.load(a.fd)
    fts = []
    i = 0
    while f"prof{i}_t" in d:
        fts.append(float(d[f"prof{i}_t"]))
        i += 1
    for t in [float(s) for s in a.times.split(",")]:
        k = int(np.argmin(np.abs(np.array(fts) - t)))
        s = sph_air(a.sph, fts[k])
        ml = float(np.sum(s["m"][:a.layer]))
        f = fd_air(a.fd, k, a.nc_fd, a.dr_air, a.grade)
        print(f"t = {1e3 * fts[k]:.3f} ms (SPH frame {1e3 * s['t']:.3f} ms); layer = innermost {1e3 * ml:.3f} g of air")
        print("        contact  layer-out  E_lay kin / int [MJ]  E_shell kin / int [MJ]  E_air [MJ]  p_lay [kPa] rho_lay"
              "  shock r50 [m]  peak dp [kPa]  10-90 % width [mm] (particles/zones, local dx mm)")
        for lab, x in (("SPH", s), ("FD ", f)):
            r = analyse(x, ml)
            print(f"  {lab}  {r['rc']:.4f}   {r['rlay']:.4f}     {r['Ek_lay'] / 1e6:.4f} / {r['Ei_lay'] / 1e6:.4f}"
                  f"        {r['Ek_sh'] / 1e6:.4f} / {r['Ei_sh'] / 1e6:.4f}        {r['E_tot'] / 1e6:.4f}"
                  f"    {r['p_lay'] / 1e3:8.1f}  {r['rho_lay']:.3f}    {r['r50']:.4f}      {r['pk'] / 1e3:8.1f}"
                  f"       {1e3 * r['w1090']:.2f} ({r['npart']}, {1e3 * r['dxloc']:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
