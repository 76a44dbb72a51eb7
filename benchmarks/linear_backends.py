"""Linear-solver back-ends on the Newton systems of a real solve (issue 3, item 3).

    python benchmarks/linear_backends.py [--hmax 0.03] [--paths curvature-first,gravity-first]
        [--backends pardiso,superlu,pyamg] [--systems 6] [--rtol 1e-6]
        [--pyamg-options '{"reuse": false}'] [--threads N] [--full-solve]
        [--json linear_backends.json] [--keep DIR]

1. Record: one ``solve`` per load path (default: the rectangle L/a = 1.3,
   a/R = 2.5 at hmax 0.03) with the best direct back-end, in a child process,
   saving the systems ``K dw = -r_free`` Newton actually solved (the tangent,
   the residual's free part and the state it was formed at: the first solve
   after each factorisation).  ``--systems N`` keeps N of them, evenly spaced
   along the path (``all``: every one), plus the tangent re-formed at the
   converged state with its residual.
2. Replay: every back-end, in a fresh process per back-end and path, gets the
   kept systems in path order through the public interface
   (``attach(problem)``, ``factorize(K, state=w)``, ``solve(b)``), so that
   reuse between Newton iterations (PARDISO's symbolic analysis, pyamg's
   hierarchy) works as in a solve.
3. Table: back-end, path, unknowns, systems, setup/factorisation time, solve
   time, time per system, Krylov iterations (mean/max; pyamg), the largest
   final ``||K x - b|| / ||b||``, the largest difference from the recording
   direct solver's solution ``||x - x_ref|| / ||x_ref||`` (pyamg: up to
   ~1e-3 at rtol 1e-6 on the near-converged systems, whose small right-hand
   sides excite the soft bending modes; Newton does not notice), and the peak
   resident memory of the process (VmHWM; ``tracemalloc`` misses MKL's
   allocations) and its growth during the replay.

superlu is left out below hmax 0.05 unless named in ``--backends``.
``--full-solve`` also times complete solves ``solve(..., solver=name)`` per
back-end (fresh process each, via ``harness.run_isolated``).  Timings are only
meaningful on an otherwise idle machine; a warning is printed otherwise.
Exit code 1 if a back-end failed to reach the required residual on some
system (pyamg: its ``rtol``; direct solvers: 1e-6).
"""
from __future__ import annotations

import importlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from harness import (
    GB,
    available_backends,
    fmt,
    machine_info,
    parser,
    peak_rss_bytes,
    run_isolated,
    warn_if_busy,
)

DIRECT_RTOL = 1e-6  # a direct solve that misses this is reported as failed
SUPERLU_MIN_HMAX = 0.05  # superlu takes many minutes per system below this (as solve_speed.py)


