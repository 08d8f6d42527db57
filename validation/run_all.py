#!/usr/bin/python3
"""Runs every validation case (validation/<case>/check.py) and prints a summary.

    /usr/bin/python3 validation/run_all.py --build build [--full]

Exit status: 0 if every case passes, 1 otherwise. Each case prints its reference, tolerance,
measured numbers and PASS/FAIL, and writes its figures next to its check.py.
"""
import argparse
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
# every validation/<case>/check.py (and the named extra scripts), in a stable order
EXTRA = {"ulpd": ["check_sod.py", "check_sedov.py", "check_c4_rod.py"], "material_points": ["run.py"],
         "buried_charge": ["fine.py"]}


def discover():
    cases = []
    for d in sorted(os.listdir(HERE)):
        if os.path.isfile(os.path.join(HERE, d, "check.py")):
            cases.append((d, "check.py"))
        for extra in EXTRA.get(d, []):
            cases.append((d, extra))
    return cases


def accepts(script, option):
    """Whether a case script takes an option (they do not all take --threads or --full)."""
    r = subprocess.run([sys.executable, script, "--help"], capture_output=True, text=True)
    return option in r.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--full", action="store_true", help="full resolutions (make validate)")
    ap.add_argument("--threads", type=int, default=0, help="OpenMP threads per run (0: all cores)")
    ap.add_argument("cases", nargs="*", help="case folders (default: all)")
    args = ap.parse_args()
    threads = args.threads or os.cpu_count() or 2
    results = []
    for case, name in discover():
        if args.cases and case not in args.cases:
            continue
        script = os.path.join(HERE, case, name)
        cmd = [sys.executable, script]
        if accepts(script, "--build"):
            cmd += ["--build", args.build]
        if accepts(script, "--threads"):
            cmd += ["--threads", str(threads)]
        if args.full and accepts(script, "--full"):
            cmd.append("--full")
        case = case if name == "check.py" else f"{case}/{name}"
        print(f"=== {case}: {' '.join(cmd)}", flush=True)
        t0 = time.time()
        rc = subprocess.run(cmd).returncode
        results.append((case, rc, time.time() - t0))
        print(flush=True)
    print("=== validation summary")
    for case, rc, wall in results:
        print(f"  {case:<28} {'PASS' if rc == 0 else 'FAIL':<5} {wall:7.1f} s")
    failed = [c for c, rc, _ in results if rc != 0]
    print("all cases pass" if not failed else f"{len(failed)} case(s) failed: {', '.join(failed)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
