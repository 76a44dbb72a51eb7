"""Peak memory and time of one transfer between meshes (issue 19, the memory part).

    OMP_NUM_THREADS=1 python benchmarks/transfer_memory.py [--hmax 0.1,0.06] [--new-only 0.03]
        [--fold-search 0.06] [--out benchmarks/results/transfer_memory.txt]

The case of the issue: the state of a rectangle (b/a = 1, a/R = 2.5, the
symmetric half model that ``follow_length`` uses) on the mesh made at
L/a = 1.8 and stretched to 2.4 (``with_length``) is interpolated onto a fresh
mesh made at 2.4, as ``bistability`` does when a continuation in L remeshes.
The state is a smooth synthetic field (point location and interpolation cost
the same for any values; a solve before the transfer would put its own peak
into the process).

Each (hmax, code) runs in a fresh Python process, one after another:

- ``old``: scikit-fem's ``basis.probes`` (its element finder), as
  ``bistability.transfer`` did before; the code is copied below;
- ``new``: :func:`skfem_sheet.analyses.transfer.transfer`.

In the child, after both problems are built, ``gc.collect()``, the resident
set ``VmRSS`` is read, the high-water mark is reset (``5`` written to
``/proc/self/clear_refs``) and after the transfers ``VmHWM`` is read: the
transfer's own peak (``peak``, over ``REPEAT`` transfers) and its rise over
the resident set before it (``rise``).  ``best`` is the wall time of the
fastest of them, ``first`` that of the first (for ``old`` it includes
building scikit-fem's KD-tree of the element centroids, cached on the mesh
for the others).  ``setup`` is the high-water mark of building the two problems.  A further
transfer under ``tracemalloc`` gives the peak of the memory it allocates
(``traced``: numpy's buffers and Python objects, not what scipy's C++ code
allocates).
The parent also compares the two results (max abs difference) where both ran.

``--fold-search H``: the peak memory (VmHWM) of a whole fold search
(``fold_lengths`` of the rectangle at a/R 2.5, lengths 0.6 to 2.4, with the
new transfer) and of its largest solve (L/a 2.4, gravity-first), each in a
fresh process (the issue's acceptance: at most twice that of the solve).
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc

import numpy as np

try:
    import skfem_sheet  # noqa: F401
except ImportError:  # run from a checkout without installing: use the repository next door
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from skfem_sheet import Sheet
from skfem_sheet.analyses.transfer import _clip_to_sheet, transfer
from skfem_sheet.bistability import fold_lengths
from skfem_sheet.io import atomic_write, dumps_json
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.problem import SheetProblem
from skfem_sheet.solve import solve

MB = 1024.0 ** 2
L_MESH, L_NOW = 1.8, 2.4
REPEAT = 3  # transfers timed in each child (the fastest is reported)


def probes_transfer(old, w_old, new):
    """The transfer before issue 19 (scikit-fem's element finder), verbatim."""
    s_old = old.length / old.sheet_mesh.length
    X = new.nodes / np.array([s_old, 1.0, 1.0])  # in old's mesh coordinates
    X = _clip_to_sheet(X, old.sheet_mesh)
    U_old, p_old = old.split(w_old)
    P2 = old.basis_u.probes(X.T)
    n_v = new.sheet_mesh.n_vertices
    P1 = old.basis_p.probes(X[:n_v].T)  # P2 vertex nodes come first (skfem numbering)
    w = np.zeros(new.ndof)
    w[: new.nu_dof] = (P2 @ U_old).ravel()
    w[new.nu_dof:] = P1 @ p_old
    return w


def _status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024.0  # kB -> bytes
    raise KeyError(key)


def smooth_state(problem):
    """A smooth displacement and pressure (bending-like), in the stretched coordinates."""
    X = problem.nodes
    w = np.zeros(problem.ndof)
    w[: problem.nu_dof] = np.stack([0.1 * X[:, 0] * X[:, 1], 0.05 * np.sin(X[:, 1]) * X[:, 0],
                                    -0.3 * X[:, 0] ** 2 + 0.02 * X[:, 1] ** 2], 1).ravel()
    V = problem.sheet_mesh.mesh.p.T * [problem.length / problem.sheet_mesh.length, 1, 1]
    w[problem.nu_dof:] = np.cos(V[:, 0]) + V[:, 1]
    return w


def child(hmax, code, out):
    sheet = Sheet(length=L_MESH, tip_width=1.0, curvature=2.5)
    old = SheetProblem(sheet, sheet_mesh(sheet, hmax, half=True)).with_length(L_NOW)
    now = sheet.replace(length=L_NOW)
    new = SheetProblem(now, sheet_mesh(now, hmax, half=True))
    w_old = smooth_state(old)
    gc.collect()
    setup = _status("VmHWM")
    rss0 = _status("VmRSS")
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # reset the high-water mark VmHWM to the current RSS
    fn = probes_transfer if code == "old" else transfer
    walls = []
    for _ in range(REPEAT):
        t0 = time.perf_counter()
        w = fn(old, w_old, new)
        walls.append(time.perf_counter() - t0)
    peak = _status("VmHWM")
    np.save(out, w)
    del w
    gc.collect()
    tracemalloc.start()  # numpy reports its buffers to tracemalloc
    fn(old, w_old, new)
    traced = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return {"hmax": hmax, "code": code, "old_dofs": old.ndof, "new_dofs": new.ndof,
            "old_elements": old.sheet_mesh.n_elements, "setup_mb": setup / MB,
            "rss0_mb": rss0 / MB, "peak_mb": peak / MB, "rise_mb": (peak - rss0) / MB,
            "traced_mb": traced / MB, "first_s": walls[0], "best_s": min(walls)}


def run_child(hmax, code, out):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = ["/usr/bin/time", "-v", sys.executable, os.path.abspath(__file__), "--child",
           str(hmax), code, out]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if p.returncode != 0:
        raise RuntimeError(f"child {hmax} {code} failed:\n{p.stderr[-3000:]}")
    rec = json.loads(p.stdout.strip().splitlines()[-1])
    for line in p.stderr.splitlines():
        if "Maximum resident set size" in line:
            rec["process_max_rss_mb"] = int(line.split()[-1]) / 1024.0
    return rec

def whole(kind, hmax):
    """One fold search (``fold_lengths``) or its largest solve, in this process."""
    t0 = time.perf_counter()
    if kind == "fold":
        r = fold_lengths(1.0, 2.5, hmax=hmax)
        rec = {"popup_length": r.popup_length, "standout_length": r.standout_length}
    else:  # the longest sheet of the fold search's range, the branch it starts from there
        r = solve(Sheet(length=L_NOW, tip_width=1.0, curvature=2.5), "gravity-first", hmax)
        rec = {"deflection": r.deflection}
    rec.update(kind=kind, hmax=hmax, wall_s=time.perf_counter() - t0,
               vmhwm_mb=_status("VmHWM") / MB)
    return rec


def run_whole(kind, hmax):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = ["/usr/bin/time", "-v", sys.executable, os.path.abspath(__file__), "--whole", kind,
           str(hmax)]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if p.returncode != 0:
        raise RuntimeError(f"{kind} at {hmax} failed:\n{p.stderr[-3000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hmax", default="0.1,0.06", help="meshes for old and new (comma list)")
    ap.add_argument("--new-only", default="", help="meshes for the new code only (comma list)")
    ap.add_argument("--out", default=None, help="write the table here too")
    ap.add_argument("--fold-search", default="", help="meshes at which to measure a whole "
                    "fold search (fold_lengths, b/a 1, a/R 2.5) and its largest solve")
    ap.add_argument("--child", nargs=3, metavar=("HMAX", "CODE", "NPY"), help=argparse.SUPPRESS)
    ap.add_argument("--whole", nargs=2, metavar=("KIND", "HMAX"), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        print(dumps_json(child(float(a.child[0]), a.child[1], a.child[2]), indent=None))
        return 0
    if a.whole:
        print(dumps_json(whole(a.whole[0], float(a.whole[1])), indent=None))
        return 0
    cases = [(float(h), c) for h in a.hmax.split(",") if h for c in ("old", "new")]
    cases += [(float(h), "new") for h in a.new_only.split(",") if h]
    rows, lines = [], []
    head = (f"one transfer, rectangle a/R 2.5 (half model): mesh of L/a {L_MESH} stretched to "
            f"{L_NOW} -> fresh mesh at {L_NOW}; OMP_NUM_THREADS=1, one fresh process per row, "
            "run one at a time")
    cols = (f"{'hmax':>5} {'code':>4} {'dofs old':>9} {'dofs new':>9} {'setup MB':>9} "
            f"{'rss0 MB':>8} {'peak MB':>8} {'rise MB':>8} {'traced MB':>9} {'proc MB':>8} "
            f"{'first s':>8} {'best s':>8} "
            f"{'max|new-old|':>12}")
    print(head)
    print(cols)
    with tempfile.TemporaryDirectory() as tmp:
        for hmax, code in cases:
            out = os.path.join(tmp, f"{hmax}_{code}.npy")
            r = run_child(hmax, code, out)
            diff = ""
            if code == "new" and os.path.exists(os.path.join(tmp, f"{hmax}_old.npy")):
                diff = float(np.abs(np.load(out) - np.load(os.path.join(tmp, f"{hmax}_old.npy")))
                             .max())
                r["max_abs_diff_vs_old"] = diff
                diff = f"{diff:.2e}"
            rows.append(r)
            line = (f"{hmax:>5g} {code:>4} {r['old_dofs']:>9d} {r['new_dofs']:>9d} "
                    f"{r['setup_mb']:>9.0f} {r['rss0_mb']:>8.0f} {r['peak_mb']:>8.0f} "
                    f"{r['rise_mb']:>8.0f} {r['traced_mb']:>9.1f} "
                    f"{r.get('process_max_rss_mb', float('nan')):>8.0f} "
                    f"{r['first_s']:>8.4f} {r['best_s']:>8.4f} {diff:>12}")
            print(line, flush=True)
            lines.append(line)
    for h in [float(h) for h in a.fold_search.split(",") if h]:
        fold, one = run_whole("fold", h), run_whole("solve", h)
        ratio = fold["vmhwm_mb"] / one["vmhwm_mb"]
        extra = ["", f"whole fold search at hmax {h:g} (new transfer; fresh processes, VmHWM):",
                 (f"  fold_lengths(b/a 1, a/R 2.5): L0* {fold['popup_length']:.4f}, "
                  f"L1* {fold['standout_length']:.4f}, peak {fold['vmhwm_mb']:.0f} MB, "
                  f"wall {fold['wall_s']:.0f} s"),
                 (f"  its largest solve (L/a {L_NOW}, gravity-first): peak "
                  f"{one['vmhwm_mb']:.0f} MB, wall {one['wall_s']:.0f} s; ratio {ratio:.2f}")]
        print("\n".join(extra), flush=True)
        lines += extra
    notes = [
        "",
        "setup: VmHWM after building both problems; rss0: VmRSS just before the transfer;",
        "peak: VmHWM during the transfer (reset before it); rise = peak - rss0 (the transfer's",
        "own rise of the resident set); traced: peak of the memory allocated by the transfer",
        "(tracemalloc, a second run of it in the same process: numpy's buffers; the rise can be",
        "smaller where the transfer reuses memory that the setup freed);",
        "proc: maximum RSS of the whole process (/usr/bin/time -v);",
        "max|new-old|: largest difference of the transferred state (new code against",
        "scikit-fem's probes, same mesh, same synthetic state).",
        f"first s / best s: wall time of the first of {REPEAT} transfers in the process and of",
        "the fastest (the old code caches its KD-tree of element centroids on the mesh after",
        "the first; in a continuation each remesh transfers from a mesh used once).",
        "For scale at hmax 0.03: one full solve of the rectangle at L/a 1.3 (57723 unknowns)",
        "peaks at 0.91 GB (benchmarks/results/solve_speed_hmax0.03.txt); the solve at L/a 2.4",
        "has about twice the unknowns; the transfer adds its 'traced' MB to that.",
    ]
    if a.out:
        atomic_write(a.out, "\n".join([head, cols, "-" * len(cols)] + lines + notes) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
