"""Where the time goes: one fold curve, Fig. 7's 18 curves, a fold-map row or a solve, by stage and operation (issue 59).

    python benchmarks/speed_profile.py curve 3.5 [--rectangle] [--hmax 0.03]
    python benchmarks/speed_profile.py fig7 [--workers 2] [--quality paper]
    python benchmarks/speed_profile.py row 1 2.5 [--quality paper]
    python benchmarks/speed_profile.py solve [--length 1.3 --tip-width 1 --curvature 2.5]
        [--path both] [--hmax 0.03]
    python benchmarks/speed_profile.py paper [--record FILE.json] [--curves FILE.json]
    ... [--txt OUT.txt] [--json OUT.json]

Every part runs the package's own code under a recorder that times, without
changing anything, the operations the work is made of: factorisations and
back-substitutions of the linear solver, residual and tangent assemblies,
mapped and built function spaces, meshes, and the transfer of states
between meshes.  Each operation is booked to the *stage* under way (the
innermost of the functions below that is running) and to the *level* (the
mesh size of the system it acts on), so that the table says, e.g., how
many seconds the factorisations at hmax 0.03 of the fine refinement of a
fold curve took.

- ``curve A_R``: one fold curve at Fig. 7's settings (``studies.foldmap``'s
  record of a curve at the quality's mesh: hmax 0.03 from 0.1 and 0.06,
  inertia checked at every fifth fine point; ``--rectangle``: the curve in
  (L, a/R) at b/a 1 from that a/R).  Stages: the start solve, the standout
  fold, the coarse fold curve, the refinement (per level), the ends
  continued on a fine mesh, the cusp on the fine mesh, the inertia checks.
- ``fig7``: the quality's 18 fold curves, each in a worker process under the
  recorder (the studies' pool, in the order the fold-curve table runs
  them): the batch's elapsed time, every curve's wall and stages, and the
  sum of the stages over the curves.  (Not through the resumable table:
  ``figure fig7 --quality paper`` times the command itself.)
- ``row B A_R``: one fold-map row of the quality (``studies.foldmap``'s
  record: both branches followed in L, coarse to fine at paper quality).
  Stages are read off the levels (the coarse trace on hmax 0.1, the fine
  continuation on the row's mesh).
- ``solve``: ``skfem_sheet.solve`` on one sheet per path, its
  ``wall_time_s`` beside the recorder's: the coarse path, the transfer and
  the fine Newton solve by level, and the share outside the fine linear
  solver.
- ``paper``: no computation; the recorded ``figure all`` summary (``--record``,
  default the newest of ``benchmarks/results/speed/figure_all_paper_*.json``)
  per figure and per data step, and the model of the paper's time on N
  workers from its task costs (per batch the sum and the longest single
  task; the critical path), the fold curves optionally from a ``fig7`` JSON
  (``--curves``).

Timings depend on the machine's load: the load average is printed and
recorded; compare parts run in one process or side by side, and counts
(factorisations) across runs.  ``OMP_NUM_THREADS=1 MKL_NUM_THREADS=1`` for
timings on a shared machine.
"""
from __future__ import annotations

import contextlib
import glob
import json
import os
import sys
import time
from collections import defaultdict

from harness import machine_info, parser

#: Where the records go by default.
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results", "speed")


