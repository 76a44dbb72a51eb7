"""A Dask worker process killed mid-sweep (studies.runner.execute on a LocalCluster).

Two worker processes (one thread each) compute cheap fake points.  One point,
the victim, computes its record and then holds it (sleeps) before returning:
the test kills that worker process with SIGKILL while it holds the finished
point (and possibly others queued on it).  Dask's nanny restarts the worker and the
scheduler resubmits the lost task; the victim is then computed a second time.
The sweep must finish with every point exactly once in the table and in the
journal: the journal is written by the client, from the results it receives,
so a record computed by a worker that died before handing it over is never
counted.
"""
import json
import os
import signal
import sys
import threading
import time

import pytest

distributed = pytest.importorskip("distributed")
cloudpickle = pytest.importorskip("cloudpickle")

import pandas as pd  # noqa: E402

from skfem_sheet.studies import runner  # noqa: E402

N_POINTS = 12
VICTIM = 5
HOLD_S = 120.0  # the victim's first run holds its result this long (it is killed long before)


def _key(x) -> str:
    return runner.hash_key([["x", x]])


def fake_task(points):
    """Records of ``points``: ``y = x**2``; writes a marker per computation."""
    out = []
    for p in points:
        x = p["x"]
        marks = p["marks"]
        first = not os.path.exists(os.path.join(marks, f"computed-{x}"))
        with open(os.path.join(marks, f"run-{x}-{os.getpid()}-{time.monotonic_ns()}"), "w"):
            pass
        rec = {"x": x, "y": x * x, "key": _key(x), "converged": True}
        if x == VICTIM and first:
            # computed, not yet returned: announce the pid that holds it, then wait to be killed
            tmp = os.path.join(marks, "victim.tmp")
            with open(tmp, "w") as f:
                f.write(str(os.getpid()))
            os.replace(tmp, os.path.join(marks, f"computed-{x}"))
            time.sleep(HOLD_S)
        else:
            time.sleep(0.05)
        out.append(runner.finish_record(rec))
    return out


def fake_failed(point, message, error):
    return {"x": point["x"], "key": _key(point["x"]), "converged": False, "message": message,
            "error": error}


def fake_frame(records):
    return runner.typed_frame(records, ["key", "x", "y", "converged", "pid"],
                              floats=("y",), ints=("x", "pid"), bools=("converged",))


JOB = runner.Job(task=fake_task, failed=fake_failed, frame=fake_frame,
                 key_of=lambda rec: _key(rec["x"]), required=("key", "x", "converged"),
                 desc="fault")


def _killer(marks, stop, killed):
    """Kill (SIGKILL) the worker process that holds the victim's finished record."""
    path = os.path.join(marks, f"computed-{VICTIM}")
    while not stop.is_set():
        if os.path.exists(path):
            pid = int(open(path).read())
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
            return
        time.sleep(0.02)


@pytest.fixture
def cluster():
    # the test module is pickled by value: the workers need not import it
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=50)
    client = distributed.Client(cluster, set_as_default=False)
    try:
        yield client
    finally:
        client.close()
        cluster.close()
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


def test_worker_killed_while_holding_a_point_counts_it_once(cluster, tmp_path):
    client = cluster
    marks = tmp_path / "marks"
    marks.mkdir()
    table = tmp_path / "fault.csv"
    points = [{"x": x, "marks": str(marks)} for x in range(N_POINTS)]
    keys = [_key(x) for x in range(N_POINTS)]
    worker_pids = set(client.run(os.getpid).values())
    assert len(worker_pids) == 2

    stop, killed = threading.Event(), []
    th = threading.Thread(target=_killer, args=(str(marks), stop, killed), daemon=True)
    th.start()
    t0 = time.monotonic()
    try:
        done, stats = runner.execute(
            points, keys, JOB, table=str(table), workers=None, scheduler=client,
            progress=False, retry_failed=False,
            chunker=lambda todo, n: [todo[i:i + 2] for i in range(0, len(todo), 2)])
    finally:
        stop.set()
        th.join(5)
    wall = time.monotonic() - t0
    assert wall < HOLD_S / 2, "the victim was not killed: the sweep waited for it"

    # the worker that held the point was killed, and the victim was computed twice
    assert len(killed) == 1 and killed[0] in worker_pids
    runs = [f.name.split("-") for f in marks.iterdir() if f.name.startswith("run-")]
    victim_runs = [r for r in runs if int(r[1]) == VICTIM]
    victim_pids = {int(r[2]) for r in victim_runs}
    assert len(victim_runs) == 2 and len(victim_pids) == 2 and killed[0] in victim_pids
    assert {int(r[1]) for r in runs} == set(range(N_POINTS))

    # every point exactly once: in the returned records, the journal and the table
    assert stats["new"] == N_POINTS and stats["points"] == N_POINTS
    assert sorted(done) == sorted(keys)
    lines = [json.loads(x) for x in open(runner.journal_path(table)).read().splitlines()]
    assert len(lines) == N_POINTS
    assert sorted(r["x"] for r in lines) == list(range(N_POINTS))
    assert all(r["converged"] and r["y"] == r["x"] ** 2 for r in lines)
    victim = next(r for r in lines if r["x"] == VICTIM)
    assert victim["pid"] != killed[0]  # the record came from the second computation
    df = pd.read_csv(table)
    assert len(df) == N_POINTS and df["key"].is_unique and set(df["key"]) == set(keys)
    assert sorted(df["x"]) == list(range(N_POINTS))
    assert (df["y"] == df["x"] ** 2).all() and df["converged"].all()

    # a second run resumes: nothing is computed again, nothing is appended
    done2, stats2 = runner.execute(points, keys, JOB, table=str(table), workers=None,
                                   scheduler=client, progress=False, retry_failed=False,
                                   chunker=lambda todo, n: [todo])
    assert stats2["new"] == 0 and stats2["cached"] == N_POINTS
    assert len(open(runner.journal_path(table)).read().splitlines()) == N_POINTS