# ---------------------------------------------------------------------------
# child 1: record the Newton systems of a solve
# ---------------------------------------------------------------------------
def _record(spec, outdir):
    from skfem_sheet import Sheet
    from skfem_sheet.linalg import make_linear_solver
    from skfem_sheet.problem import SheetProblem

    solve_module = importlib.import_module("skfem_sheet.solve")
    os.makedirs(outdir, exist_ok=True)
    saved = []
    last_state = {}

    # The state a tangent was formed at: from factorize(K, state=w) when the
    # caller passes it, else remembered from the last SheetProblem.tangent(w).
    original_tangent = SheetProblem.tangent

    def tangent(self, w):
        last_state["w"] = np.array(w)
        return original_tangent(self, w)

    SheetProblem.tangent = tangent

    class Recorder:
        """The direct back-end, saving the first system after each factorisation."""

        def __init__(self, name):
            self.inner = make_linear_solver(name)
            self.name = self.inner.name
            self._pending = None

        def attach(self, problem):
            self.inner.attach(problem)

        def inertia(self):
            return self.inner.inertia()

        def factorize(self, K, state=None):
            self.inner.factorize(K)
            w = state if state is not None else last_state.get("w")
            self._pending = (K.data.copy(), None if w is None else np.array(w), K)

        def solve(self, b):
            x = self.inner.solve(b)
            if self._pending is not None and np.ndim(b) == 1:
                data, w, K = self._pending
                self._pending = None
                fn = os.path.join(outdir, f"sys_{len(saved):04d}.npz")
                np.savez(fn, data=data, b=np.asarray(b), x=x,
                         w=w if w is not None else np.zeros(0))
                saved.append(fn)
                if len(saved) == 1:
                    np.savez(os.path.join(outdir, "pattern.npz"), indices=K.indices,
                             indptr=K.indptr)
            return x

    direct = spec["direct"]
    solve_module.make_linear_solver = lambda name="auto", **kw: Recorder(direct)
    kw = dict(path=spec["path"], hmax=spec["hmax"], on_failure="return")
    if spec.get("layers") is not None:
        kw["layers"] = spec["layers"]
    t0 = time.perf_counter()
    r = solve_module.solve(Sheet(**spec["sheet"]), **kw)
    wall = time.perf_counter() - t0
    SheetProblem.tangent = original_tangent
    p = r.problem
    # the converged state, with its own residual as right-hand side
    K = p.tangent(r.w)
    res, _ = p.residual(r.w, r.gravity)
    b = -res[p.free]
    ref = make_linear_solver(direct)
    ref.attach(p)
    ref.factorize(K)
    fn = os.path.join(outdir, f"sys_{len(saved):04d}.npz")
    np.savez(fn, data=K.data, b=b, x=ref.solve(b), w=r.w)
    saved.append(fn)
    # keep an evenly spaced selection (the first, the last Newton system, the final state)
    n_keep = spec["systems"]
    newton_sys = saved[:-1]
    if n_keep is not None and len(newton_sys) > n_keep:
        keep = set(np.unique(np.linspace(0, len(newton_sys) - 1, n_keep).round().astype(int)))
        for i, f in enumerate(newton_sys):
            if i not in keep:
                os.unlink(f)
        newton_sys = [f for i, f in enumerate(newton_sys) if i in keep]
    meta = dict(spec=spec, files=[os.path.basename(f) for f in newton_sys + saved[-1:]],
                recorded=len(saved), n=int(len(p.free)), dofs=int(p.ndof),
                half=bool(getattr(p.sheet_mesh, "half", False)), layers=int(p.sheet_mesh.layers),
                converged=bool(r.converged), deflection=float(r.deflection),
                newton_iterations=int(r.newton_iterations), solve_wall_s=wall,
                message=r.message)
    with open(os.path.join(outdir, "meta.json"), "w") as f:
        json.dump(meta, f)


# ---------------------------------------------------------------------------
# child 2: replay the systems with one back-end
# ---------------------------------------------------------------------------
def _replay(spec, sysdir, out):
    import scipy.sparse as sp

    from skfem_sheet import Sheet
    from skfem_sheet.linalg import LinearSolverError, make_linear_solver
    from skfem_sheet.mesh import sheet_mesh
    from skfem_sheet.problem import SheetProblem

    with open(os.path.join(sysdir, "meta.json")) as f:
        meta = json.load(f)
    rs = meta["spec"]
    sheet = Sheet(**rs["sheet"])
    mesh_kw = dict(half=True) if meta["half"] else {}
    problem = SheetProblem(sheet, sheet_mesh(sheet, rs["hmax"], meta["layers"], **mesh_kw))
    if len(problem.free) != meta["n"]:
        raise RuntimeError(f"rebuilt problem has {len(problem.free)} free dofs, "
                           f"the recording {meta['n']}")
    pat = np.load(os.path.join(sysdir, "pattern.npz"))
    n = meta["n"]
    name = spec["backend"]
    solver = make_linear_solver(name, **(spec.get("options") or {}))
    if hasattr(solver, "attach"):
        solver.attach(problem)
    rows = []
    rss0 = peak_rss_bytes()
    ok = True
    for fn in meta["files"]:
        d = np.load(os.path.join(sysdir, fn))
        K = sp.csr_matrix((d["data"], pat["indices"], pat["indptr"]), shape=(n, n))
        b, x_ref = d["b"], d["x"]
        w = d["w"] if d["w"].size else None
        row = dict(system=fn)
        t0 = time.perf_counter()
        try:
            solver.factorize(K, state=w)
            t1 = time.perf_counter()
            x = solver.solve(b)
            t2 = time.perf_counter()
        except LinearSolverError as err:
            row.update(error=str(err), factor_s=None, solve_s=time.perf_counter() - t0)
            ok = False
        else:
            nb = np.linalg.norm(b)
            row.update(factor_s=t1 - t0, solve_s=t2 - t1,
                       rel_residual=float(np.linalg.norm(K @ x - b) / nb) if nb else 0.0,
                       diff_ref=float(np.linalg.norm(x - x_ref)
                                      / max(np.linalg.norm(x_ref), 1e-300)))
            its = getattr(solver, "iterations", None)
            if its:
                row["krylov_iterations"] = int(its[-1])
            tol = getattr(solver, "rtol", DIRECT_RTOL)
            if not row["rel_residual"] <= tol:
                ok = False
        rows.append(row)
    rec = dict(backend=name, path=rs["path"], n=n, systems=rows, ok=ok,
               peak_rss_gb=peak_rss_bytes() / GB, rss_before_gb=rss0 / GB,
               options=spec.get("options") or {})
    for attr in ("n_setups", "n_refreshes", "setup_time", "krylov_time", "rtol"):
        if hasattr(solver, attr):
            rec[attr] = getattr(solver, attr)
    with open(out, "w") as f:
        json.dump(rec, f)