# -- the recorder ---------------------------------------------------------------------------
class Recorder:
    """Times the package's operations by (stage, level, operation), in this process.

    The patches wrap the functions where they are looked up (every loaded
    module that holds the same function object), call them unchanged, and
    are removed on :meth:`close`.
    """

    def __init__(self):
        self.stack = []
        self.ops = defaultdict(lambda: [0, 0.0])   # (stage, level, op) -> [count, s]
        self.stages = defaultdict(lambda: [0, 0.0])  # stage path -> [calls, inclusive s]
        self.levels = {}  # system size -> level label
        self._undo = []

    # patching
    def _replace(self, owner, name, new):
        old = getattr(owner, name)
        setattr(owner, name, new)
        self._undo.append((owner, name, old))

    def _everywhere(self, module, name, make):
        """Wrap ``module.name`` and every loaded module's global bound to it."""
        orig = getattr(module, name)
        new = make(orig)
        for m in list(sys.modules.values()):
            if m is None or not getattr(m, "__name__", "").startswith("skfem_sheet"):
                continue
            if getattr(m, name, None) is orig:
                self._replace(m, name, new)

    def stage(self, name):
        def make(fn):
            def wrapped(*a, **k):
                label = name(*a, **k) if callable(name) else name
                self.stack.append(label)
                path = " > ".join(self.stack)
                t = time.perf_counter()
                try:
                    return fn(*a, **k)
                finally:
                    rec = self.stages[path]
                    rec[0] += 1
                    rec[1] += time.perf_counter() - t
                    self.stack.pop()
            wrapped.__wrapped__ = fn
            return wrapped
        return make

    def op(self, op, level_of):
        def make(fn):
            def wrapped(*a, **k):
                t = time.perf_counter()
                try:
                    return fn(*a, **k)
                finally:
                    key = (" > ".join(self.stack) or "(outside)", level_of(a), op)
                    rec = self.ops[key]
                    rec[0] += 1
                    rec[1] += time.perf_counter() - t
            wrapped.__wrapped__ = fn
            return wrapped
        return make

    def _size_level(self, n):
        return self.levels.get(int(n), f"n {int(n)}")

    def install(self):
        from skfem_sheet import assembly, discretisation, linalg, mesh, problem
        from skfem_sheet.analyses import transfer

        def label(sheet_mesh):
            return f"hmax {sheet_mesh.hmax:g}" + (f" r{sheet_mesh.refine}"
                                                   if sheet_mesh.refine else "")

        orig_init = problem.SheetProblem.__init__

        def init(obj, *a, **k):
            orig_init(obj, *a, **k)
            m = obj.sheet_mesh
            for n in {int(obj.ndof), int(len(obj.free))}:
                self.levels.setdefault(n, label(m))
        self._replace(problem.SheetProblem, "__init__", init)

        def prob_level(a):
            return label(a[0].sheet_mesh)

        def size_level(a):
            x = a[1]
            return self._size_level(x.shape[0])

        for name, op in (("residual", "residual"), ("tangent", "tangent"),
                         ("clamp_coupling", "assembly (other)"), ("energy", "assembly (other)")):
            self._replace(problem.SheetProblem, name,
                          self.op(op, prob_level)(getattr(problem.SheetProblem, name)))
        for cls in (linalg.PardisoSolver, linalg.SuperLUSolver, linalg.PyAMGSolver):
            self._replace(cls, "factorize", self.op("factorisation", size_level)(cls.factorize))
            self._replace(cls, "solve", self.op("back-substitution", size_level)(cls.solve))
        space = discretisation.TaylorHoodSpace
        self._replace(space, "mapped", self.op("mapped space",
                                               lambda a: label(a[1]))(space.mapped))
        self._replace(space, "build", classmethod(self.op(
            "space built", lambda a: label(a[1]))(space.build.__func__)))
        self._replace(mesh.MeshSpec, "build", self.op(
            "mesh", lambda a: f"hmax {a[0].hmax:g}" + (f" r{a[0].refine}" if a[0].refine
                                                       else ""))(mesh.MeshSpec.build))
        self._replace(assembly.Assembler, "build", classmethod(self.op(
            "assembler built", lambda a: label(a[1].mesh))(assembly.Assembler.build.__func__)))
        self._everywhere(transfer, "transfer", self.op(
            "transfer", lambda a: f"{label(a[0].sheet_mesh)} -> {label(a[2].sheet_mesh)}"))

    def curve_stages(self):
        from skfem_sheet.engine import curves, fold
        from skfem_sheet.foldcurve import cusp, refine, trace
        from skfem_sheet.sheet_shape import SheetShapeProblem

        self._everywhere(trace, "trace", self.stage(
            lambda *a, **k: "coarse trace" if k.get("seeds") else "trace"))
        self._everywhere(trace, "standout_fold", self.stage("standout fold"))
        self._everywhere(curves, "fold_curve", self.stage("fold curve"))
        self._replace(SheetShapeProblem, "solve_state",
                      self.stage("start solve")(SheetShapeProblem.solve_state))
        self._everywhere(refine, "refine", self.stage(
            lambda *a, **k: f"refine at hmax {a[3].hmax:g}"))
        self._everywhere(refine, "continue_to_end", self.stage("end continued on the mesh"))
        self._everywhere(cusp, "cusp_by_coefficient", self.stage("cusp on the fine mesh"))
        self._everywhere(fold, "inertia_crossing", self.stage("inertia check"))

    def close(self):
        for owner, name, old in reversed(self._undo):
            setattr(owner, name, old)
        self._undo = []

    def as_dict(self):
        return {"ops": [[s, lv, op, c, t] for (s, lv, op), (c, t) in sorted(self.ops.items())],
                "stages": [[s, c, t] for s, (c, t) in sorted(self.stages.items())]}


