"""Acceptance evidence for resumable sweeps (issue 4): kill -9, Ctrl-C, restart, Dask.

    python benchmarks/sweep_kill.py [--out DIR] [--hmax 0.15] [--workers 2] [--dask]

Runs ``python -m skfem_sheet sweep`` on a grid of 24 coarse sheets (L/a 0.3, 0.4,
0.5; b/a 1, 0; a/R 0, 2.5; both load paths) and

1. kills the sweep process with ``kill -9`` (the parent only, as a user would)
   once about a third of the points are in the journal, and checks that its
   worker processes exit on their own (they stop after their current point);
2. restarts it, and interrupts it with SIGINT (Ctrl-C) a few points later: the
   sweep must exit with code 130 after writing a table of every finished point;
3. restarts it again, to the end, and checks that every point is in the journal
   and in the table exactly once, that lines written before each interruption
   are unchanged (finished points are never recomputed), and that a fourth run
   computes nothing;
4. with ``--dask``: runs the same grid on ``distributed.LocalCluster(n_workers=2,
   processes=True)`` and compares the table with the process-pool one.

Prints the evidence and exits with 1 if a check fails.  Run it with nothing else
running if you want the wall times to mean anything.
"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

from harness import parser

GRID = ["--lengths", "0.3:0.5:0.1", "--tip-widths", "1,0", "--curvatures", "0,2.5",
        "--paths", "both"]
FAILED = []


def check(ok, what):
    print(f"  [{'ok' if ok else 'FAILED'}] {what}")
    if not ok:
        FAILED.append(what)


def valid_records(path):
    """Complete JSON lines of a journal file (bytes are read as a file name's content)."""
    data = path if isinstance(path, bytes) else (
        read(path) if os.path.exists(path) else b"")
    out = []
    for line in data.split(b"\n"):
        try:
            rec = json.loads(line)
        except (ValueError, UnicodeDecodeError):
            continue
        if isinstance(rec, dict) and "key" in rec:
            out.append(rec)
    return out


def read(path):
    with open(path, "rb") as fh:
        return fh.read()


def group_pids(pgid):
    """Live processes of a process group (Linux /proc)."""
    pids = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            pids.append(int(d))
    return pids


def start(cmd):
    return subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def wait_lines(journal, n, proc, timeout=900):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout and proc.poll() is None:
        if len(valid_records(journal)) >= n:
            return True
        time.sleep(0.02)
    return False


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--out", default=None, help="folder for the tables (default: a temp dir)")
    ap.add_argument("--hmax", type=float, default=0.15)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--dask", action="store_true", help="also compare with a LocalCluster run")
    args = ap.parse_args(argv)
    out = args.out or tempfile.mkdtemp(prefix="sweep_kill_")
    os.makedirs(out, exist_ok=True)
    table = os.path.join(out, "pool.csv")
    journal = table + ".journal.jsonl"
    for f in (table, journal):
        if os.path.exists(f):
            os.remove(f)
    cmd = [sys.executable, "-m", "skfem_sheet", "sweep", *GRID, "--hmax", str(args.hmax),
           "--table", table, "--workers", str(args.workers), "--quiet"]
    n_points = 3 * 2 * 2 * 2
    print(f"sweep of {n_points} points, hmax={args.hmax}, {args.workers} workers:\n  "
          + " ".join(cmd[1:]))

    # 1. kill -9 of the sweep process
    print("\n1. kill -9 once a third of the points are finished")
    t0 = time.monotonic()
    p = start(cmd)
    reached = wait_lines(journal, n_points // 3, p)
    workers = [q for q in group_pids(p.pid) if q != p.pid]
    if p.poll() is None:
        os.kill(p.pid, signal.SIGKILL)
    t_kill = time.monotonic()
    p.wait()
    before1 = read(journal)
    n1 = len(valid_records(journal))
    print(f"  killed after {time.monotonic() - t0:.1f} s: exit code {p.returncode}, "
          f"{n1} points in the journal, worker processes {workers}")
    check(reached and p.returncode == -signal.SIGKILL and 0 < n1 < n_points,
          "the sweep was killed halfway")
    while group_pids(p.pid) and time.monotonic() - t_kill < 120:
        time.sleep(0.05)
    left = group_pids(p.pid)
    check(not left, f"orphaned workers stopped by themselves "
                    f"({time.monotonic() - t_kill:.1f} s after the kill)")
    if left:
        os.killpg(p.pid, signal.SIGKILL)
    p.communicate()

    # 2. restart, then Ctrl-C
    print("\n2. restart, then SIGINT (Ctrl-C) a few points later")
    p = start(cmd)
    reached = wait_lines(journal, n1 + 3, p)
    if p.poll() is None:
        os.killpg(p.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: the whole group
    _, err = p.communicate(timeout=120)
    before2 = read(journal)
    recs = valid_records(journal)
    import pandas as pd

    rows = pd.read_csv(table) if os.path.exists(table) else pd.DataFrame({"key": []})
    print(f"  exit code {p.returncode}; stderr: {err.strip()!r}")
    print(f"  {len(recs)} points in the journal, {len(rows)} rows in the table")
    check(reached and p.returncode == 130, "Ctrl-C stops the sweep with exit code 130")
    check(sorted(rows.key) == sorted(r["key"] for r in recs),
          "the table written on Ctrl-C holds exactly the finished points")
    check(before2.startswith(before1), "lines from before the kill are unchanged")
    time.sleep(1.0)
    check(not group_pids(p.pid), "no worker process left after Ctrl-C")

    # 3. run to the end
    print("\n3. restart to the end")
    t0 = time.monotonic()
    r = subprocess.run(cmd, capture_output=True, text=True)
    print(f"  exit code {r.returncode} after {time.monotonic() - t0:.1f} s: {r.stdout.strip()}")
    recs = valid_records(journal)
    keys = [x["key"] for x in recs]
    rows = pd.read_csv(table)
    check(r.returncode == 0, "the restarted sweep finishes")
    check(len(keys) == len(set(keys)) == n_points,
          f"every point exactly once in the journal ({len(keys)} lines, "
          f"{len(set(keys))} keys)")
    check(len(rows) == n_points and rows.key.is_unique and rows.converged.all(),
          f"every point exactly once in the table ({len(rows)} rows, all converged)")
    n2 = len(valid_records(before2))
    check(f"({n_points - n2} computed now, {n2} from earlier runs)" in r.stdout,
          "the restart computed only the missing points")
    check(read(journal).startswith(before2),
          "lines from before the Ctrl-C are unchanged")
    r = subprocess.run(cmd, capture_output=True, text=True)
    check(f"(0 computed now, {n_points} from earlier runs)" in r.stdout,
          "a fourth run computes nothing")

    if args.dask:
        print("\n4. the same sweep on distributed.LocalCluster(n_workers=2, processes=True)")
        import logging

        import numpy as np
        from distributed import LocalCluster

        from skfem_sheet.studies.sweep import grid, run_sweep

        pts = grid(length=[0.3, 0.4, 0.5], tip_width=[1.0, 0.0], curvature=[0.0, 2.5],
                   path="both", hmax=args.hmax)
        t0 = time.monotonic()
        with LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                          dashboard_address=None, silence_logs=logging.ERROR) as cluster:
            run_sweep(pts, table=os.path.join(out, "dask.csv"),
                      scheduler=cluster.scheduler_address, progress=False)
        dask = pd.read_csv(os.path.join(out, "dask.csv"))
        print(f"  {len(dask)} rows in {time.monotonic() - t0:.1f} s")
        dd = np.max(np.abs(dask.deflection.to_numpy() - rows.deflection.to_numpy()))
        same = ["key", "path", "converged", "branch", "snapped", "newton_iterations",
                "load_steps", "dofs"]
        check(list(dask.key) == list(rows.key) and dask[same].equals(rows[same]),
              "same rows (keys, order, convergence, branch, iterations) as the process pool")
        check(dd <= 1e-12, f"same deflections: max |d_dask - d_pool| = {dd:.1e}")

    print(f"\n{'ALL CHECKS PASSED' if not FAILED else f'{len(FAILED)} CHECKS FAILED'} "
          f"(tables in {out})")
    return 1 if FAILED else 0


if __name__ == "__main__":
    sys.exit(main())
