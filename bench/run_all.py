#!/usr/bin/python3
"""Runs the benchmarks (SPH throughput, PySPH Sod comparison, SPH solid throughput, then TL-PD,
UL-PD and RKPM throughput and ejecta vs LAMMPS on its peridynamics examples), prints one summary
table and writes bench/results.md (numbers, date, machine, load average).

    /usr/bin/python3 bench/run_all.py --build build [--repeats 3] [--steps 40] [--profile] [--skip NAME ...]

The last four are separate scripts (each has its own README/docstring and options); run_all runs
them with their defaults (bench/lammps_peri without its 1M-particle part; it installs LAMMPS with
apt-get when `lmp` is missing), puts their verdict lines in the summary and their whole output in
results.md.

A report, not a test: the exit status is 0 whatever the numbers are (1 only if a benchmark
could not run at all). Wall times are the best of --repeats; other jobs on the machine slow
them down, so the load average is recorded with them.
"""
import argparse
import datetime
import os
import platform
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import pysph_sod  # noqa: E402
import sph_throughput as tp  # noqa: E402
import sph_solid_throughput as stp  # noqa: E402


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def verdict(ok):
    return "PASS" if ok else "FAIL"


def summary_rows(t, s, st=None):
    rows = []
    if t:
        for th in sorted(t["rate_core"]):
            rows.append((f"SPH throughput, {th} thread{'s' if th > 1 else ''}",
                         f"{t['rate_core'][th]:.3g} particle-steps/s/core", f">= {tp.TARGET_RATE:.0e}",
                         verdict(t["rate_core"][th] >= tp.TARGET_RATE)))
        if "speedup" in t:
            rows.append(("SPH speed-up 1 -> 2 threads", f"{t['speedup']:.2f}", f">= {tp.TARGET_SPEEDUP}",
                         verdict(t["speedup"] >= tp.TARGET_SPEEDUP)))
        rows.append(("SPH memory", f"{t['bytes_per_particle']:.0f} bytes/particle", f"<= {tp.TARGET_BYTES:.0f}",
                     verdict(t["bytes_per_particle"] <= tp.TARGET_BYTES)))
        rows.append(("SPH setup share (1 thread)", f"{100 * t['setup_fraction']:.0f} % of {t['steps']} steps", "", ""))
    if st:
        for th in sorted(st["rate_core"]):
            rows.append((f"SPH solid (DP) throughput, {th} thread{'s' if th > 1 else ''}",
                         f"{st['rate_core'][th]:.3g} particle-steps/s/core", f">= {stp.TARGET_RATE:.0e}",
                         verdict(st["rate_core"][th] >= stp.TARGET_RATE)))
        if "speedup" in st:
            rows.append(("SPH solid speed-up 1 -> 2 threads", f"{st['speedup']:.2f}", f">= {stp.TARGET_SPEEDUP}",
                         verdict(st["speedup"] >= stp.TARGET_SPEEDUP)))
    if s:
        p = s["pysph"]
        e = s["ejecta_same_n"]
        if "error" in p:
            rows.append(("PySPH Sod", "could not run", "", p["error"].splitlines()[0][:60]))
        else:
            rows.append(("Sod time ejecta/PySPH (same n)", f"{e['wall'] / p['run_time']:.3f}",
                         f"{e['wall']:.2f} s / {p['run_time']:.2f} s", ""))
            rows.append(("Sod L1(rho) ejecta/PySPH (same n)", f"{e['l1'] / p['l1']:.3f}",
                         f"{e['l1']:.5f} / {p['l1']:.5f}", ""))
    return rows


# The benchmarks that are whole scripts: name, command (after the interpreter), what it measures.
SCRIPTS = [
    ("tlpd_throughput", ["tlpd_throughput.py"], "TL-PD, 216,000-particle DP block, m = 3 (issue 4)"),
    ("ulpd_throughput", ["ulpd_throughput.py"], "UL-PD against SPH on the same gas box (issue 3)"),
    ("rkpm_throughput", ["rkpm_throughput.py"], "RKPM MSNNI, 195,112-node soil block, 003 Table 7 (issue 9)"),
    ("explosive_throughput", ["explosive_throughput.py"],
     "SPH kernel / shape tensor / UL-PD on a 97,336-particle C4 cube, plane burn; shape/kernel <= 1.5 (issue 3)"),
    ("lammps_peri", ["lammps_peri/run.py", "--no-big"], "ejecta vs LAMMPS peri/pmb and peri/lps (issue 5)"),
]