@contextlib.contextmanager
def recording(curve=False):
    rec = Recorder()
    rec.install()
    if curve:
        rec.curve_stages()
    try:
        yield rec
    finally:
        rec.close()


# -- tables ---------------------------------------------------------------------------------
def _top(stage):
    """The stage a path is booked under in the summaries: its first two parts."""
    parts = stage.split(" > ")
    return " > ".join(parts[:2])


OPS = ("factorisation", "back-substitution", "residual", "tangent", "assembly (other)",
       "mapped space", "space built", "assembler built", "mesh", "transfer")


def stage_table(prof, wall=None):
    """Lines: per stage (two levels deep) its own wall (without its sub-stages'),
    per operation the count and seconds booked to it (and to its deeper
    stages), and the rest (Python, the bordered solves' dense algebra); then
    per level (mesh) the operations over all stages."""
    ops = prof["ops"]
    incl = defaultdict(float)
    for s, _c, t in prof["stages"]:
        if len(s.split(" > ")) <= 2:
            incl[s] += t
    booked = defaultdict(lambda: defaultdict(lambda: [0, 0.0]))
    for s, _lv, op, c, t in ops:
        booked[_top(s)][op][0] += c
        booked[_top(s)][op][1] += t
    own = {}
    for s, t in incl.items():
        depth = len(s.split(" > "))
        own[s] = t - sum(t2 for s2, t2 in incl.items() if s2.startswith(s + " > ")
                         and len(s2.split(" > ")) == depth + 1)
    lines = ["  stage (own wall, booked operations: count and s)  "
             + "".join(f"{n[:13]:>15s}" for n in OPS) + "    rest s",
             f"  {'':40s}  wall s  " + "".join(f"{'n      s':>15s}" for _ in OPS)]
    rows = sorted(set(booked) | set(own), key=lambda s: s.split(" > "))
    for s in rows:
        row = booked.get(s, {})
        w = own.get(s)
        ops_s = sum(v[1] for v in row.values())
        lines.append(f"  {s[:40]:40s} " + (f"{w:7.1f}" if w is not None else "      -") + "  "
                     + "".join(f"{row[n][0]:6d} {row[n][1]:8.1f}" if n in row else " " * 15
                               for n in OPS)
                     + (f" {w - ops_s:9.1f}" if w is not None else ""))
    by_level = defaultdict(lambda: defaultdict(lambda: [0, 0.0]))
    for _s, lv, op, c, t in ops:
        by_level[lv][op][0] += c
        by_level[lv][op][1] += t
    lines += ["", f"  {'by level (every stage)':40s}          "
              + "".join(f"{n[:13]:>15s}" for n in OPS) + "   s per factorisation"]
    for lv in sorted(by_level):
        row = by_level[lv]
        f = row.get("factorisation")
        lines.append(f"  {lv[:40]:40s}          " + "".join(
            f"{row[n][0]:6d} {row[n][1]:8.1f}" if n in row else " " * 15 for n in OPS)
            + (f"   {f[1] / f[0]:.3f}" if f and f[0] else ""))
    total = sum(t for *_, t in ops)
    if wall:
        lines.append(f"\n  operations {total:.1f} s of {wall:.1f} s wall "
                     f"({100 * total / wall:.0f}%); the rest is Python and the dense algebra "
                     f"of the bordered solves")
    return lines


def _load():
    try:
        return os.getloadavg()
    except OSError:
        return (float("nan"),) * 3


# -- parts ----------------------------------------------------------------------------------
def curve_point(curvature, quality="paper", rectangle=False):
    from skfem_sheet.figures.data import fold_curve_points

    pts = fold_curve_points(quality)
    want = "curvature" if rectangle else "tip_width"
    for p in pts:
        if p["second"] == want and abs(p["curvature"] - curvature) < 1e-9:
            return p
    from skfem_sheet.studies import foldmap
    s = pts[0]
    return foldmap.curve_points([] if rectangle else [curvature], hmax=s["hmax"],
                                rectangle_from=curvature if rectangle else None)[0]


