#!/usr/bin/python3
"""Load-independent estimate of the 2-thread speed-up of ejecta on the LAMMPS peri target.

/usr/bin/python3 bench/lammps_peri/thread_split.py [--ejecta build/bin/ejecta] [--model pmb|lps]
    [--steps 1000] [--schedule static|dynamic] [--top 0]

Runs ejecta with 2 threads under `valgrind --tool=callgrind --separate-threads=yes` twice (N steps and
1 step, the same scene as run.py), subtracts the 1-step run thread by thread (set-up and the first step
run on the main thread) and prints the instructions (Ir) each thread executed in the remaining N - 1
steps, and the estimate sum / max: the speed-up two equally fast, idle cores would reach if time were
proportional to instructions. With OMP_WAIT_POLICY=passive a waiting thread sleeps (no instructions), so
serial work (run by the main thread alone) and imbalance lower the estimate; cache traffic between
the cores, memory bandwidth and the cost of waking threads are NOT counted (callgrind runs one thread at
a time). Use `--schedule static` (OMP_SCHEDULE=static: each thread gets contiguous halves of the chunks,
deterministic, the code's own balance); with the core's default (dynamic, 1 chunk at a time) the split
under valgrind depends on valgrind's thread switching, not on the hardware. --top N also prints the N
largest functions with their count per thread. Valgrind 3.19 (Debian 12) cannot run AVX-512 code: on a CPU with AVX-512 build ejecta for this
script with `-DEJ_NATIVE=OFF` (x86-64-v2). The load on the machine does not enter the counts."""
import atexit
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections import defaultdict

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import make_target  # noqa: E402
from run import ejecta_scene  # noqa: E402


def arg(name, default):
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default


ROOT = os.path.dirname(os.path.dirname(HERE))
EJECTA = os.path.abspath(arg("--ejecta", os.path.join(ROOT, "build", "bin", "ejecta")))
MODEL = arg("--model", "pmb")
STEPS = int(arg("--steps", "1000"))
SCHED = arg("--schedule", "static")
TOP = int(arg("--top", "0"))


def callgrind(scene, wd, tag):
    env = dict(os.environ, OMP_NUM_THREADS="2", OMP_WAIT_POLICY="passive", OMP_SCHEDULE=SCHED)
    cmd = ["valgrind", "--tool=callgrind", "--separate-threads=yes", "--fair-sched=yes",
           f"--callgrind-out-file={os.path.join(wd, 'cg.' + tag + '.%p')}", EJECTA, "run", scene,
           "-o", os.path.join(wd, tag + ".h5"), "--threads", "2"]
    p = subprocess.run(cmd, cwd=wd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if p.returncode != 0:
        sys.exit(p.stdout[-3000:])
    total, funcs = {}, defaultdict(dict)
    for f in glob.glob(os.path.join(wd, f"cg.{tag}.*-*")):
        t = int(f.rsplit("-", 1)[1])
        for ln in open(f):
            if ln.startswith("summary:"):
                total[t] = int(ln.split()[1])
        if TOP:
            out = subprocess.run(["callgrind_annotate", "--threshold=100", f], stdout=subprocess.PIPE,
                                 stderr=subprocess.DEVNULL, text=True).stdout
            for ln in out.splitlines():
                m = re.match(r"\s*([\d,]+)\s+\(\s*[\d.]+%\)\s+(\S+)", ln)
                if m and "PROGRAM" not in ln:
                    funcs[m.group(2).split(":")[-1]][t] = int(m.group(1).replace(",", ""))
    return total, funcs


def main():
    wd = tempfile.mkdtemp(prefix="ej_thread_split_")
    atexit.register(shutil.rmtree, wd, ignore_errors=True)  # scratch: removed at exit
    csv = os.path.join(wd, "target.csv")
    make_target.write(csv, 1)
    sN = ejecta_scene(MODEL, wd, STEPS, csv)  # as run.py: v and damage frames every 1e-5 s
    s1 = ejecta_scene(MODEL, wd, 1, csv, every=0)
    tN, fN = callgrind(sN, wd, "n")
    t1, f1 = callgrind(s1, wd, "one")
    d = {t: tN[t] - t1.get(t, 0) for t in tN}
    tot, mx = sum(d.values()), max(d.values())
    print(f"{MODEL.upper()}, {STEPS} steps minus a 1-step run, 2 threads, OMP_SCHEDULE={SCHED}, "
          f"OMP_WAIT_POLICY=passive; {EJECTA}")
    for t in sorted(d):
        print(f"  thread {t}: {d[t] / 1e6:10.1f} M instructions ({d[t] / tot:.3f} of the sum)")
    print(f"  sum {tot / 1e6:.1f} M, busiest thread {mx / 1e6:.1f} M: estimated 2-thread speed-up "
          f"sum/max = {tot / mx:.3f}  [{'PASS' if tot / mx >= 1.8 else 'FAIL'} >= 1.8, instruction counts only]")
    if TOP:
        rows = []
        for fn, v in fN.items():
            per = {t: v.get(t, 0) - f1.get(fn, {}).get(t, 0) for t in d}
            rows.append((sum(per.values()), fn, per))
        rows.sort(reverse=True)
        print("  largest functions, M instructions per thread:")
        for s, fn, per in rows[:TOP]:
            print("   " + " ".join(f"{per[t] / 1e6:9.1f}" for t in sorted(d)) + f"  {fn}")


if __name__ == "__main__":
    main()