def run_script(name, cmd, build):
    """Runs one benchmark script; returns (verdict lines, whole output)."""
    args = [sys.executable, os.path.join(HERE, cmd[0])] + cmd[1:]
    args += ["--ejecta", os.path.abspath(os.path.join(build, "bin", "ejecta"))] if name == "lammps_peri" else ["--build", build]
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=os.path.dirname(HERE))
    out = p.stdout
    if p.returncode != 0:
        raise RuntimeError(f"exit {p.returncode}: {out[-2000:]}")
    lines, part = [], ""
    for ln in out.splitlines():
        if ln.startswith("== "):  # a part of the script's report (lammps_peri: == PMB, == LPS)
            part = ln[3:].split(":")[0].strip() + ": "
        elif "PASS" in ln or "FAIL" in ln or "ratio" in ln:
            lines.append(part + ln.strip())
    return lines, out


def busy(info):
    """True when other jobs were running: OpenMP barriers then stall and timings mislead."""
    try:
        return float(info["load_before"].split()[0]) > 0.5
    except (ValueError, IndexError):
        return False


def markdown(t, s, info, st=None):
    L = ["# ejecta benchmarks", "",
         "Generated by `make bench` (`bench/run_all.py`); a report, not a test. Wall times are the best",
         f"of {info['repeats']} runs; other jobs on the machine slow them down (load average below).", "",
         f"- date: {info['date']}",
         f"- machine: {info['cpu']}, nproc {info['nproc']}, {info['system']}",
         f"- build: `{info['build']}`",
         f"- load average (1, 5, 15 min): before {info['load_before']}, after {info['load_after']}", "",
         ] + ([f"**Warning: the machine was busy (1-min load {info['load_before'].split()[0]} before the runs on "
               f"{info['nproc']} cores); multi-thread timings in particular are not meaningful. Re-run on an idle "
               "machine.**", ""] if busy(info) else []) + [
         "## Summary", "", "| benchmark | result | target / detail | verdict |", "|---|---|---|---|"]
    for r in summary_rows(t, s, st):
        L.append("| " + " | ".join(r) + " |")
    if t:
        L += ["", "## SPH throughput (`bench/sph_throughput.py`)", "",
              f"Ideal gas in the periodic unit cube, {t['n_side']}^3 = {t['n']} particles (cubic lattice, jitter "
              f"{t['jitter']:g} spacing, h_factor {t['h_factor']:g}), pressure bump 1.1 in r < 0.15, default SPH "
              f"parameters, {t['steps']} steps. Neighbours inside 2h: mean {t['nbr_inside']:.1f} (min {t['nbr_min']}, "
              f"max {t['nbr_max']}); Verlet-list entries visited per particle: {t['nbr_listed']:.1f}; "
              f"{t['n_rebuilds']} neighbour rebuilds. Step rate = n (N - 1) / (T(N) - T(1)).", "",
              "| threads | T(1 step) [s] | T(N steps) [s] | particle-steps/s | per core |", "|---|---|---|---|---|"]
        for th in sorted(t["rate"]):
            L.append(f"| {th} | {t['t1'][th]:.2f} | {t['tN'][th]:.2f} | {t['rate'][th]:.3g} | {t['rate_core'][th]:.3g} |")
        th0 = sorted(t["rss"])[0]
        L += ["", f"Speed-up 1 -> 2 threads: {t.get('speedup', float('nan')):.2f}. Peak RSS "
              f"{t['rss'][th0] / 2**20:.1f} MiB, tiny run {t['rss_tiny'] / 2**20:.1f} MiB: "
              f"{t['bytes_per_particle']:.0f} bytes/particle (ghost images included)."]
        if t.get("profile"):
            L += ["", "perf profile of a 1-thread run (self time):", "", "```", t["profile"], "```"]
    if st:
        L += ["", "## SPH solid mechanics throughput (`bench/sph_solid_throughput.py`)", "",
              f"Sand block {st['n_side']}^3 = {st['n']} particles (drucker_prager, strength: true, defaults), falling "
              f"at 2 m/s onto a symmetry floor, {st['steps']} steps. Rate = n (N - 1) / (T(N) - T(1)); 1 thread from CPU "
              f"time: {st['rate_cpu_1']:.3g} particle-steps/s.", "",
              "| threads | T(1 step) [s] | T(N steps) [s] | particle-steps/s | per core |", "|---|---|---|---|---|"]
        for th in sorted(st["rate"]):
            L.append(f"| {th} | {st['t1'][th]:.2f} | {st['tN'][th]:.2f} | {st['rate'][th]:.3g} | {st['rate_core'][th]:.3g} |")
    if s:
        p = s["pysph"]
        L += ["", "## Sod shock tube vs PySPH (`bench/pysph_sod.py`)", "",
              "PySPH's `examples/gas_dynamics/sod_shocktube.py` at its defaults (ADKE, 720 equal-mass particles, "
              "dt 1e-4, PEC: two force evaluations per step) against ejecta's validation Sod scene "
              "(one spacing, smoothed jump), both one thread, t = 0.15 s. L1(rho) over |x| <= 0.4, "
              "volume-weighted, against the exact solution. PySPH time: solver only (\"Run took\"); ejecta: process "
              "wall.", ""]
        if "error" in p:
            L += [f"PySPH could not run: `{p['error']}`", ""]
        L += ["| code | particles | steps | wall [s] | L1(rho) | time ratio | L1 ratio |", "|---|---|---|---|---|---|---|"]
        if "error" not in p:
            L.append(f"| PySPH {p['version']} (ADKE) | {p['n']} | {p['steps']} | {p['run_time']:.2f} "
                     f"(process {p['wall']:.2f}) | {p['l1']:.5f} | | |")
        for key, label in (("ejecta_same_n", "ejecta, same count"), ("ejecta_same_dxl", "ejecta, PySPH left dx")):
            e = s[key]
            tr = lr = ""
            if "error" not in p:
                tr, lr = f"{e['wall'] / p['run_time']:.3f}", f"{e['l1'] / p['l1']:.3f}"
            L.append(f"| {label} | {e['n']} | {e['steps']} | {e['wall']:.2f} | {e['l1']:.5f} | {tr} | {lr} |")
    return "\n".join(L) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--n-side", type=int, default=46)
    ap.add_argument("--profile", action="store_true", help="perf profile of the throughput run")
    ap.add_argument("--results", default=os.path.join(HERE, "results.md"))
    ap.add_argument("--skip", nargs="*", default=[], choices=[n for n, _, _ in SCRIPTS],
                    help="leave out these script benchmarks")
    args = ap.parse_args()
    info = {"date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"), "cpu": cpu_model(),
            "nproc": os.cpu_count(), "system": f"{platform.system()} {platform.release()}",
            "build": args.build, "repeats": args.repeats, "load_before": tp.loadavg()}
    failed = 0
    t = s = None
    try:
        print("=== sph_throughput", flush=True)
        t = tp.measure(args.build, args.n_side, args.steps, args.repeats, profile=args.profile)
    except Exception as e:  # noqa: BLE001 (keep going: the other benchmark still reports)
        print(f"sph_throughput failed: {type(e).__name__}: {e}")
        failed += 1
    try:
        print("\n=== pysph_sod", flush=True)
        s = pysph_sod.measure(args.build, args.repeats)
    except Exception as e:  # noqa: BLE001
        print(f"pysph_sod failed: {type(e).__name__}: {e}")
        failed += 1
    st = None
    try:
        print("\n=== sph_solid_throughput", flush=True)
        st = stp.measure(args.build, repeats=args.repeats)
    except Exception as e:  # noqa: BLE001
        print(f"sph_solid_throughput failed: {type(e).__name__}: {e}")
        failed += 1
    scripts = {}
    for name, cmd, what in SCRIPTS:
        if name in args.skip:
            continue
        try:
            print(f"\n=== {name}", flush=True)
            lines, out = run_script(name, cmd, args.build)
            print(out, end="", flush=True)
            scripts[name] = (what, lines, out)
        except Exception as e:  # noqa: BLE001
            print(f"{name} failed: {type(e).__name__}: {e}")
            scripts[name] = (what, [f"could not run: {type(e).__name__}"], str(e))
            failed += 1
    info["load_after"] = tp.loadavg()

    print(f"\n=== benchmark summary ({info['cpu']}, nproc {info['nproc']}, load {info['load_before']} -> "
          f"{info['load_after']})")
    for r in summary_rows(t, s, st):
        print(f"  {r[0]:<36} {r[1]:<30} {r[2]:<26} {r[3]}")
    if busy(info):
        print(f"  WARNING: 1-min load {info['load_before'].split()[0]} before the runs: other jobs were running; "
              "the 2-thread numbers especially are not meaningful")
    for name, (what, lines, _) in scripts.items():
        for ln in lines:
            print(f"  {name}: {ln}")
    text = markdown(t, s, info, st)
    for name, (what, lines, out) in scripts.items():
        text += f"\n## {what} (`bench/{dict((n, c[0]) for n, c, _ in SCRIPTS)[name]}`)\n\n"
        text += "Verdict and ratio lines:\n\n" + "".join(f"- {ln}\n" for ln in lines)
        if out:
            text += "\nWhole output:\n\n```\n" + out.rstrip() + "\n```\n"
    with open(args.results, "w") as f:
        f.write(text)
    print(f"  wrote {os.path.relpath(args.results)}")
    return 1 if failed == 3 + len(SCRIPTS) else 0


if __name__ == "__main__":
    sys.exit(main())