def run_curve(point):
    """One fold curve's record under the recorder: ``(record, profile, wall, cpu)``."""
    from skfem_sheet.studies import foldmap

    rec = foldmap._empty_curve_record(point, foldmap._curve_key(point))
    with recording(curve=True) as r:
        t0, c0 = time.perf_counter(), time.process_time()
        foldmap._fill_curve_record(point, rec)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    keep = ("curvature", "second", "tip_width", "standout_length", "popup_length",
            "cusp_tip_width", "cusp_curvature", "cusp_length", "cusp_located", "bistable",
            "completed", "n_points", "factorizations", "remeshes", "message", "wall_time_s",
            "points")
    return {k: rec.get(k) for k in keep}, r.as_dict(), wall, cpu


def _curve_task(chunk):
    """A worker's task of the fig7 part (module level: the pool pickles it by name)."""
    out = []
    for p in chunk:
        rec, prof, wall, cpu = run_curve(p)
        out.append(dict(point=p, record=rec, profile=prof, wall_s=wall, cpu_s=cpu,
                        pid=os.getpid()))
    return out


def _name(rec):
    if rec["second"] == "curvature":
        return f"b/a {rec['tip_width']:g} in a/R from {rec['curvature']:g}"
    return f"a/R {rec['curvature']:g}"


def curve_lines(rec):
    cusp = rec.get("cusp_tip_width") if rec["second"] == "tip_width" else rec.get("cusp_curvature")
    return (f"  {_name(rec):28s} L1* {rec['standout_length']:.7f}  L0* {rec['popup_length']:.7f}  "
            f"cusp {cusp:.7f} (L {rec['cusp_length']:.7f})  {rec['n_points']} points, "
            f"{rec['factorizations']} factorisations, {rec['wall_time_s']:.1f} s")


def part_curve(args, out, lines):
    point = curve_point(args.curvature, args.quality, args.rectangle)
    if args.hmax:
        point = dict(point, hmax=args.hmax)
    rec, prof, wall, cpu = run_curve(point)
    out["curve"] = dict(point=point, record=rec, profile=prof, wall_s=wall, cpu_s=cpu)
    lines += [f"one fold curve, {args.quality} quality settings, hmax {point['hmax']:g}: "
              f"{wall:.1f} s wall, {cpu:.1f} s CPU", curve_lines(rec), f"  {rec['message']}", ""]
    lines += stage_table(prof, wall)


def _sum_profiles(profiles):
    ops, stages = defaultdict(lambda: [0, 0.0]), defaultdict(lambda: [0, 0.0])
    for p in profiles:
        for s, lv, op, c, t in p["ops"]:
            ops[(s, lv, op)][0] += c
            ops[(s, lv, op)][1] += t
        for s, c, t in p["stages"]:
            stages[s][0] += c
            stages[s][1] += t
    return {"ops": [[s, lv, op, c, t] for (s, lv, op), (c, t) in sorted(ops.items())],
            "stages": [[s, c, t] for s, (c, t) in sorted(stages.items())]}


def part_fig7(args, out, lines):
    from skfem_sheet.figures.data import fold_curve_points
    from skfem_sheet.studies import foldmap
    from skfem_sheet.studies.runner import pool

    points = fold_curve_points(args.quality)
    chunks = foldmap._curve_chunks(points, args.workers)
    t0 = time.perf_counter()
    done = []
    for recs in pool(chunks, args.workers, _curve_task, lambda p, m, e: None):
        for r in recs:
            if r is None:
                continue
            r["finished_s"] = time.perf_counter() - t0
            done.append(r)
            print(f"{r['finished_s']:7.0f} s  {curve_lines(r['record'])}", flush=True)
    elapsed = time.perf_counter() - t0
    walls = sum(r["wall_s"] for r in done)
    cpus = sum(r["cpu_s"] for r in done)
    out["fig7"] = dict(elapsed_s=elapsed, workers=args.workers, curves=done,
                       sum_walls_s=walls, sum_cpu_s=cpus)
    lines += [f"Fig. 7's {len(points)} fold curves ({args.quality}) on {args.workers} workers: "
              f"elapsed {elapsed:.1f} s; the curves' walls sum to {walls:.1f} s "
              f"(ideal on {args.workers}: {walls / args.workers:.1f} s), CPU {cpus:.1f} s", ""]
    lines.append("  curve (in the order run)       finished   wall s   CPU s  fact   coarse  fine "
                 "levels (factorisations)")
    for r in done:
        rec = r["record"]
        lines.append(f"  {_name(rec):30s} {r['finished_s']:8.0f} {r['wall_s']:8.1f} "
                     f"{r['cpu_s']:7.1f} {rec['factorizations']:5d}   {rec['message'][:90]}")
    lines += ["", "  every curve, its fold lengths and cusp:"]
    lines += [curve_lines(r["record"]) for r in done]
    lines += ["", "  the 18 curves' stages and operations summed:"]
    lines += stage_table(_sum_profiles([r["profile"] for r in done]), walls)