# ---------------------------------------------------------------------------
# parent
# ---------------------------------------------------------------------------
def _child(mode, spec, *paths, threads=None, timeout=None):
    env = dict(os.environ)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = os.pathsep.join(x for x in (root, env.get("PYTHONPATH")) if x)
    if threads:
        for var in ("MKL_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
            env[var] = str(threads)
    try:
        proc = subprocess.run([sys.executable, os.path.abspath(__file__), mode, json.dumps(spec),
                               *paths], env=env, timeout=timeout, stderr=subprocess.PIPE,
                              stdout=subprocess.DEVNULL, text=True)
    except subprocess.TimeoutExpired:
        return f"killed after {timeout:g} s"
    if proc.returncode:
        return "exit code {}: {}".format(
            proc.returncode, " | ".join((proc.stderr or "").strip().splitlines()[-3:]))
    return None


def _summary(rec):
    rows = [r for r in rec["systems"] if "error" not in r]
    its = [r["krylov_iterations"] for r in rows if "krylov_iterations" in r]
    return dict(
        systems=len(rec["systems"]), failed=len(rec["systems"]) - len(rows),
        factor_s=sum(r["factor_s"] for r in rows), solve_s=sum(r["solve_s"] for r in rows),
        per_system_s=(sum(r["factor_s"] + r["solve_s"] for r in rows) / len(rows)
                      if rows else None),
        its_mean=float(np.mean(its)) if its else None, its_max=max(its) if its else None,
        max_residual=max((r["rel_residual"] for r in rows), default=None),
        max_diff_ref=max((r["diff_ref"] for r in rows), default=None))


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--hmax", type=float, default=0.03)
    ap.add_argument("--length", type=float, default=1.3)
    ap.add_argument("--tip-width", type=float, default=1.0)
    ap.add_argument("--curvature", type=float, default=2.5)
    ap.add_argument("--layers", type=int, default=None)
    ap.add_argument("--paths", default="curvature-first,gravity-first")
    ap.add_argument("--backends", default=None,
                    help="comma-separated (default: every installed back-end)")
    ap.add_argument("--systems", default="6",
                    help="Newton systems kept per path, evenly spaced, or 'all' (default 6)")
    ap.add_argument("--rtol", type=float, default=None, help="pyamg's relative residual target")
    ap.add_argument("--pyamg-options", default="{}", help="JSON dict of PyAMGSolver options")
    ap.add_argument("--threads", type=int, default=None,
                    help="MKL/OpenMP/OpenBLAS threads in the children")
    ap.add_argument("--full-solve", action="store_true",
                    help="also time a complete solve per back-end and path")
    ap.add_argument("--timeout", type=float, default=3600.0, help="per child process (s)")
    ap.add_argument("--json", default=None, help="write all numbers here")
    ap.add_argument("--keep", default=None,
                    help="keep the recorded systems in this directory (reused if present)")
    args = ap.parse_args(argv)

    warn_if_busy()
    if args.backends:
        backends = args.backends.split(",")
    else:
        backends = [b for b in available_backends()
                    if b != "superlu" or args.hmax >= SUPERLU_MIN_HMAX]
    unknown = sorted(set(backends) - set(available_backends()))
    if unknown:
        ap.error(f"--backends: not available here: {', '.join(unknown)} "
                 f"(available: {', '.join(available_backends())})")
    direct = "pardiso" if "pardiso" in available_backends() else "superlu"
    pyamg_options = json.loads(args.pyamg_options)
    if args.rtol is not None:
        pyamg_options["rtol"] = args.rtol
    systems = None if args.systems == "all" else int(args.systems)
    sheet = dict(length=args.length, tip_width=args.tip_width, curvature=args.curvature)
    workdir = args.keep or tempfile.mkdtemp(prefix="skfem_sheet_linear_")
    report = dict(machine=machine_info(), args=vars(args), recordings={}, replays=[],
                  full_solves=[])
    failed = False
    try:
        for path in args.paths.split(","):
            sysdir = os.path.join(workdir, path)
            spec = dict(sheet=sheet, path=path, hmax=args.hmax, layers=args.layers,
                        systems=systems, direct=direct)
            meta_fn = os.path.join(sysdir, "meta.json")
            if os.path.exists(meta_fn):
                with open(meta_fn) as f:
                    if json.load(f)["spec"] != spec:
                        shutil.rmtree(sysdir)
            if not os.path.exists(meta_fn):
                print(f"recording the Newton systems of {path} (hmax={args.hmax:g}, {direct})...",
                      file=sys.stderr, flush=True)
                err = _child("--record", spec, sysdir, threads=args.threads, timeout=args.timeout)
                if err:
                    sys.exit(f"recording {path} failed: {err}")
            with open(meta_fn) as f:
                meta = json.load(f)
            report["recordings"][path] = meta
            print(f"{path}: {meta['n']} unknowns, {meta['recorded']} systems recorded, "
                  f"{len(meta['files'])} kept; d/a = {meta['deflection']:.5f}, "
                  f"{meta['newton_iterations']} Newton iterations", file=sys.stderr, flush=True)
            for name in backends:
                out = os.path.join(workdir, f"replay_{path}_{name}.json")
                spec_r = dict(backend=name, options=pyamg_options if name == "pyamg" else {})
                print(f"  replaying with {name}...", file=sys.stderr, flush=True)
                err = _child("--replay", spec_r, sysdir, out, threads=args.threads,
                             timeout=args.timeout)
                if err:
                    rec = dict(backend=name, path=path, n=meta["n"], systems=[], ok=False,
                               error=err)
                else:
                    with open(out) as f:
                        rec = json.load(f)
                rec["summary"] = _summary(rec) if rec["systems"] else None
                failed |= not rec["ok"]
                report["replays"].append(rec)
        if args.full_solve:
            for path in args.paths.split(","):
                for name in backends:
                    print(f"full solve: {path}, {name}...", file=sys.stderr, flush=True)
                    spec = dict(sheet=sheet, path=path, hmax=args.hmax, layers=args.layers,
                                solver=name)
                    report["full_solves"].append(
                        run_isolated(spec, timeout=args.timeout, threads=args.threads))
    finally:
        if args.keep is None:
            shutil.rmtree(workdir, ignore_errors=True)

    print(f"\nNewton systems of L/a={args.length:g}, b/a={args.tip_width:g}, "
          f"a/R={args.curvature:g}, hmax={args.hmax:g} (recorded with {direct})")
    head = (f"{'back-end':9} {'path':16} {'n':>7} {'sys':>4} {'setup s':>8} {'solve s':>8} "
            f"{'s/sys':>7} {'its mean':>8} {'its max':>7} {'max res':>8} {'max dx':>8} "
            f"{'peak GB':>7} {'+GB':>6}")
    print(head)
    print("-" * len(head))
    for rec in report["replays"]:
        s = rec["summary"]
        if s is None:
            print(f"{rec['backend']:9} {rec['path']:16} {rec['n']:7d}  FAILED: {rec.get('error')}")
            continue
        print(f"{rec['backend']:9} {rec['path']:16} {rec['n']:7d} {s['systems']:4d} "
              f"{s['factor_s']:8.2f} {s['solve_s']:8.2f} {fmt(s['per_system_s'], '7.2f')} "
              f"{fmt(s['its_mean'], '8.1f')} {fmt(s['its_max'], '7d')} "
              f"{fmt(s['max_residual'], '8.1e')} {fmt(s['max_diff_ref'], '8.1e')} "
              f"{rec['peak_rss_gb']:7.2f} {rec['peak_rss_gb'] - rec['rss_before_gb']:6.2f}"
              + (f"  ({s['failed']} failed)" if s["failed"] else ""))
    if report["full_solves"]:
        print("\nfull solves")
        head = (f"{'back-end':9} {'path':16} {'status':10} {'d/a':>9} {'newton':>6} "
                f"{'wall s':>7} {'linear s':>8} {'peak GB':>7}")
        print(head)
        print("-" * len(head))
        for r in report["full_solves"]:
            print(f"{r['spec']['solver']:9} {r['spec']['path']:16} {r['status']:10} "
                  f"{fmt(r.get('deflection'), '9.5f')} {fmt(r.get('newton_iterations'), '6d')} "
                  f"{fmt(r.get('wall_time_s'), '7.1f')} {fmt(r.get('linear_solve_s'), '8.1f')} "
                  f"{fmt(r.get('peak_rss_gb'), '7.2f')}"
                  + (f"  {r.get('error', '')[:80]}" if r["status"] == "crash" else ""))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)
    return 1 if failed else 0


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "--record":
        _record(json.loads(sys.argv[2]), sys.argv[3])
    elif len(sys.argv) >= 2 and sys.argv[1] == "--replay":
        _replay(json.loads(sys.argv[2]), sys.argv[3], sys.argv[4])
    else:
        sys.exit(main())
