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
CASES = ["sod", "sedov"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--full", action="store_true", help="full resolutions (make validate)")
    ap.add_argument("--threads", type=int, default=0, help="OpenMP threads per run (0: all cores)")
    ap.add_argument("cases", nargs="*", default=CASES)
    args = ap.parse_args()
    threads = args.threads or os.cpu_count() or 2
    results = []
    for case in args.cases:
        script = os.path.join(HERE, case, "check.py")
        cmd = [sys.executable, script, "--build", args.build, "--threads", str(threads)]
        if args.full:
            cmd.append("--full")
        print(f"=== {case}: {' '.join(cmd)}", flush=True)
        t0 = time.time()
        rc = subprocess.run(cmd).returncode
        results.append((case, rc, time.time() - t0))
        print(flush=True)
    print("=== validation summary")
    for case, rc, wall in results:
        print(f"  {case:<8} {'PASS' if rc == 0 else 'FAIL':<5} {wall:7.1f} s")
    failed = [c for c, rc, _ in results if rc != 0]
    print("all cases pass" if not failed else f"{len(failed)} case(s) failed: {', '.join(failed)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