def part_row(args, out, lines):
    from skfem_sheet.figures.data import map_grid_points
    from skfem_sheet.studies import foldmap

    pts = map_grid_points(args.quality, lambda c, b: abs(c - args.curvature) < 1e-9
                          and abs(b - args.tip_width) < 1e-9)
    if not pts:
        raise SystemExit(f"no map point b/a {args.tip_width:g}, a/R {args.curvature:g} in "
                         f"the {args.quality} grid")
    point = pts[0]
    rec = foldmap._empty_record(point, foldmap.map_key(point))
    with recording() as r:
        t0, c0 = time.perf_counter(), time.process_time()
        foldmap._fill_map_record(point, rec)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    keep = ("tip_width", "curvature", "popup_length", "standout_length", "bistable",
            "newton_iterations", "wall_time_s", "message")
    out["row"] = dict(point=point, record={k: rec.get(k) for k in keep}, profile=r.as_dict(),
                      wall_s=wall, cpu_s=cpu)
    lines += [f"one fold-map row, {args.quality} quality: b/a {args.tip_width:g}, "
              f"a/R {args.curvature:g}, hmax {point['hmax']:g}: {wall:.1f} s wall, {cpu:.1f} s "
              f"CPU; L0* {rec['popup_length']}, L1* {rec['standout_length']}, "
              f"{rec['newton_iterations']} Newton iterations", ""]
    lines += stage_table(r.as_dict(), wall)


def part_solve(args, out, lines):
    from skfem_sheet import Sheet, solve

    paths = ["curvature-first", "gravity-first"] if args.path == "both" else [args.path]
    out["solve"] = []
    sheet = Sheet(length=args.length, tip_width=args.tip_width, curvature=args.curvature)
    solve(Sheet(length=1.0, curvature=1.0), hmax=0.2)  # imports and first-call costs
    for path in paths:
        with recording() as r:
            t0 = time.perf_counter()
            res = solve(sheet, path=path, hmax=args.hmax)
            wall = time.perf_counter() - t0
        prof = r.as_dict()
        fine = f"hmax {args.hmax:g}"
        lin = sum(t for s, lv, op, c, t in prof["ops"] if lv == fine
                  and op in ("factorisation", "back-substitution"))
        nfact = sum(c for s, lv, op, c, t in prof["ops"] if lv == fine and op == "factorisation")
        out["solve"].append(dict(path=path, wall_s=wall, wall_time_s=res.wall_time_s,
                                 d=res.deflection, factorizations=res.factorizations,
                                 fine_linear_s=lin, fine_factorizations=nfact, profile=prof))
        lines += [f"solve L/a {args.length:g}, b/a {args.tip_width:g}, a/R {args.curvature:g}, "
                  f"{path}, hmax {args.hmax:g}: wall_time_s {res.wall_time_s:.2f} s (call "
                  f"{wall:.2f} s), d/a {res.deflection:.6f}, {res.factorizations} "
                  f"factorisations; the fine linear solver {lin:.2f} s ({nfact} fine "
                  f"factorisations), outside it {res.wall_time_s - lin:.2f} s "
                  f"({100 * (1 - lin / res.wall_time_s):.0f}%)", ""]
        lines += stage_table(prof, wall) + [""]


def _newest(pattern):
    files = sorted(glob.glob(pattern), key=os.path.getmtime)
    return files[-1] if files else None


def _longest_s(text):
    """The seconds of a summary's ``longest`` text, ``"b/a 1, a/R 5 (770 s)"`` -> 770."""
    try:
        return float(text.rsplit("(", 1)[1].split()[0])
    except (IndexError, ValueError):
        return 0.0


def paper_phases(rec, curves=None):
    """The recorded ``figure all`` run as phases: ``[(name, tasks, sum_s, longest_s,
    where)]`` in the order run, ``where`` one of "workers" (the fold map's and the
    fold curves' computed units: a batch the next step waits for), "here" (the
    ribbon model, drawing: this process) and "beside" (the side process's figures,
    one after the other, in parallel with the rest).  ``curves``: a ``fig7`` part's
    record replacing the fold curves' phase (its curves' walls)."""
    phases = []
    beside = set(rec.get("beside") or ())
    for f in rec["figures"]:
        if f["name"] in beside:
            phases.append((f["name"], 1, f["wall_time_s"], f["wall_time_s"], "beside"))
            continue
        steps = f.get("steps", [])
        spent = 0.0
        for st in steps:
            spent += st["wall_time_s"]
            if st.get("computed") and st.get("compute_s") and st["what"] in ("fold map",
                                                                             "fold curves"):
                n, tot, top = st["computed"], st["compute_s"], _longest_s(st.get("longest", ""))
                if st["what"] == "fold curves" and curves is not None:
                    walls = [c["wall_s"] for c in curves["curves"]]
                    n, tot, top = len(walls), sum(walls), max(walls)
                phases.append((f"{f['name']}: {st['what']}", n, tot, top, "workers"))
            elif st["wall_time_s"] > 1.0:
                phases.append((f"{f['name']}: {st['what']}", 1, st["wall_time_s"],
                               st["wall_time_s"], "here"))
        rest = f["wall_time_s"] - spent
        if rest > 1.0:
            phases.append((f"{f['name']}: drawing", 1, rest, rest, "here"))
    return phases


def model_lines(phases, workers=(1, 2, 4, 8, 16, 32, 64)):
    """The paper's wall on N workers: each phase on the workers takes ``max(sum / N,
    longest)`` (a greedy schedule, the costliest first, ends within ``longest`` of
    ``sum / N``), the phases here their recorded walls, one after the other; the side
    process runs beside them: ``max(side, sum of the phases)``.  With unlimited
    workers every phase is its longest task: the critical path."""
    lines = ["  phase                                   tasks   sum s  longest s    "
             + "".join(f"N={n:<6d}" for n in workers)]
    total = [0.0] * len(workers)
    side = 0.0
    crit = 0.0
    for name, n, tot, top, where in phases:
        if where == "beside":
            side += tot
            cells = "".join(f"{'(beside)':8s}" for _ in workers)
        else:
            t = [max(tot / k, top) if where == "workers" else tot for k in workers]
            total = [a + b for a, b in zip(total, t)]
            crit += top
            cells = "".join(f"{x:<8.0f}" for x in t)
        lines.append(f"  {name[:38]:38s} {n:6d} {tot:7.0f} {top:9.0f}    {cells}")
    lines.append(f"  {'side process (fig3, supplement)':38s} {'':6s} {side:7.0f} {'':9s}    "
                 + "".join(f"{side:<8.0f}" for _ in workers))
    lines.append(f"  {'the paper: max(side, phases)':38s} {'':6s} {'':7s} {'':9s}    "
                 + "".join(f"{max(side, t):<8.0f}" for t in total))
    lines.append(f"  critical path (unlimited workers): {max(side, crit):.0f} s")
    return lines


def part_paper(args, out, lines):
    """The recorded run per figure and step, and the model of the paper on N workers."""
    path = args.record or _newest(os.path.join(OUT, "figure_all_paper_*.json"))
    with open(path) as fh:
        rec = json.load(fh)
    curves = None
    if args.curves:
        with open(args.curves) as fh:
            curves = json.load(fh)["fig7"]
    lines += [f"recorded figure all --quality paper: {os.path.relpath(path)} "
              f"(elapsed {rec['elapsed_s']:.0f} s, workers {rec['workers']}; beside: "
              f"{', '.join(rec.get('beside') or []) or 'none'})", "",
              "  figure / data step                 wall s   computed  units' walls s  longest"]
    for f in rec["figures"]:
        lines.append(f"  {f['name']:34s} {f['wall_time_s']:7.1f}")
        for st in f.get("steps", []):
            cs = st.get("compute_s")
            lines.append(f"    {st['what']:32s} {st['wall_time_s']:7.1f}   "
                         f"{st.get('computed', 0):8d}  "
                         f"{cs if cs is not None else float('nan'):14.1f}  "
                         f"{st.get('longest', '')}")
    phases = paper_phases(rec, curves)
    src = f", the fold curves from {os.path.relpath(args.curves)}" if curves else ""
    lines += ["", f"the model of the paper's wall on N workers (s){src}; local processes "
              "(each batch in turn, as figure all runs them there):"]
    lines += model_lines(phases)
    merged = merge_rows_and_curves(phases)
    lines += ["", "on a Dask cluster (the fold curves in the batch of fig2's and fig4's rows):"]
    lines += model_lines(merged)
    out["paper"] = dict(record=path, curves=args.curves, phases=phases, cluster=merged)


def merge_rows_and_curves(phases):
    """``phases`` with fig7's fold curves in the batch of the shared rows (as
    ``figure all`` runs them on a Dask cluster)."""
    rows = [k for k, ph in enumerate(phases) if ph[0].endswith("-rows: fold map")]
    curves = [k for k, ph in enumerate(phases) if ph[0] == "fig7: fold curves"]
    if not rows or not curves:
        return list(phases)
    (i,), (j,) = rows[:1], curves[:1]
    a, b = phases[i], phases[j]
    both = (f"{a[0].split(':')[0]}+curves: rows and curves", a[1] + b[1], a[2] + b[2],
            max(a[3], b[3]), "workers")
    return [both if k == i else ph for k, ph in enumerate(phases) if k != j]


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("part", choices=("curve", "fig7", "row", "solve", "paper"))
    ap.add_argument("values", nargs="*", type=float,
                    help="curve: A_R; row: B A_R")
    ap.add_argument("--quality", default="paper", choices=("quick", "paper"))
    ap.add_argument("--rectangle", action="store_true", help="curve: the curve in (L, a/R)")
    ap.add_argument("--hmax", type=float, default=None,
                    help="curve: another fine mesh; solve: the mesh (default 0.03)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--length", type=float, default=1.3)
    ap.add_argument("--tip-width", type=float, default=1.0)
    ap.add_argument("--curvature", type=float, default=2.5)
    ap.add_argument("--path", default="both",
                    choices=("both", "curvature-first", "gravity-first"))
    ap.add_argument("--record", default=None, help="paper: a figure_all_paper_*.json")
    ap.add_argument("--curves", default=None,
                    help="paper: a fig7 part's JSON, whose curves replace the recorded ones")
    ap.add_argument("--txt", default=None)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    if args.part == "curve":
        if len(args.values) != 1:
            ap.error("curve takes one value, A_R")
        args.curvature = args.values[0]
    if args.part == "row":
        if len(args.values) != 2:
            ap.error("row takes two values, B A_R")
        args.tip_width, args.curvature = args.values
    if args.part == "solve" and args.hmax is None:
        args.hmax = 0.03
    load = _load()
    out = dict(machine=machine_info(), argv=sys.argv[1:], part=args.part)
    lines = ["python benchmarks/speed_profile.py " + " ".join(sys.argv[1:] if argv is None
                                                               else argv),
             f"{time.strftime('%Y-%m-%d %H:%M:%S %Z')}, load average at start "
             + ", ".join(f"{x:.2f}" for x in load)
             + f" on {os.cpu_count()} cores; OMP_NUM_THREADS="
             + os.environ.get("OMP_NUM_THREADS", "unset"), ""]
    {"curve": part_curve, "fig7": part_fig7, "row": part_row, "solve": part_solve,
     "paper": part_paper}[args.part](args, out, lines)
    end = _load()
    lines += ["", "load average at the end " + ", ".join(f"{x:.2f}" for x in end)]
    out["load_at_end"] = list(end)
    text = "\n".join(lines)
    print(text)
    if args.txt:
        with open(args.txt, "w") as fh:
            fh.write(text + "\n")
    if args.json:
        from skfem_sheet.io import dumps_json
        with open(args.json, "w") as fh:
            fh.write(dumps_json(out) + "\n")


if __name__ == "__main__":
    main()
