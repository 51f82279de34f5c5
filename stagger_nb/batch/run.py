"""Running a batch: the executors (serial, ``dask.bag`` processes, ``distributed``) and the driver behind
:func:`run_session_batch` and :func:`run_extract_poses` (which clips run, which are skipped, what is recorded)."""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import time

from .discover import _sha256_file, find_clips
from .report import MANIFEST, BatchResult, dump_json, load_manifest, write_reports
from .tasks import _pose_schema, _run_task, _table_bytes

__all__ = ["run_session_batch", "run_extract_poses", "THREAD_ENV"]

#: Environment given to the worker processes a batch starts: one BLAS / OpenMP thread each.
THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "VECLIB_MAXIMUM_THREADS": "1", "NUMEXPR_NUM_THREADS": "1"}
_EXECUTORS = ("serial", "processes", "distributed")


@contextlib.contextmanager
def _thread_env():
    """THREAD_ENV set while worker processes start (they inherit it), then restored."""
    old = {k: os.environ.get(k) for k in THREAD_ENV}
    os.environ.update(THREAD_ENV)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _execute(tasks: list, executor: str, workers: int, scheduler: str | None, progress: bool, timeout: float | None):
    """Results of ``_run_task`` over ``tasks`` (any order)."""
    from tqdm.auto import tqdm
    bar = tqdm(total=len(tasks), desc="clips", unit="clip", disable=not progress)
    results = []
    try:
        if executor == "serial" or not tasks:
            for t in tasks:
                results.append(_run_task(t))
                bar.update(1)
        elif executor == "processes":
            import dask.bag as db
            from dask.diagnostics import Callback

            class _Bar(Callback):  # one tick per finished clip task
                def _posttask(self, key, result, dsk, state, worker_id):
                    if isinstance(result, list) and all(isinstance(r, dict) and "seconds" in r for r in result):
                        bar.update(len(result))   # a finished partition (one clip each)

            with _thread_env(), _Bar():
                bag = db.from_sequence(tasks, npartitions=len(tasks)).map(_run_task)
                results = bag.compute(scheduler="processes", num_workers=workers)
            bar.n = len(results)
            bar.refresh()
        else:
            from distributed import Client, LocalCluster, as_completed
            with contextlib.ExitStack() as stack:
                if scheduler:
                    client = stack.enter_context(Client(scheduler, timeout=timeout or 30))
                else:
                    with _thread_env():
                        cluster = stack.enter_context(LocalCluster(
                            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                            env=dict(THREAD_ENV)))
                    client = stack.enter_context(Client(cluster, timeout=timeout or 30))
                futures = client.map(_run_task, tasks, pure=False)
                for fut in as_completed(futures, timeout=timeout):
                    results.append(fut.result())
                    bar.update(1)
    finally:
        bar.close()
    return results


def _run(kind: str, job: dict, input_dir, out_root: str, out_name, *, executor, workers, scheduler, progress,
         timeout) -> BatchResult:
    if executor not in _EXECUTORS:
        raise ValueError(f"executor: expected one of {', '.join(_EXECUTORS)}, got {executor!r}")
    if scheduler and executor != "distributed":
        executor = "distributed"
    in_root = os.path.abspath(os.fspath(input_dir))
    if os.path.realpath(in_root) == os.path.realpath(out_root):
        raise ValueError(f"output: {out_root} is the input folder; choose another folder (inputs are never replaced)")
    t0 = time.perf_counter()
    rels = find_clips(in_root, exclude=out_root)
    job_hash = hashlib.sha256(json.dumps(job, sort_keys=True).encode()).hexdigest()
    os.makedirs(out_root, exist_ok=True)
    manifest_path = os.path.join(out_root, MANIFEST)
    manifest = load_manifest(manifest_path)
    inputs = {os.path.realpath(os.path.join(in_root, r)) for r in rels}
    result, tasks, keys = BatchResult(), [], {}
    for rel in rels:
        src = os.path.join(in_root, rel)
        out_rel = out_name(rel)
        out = os.path.join(out_root, out_rel)
        try:
            key = {"input_sha256": _sha256_file(src), "job_sha256": job_hash}
        except OSError as e:
            result.failed.append({"file": rel, "line": None, "error": f"cannot read: {e.strerror or e}"})
            continue
        if os.path.realpath(out) in inputs:
            result.failed.append({"file": rel, "line": None, "error": f"output {out} is an input file; not written"})
            continue
        if manifest.get(rel, {}).get("key") == key and os.path.isfile(out):
            result.skipped.append(rel)
            continue
        keys[rel] = key
        tasks.append({"kind": kind, "rel": rel, "input": src, "output": out, "out_rel": out_rel, **job})
    for r in sorted(_execute(tasks, executor, workers, scheduler, progress, timeout), key=lambda r: r["file"]):
        result.worker_peak_mb[r["pid"]] = max(result.worker_peak_mb.get(r["pid"], 0.0), r["peak_rss_mb"])
        if r["ok"]:
            result.done.append(r["file"])
            manifest[r["file"]] = {"key": keys[r["file"]], "output": r["output"]}
        else:
            manifest.pop(r["file"], None)
            result.failed.append({"file": r["file"], "line": r["line"], "error": r["error"]})
    result.failed.sort(key=lambda row: row["file"])
    dump_json(manifest_path, manifest)
    result.seconds = time.perf_counter() - t0
    report = {"input_dir": in_root, "output": out_root, "executor": executor, "scheduler": scheduler,
              "workers": workers, "clips": len(rels), "done": result.done, "skipped": result.skipped,
              "failed": result.failed, "seconds": round(result.seconds, 3),
              "worker_peak_mb": {k: round(v, 1) for k, v in result.worker_peak_mb.items()}}
    result.report = write_reports(out_root, report, result.failed)
    return result


def run_session_batch(session_path, input_dir, output_dir, *, executor="distributed", workers=2,
                      scheduler: str | None = None, progress=True, timeout: float | None = None) -> BatchResult:
    """Apply the ops of the saved session ``session_path`` to every clip under ``input_dir``; write each edited
    clip as BVH to ``output_dir``, mirroring the folder layout (``a/b.amc`` -> ``a/b.bvh``).

    The session's own source clip is not needed (its ops are what is applied); ``scheduler`` names a running
    ``distributed`` scheduler (``tcp://host:8786``), otherwise ``executor`` decides. Returns a
    :class:`BatchResult`; the report (``batch_report.json`` / ``.csv``) lists every failed clip with its line.
    """
    from ..session import Session
    try:
        session = Session.load(session_path)
    except ValueError as e:
        if "source" not in str(e):
            raise
        from .. import data
        session = Session.load(session_path, source=data.load("walk").slice(0, 2))  # the source is not used
    job = {"ops": session.ops, "extract_options": dict(getattr(session, "extract_options", None) or {})}
    out_root = os.path.abspath(os.fspath(output_dir))
    in_root = os.path.abspath(os.fspath(input_dir))

    def out_name(rel: str) -> str:  # a/b.amc -> a/b.bvh, or a/b.amc.bvh when a/b.bvh is an input too
        stem = os.path.splitext(rel)[0]
        if rel.lower().endswith(".amc") and os.path.exists(os.path.join(in_root, stem + ".bvh")):
            return rel + ".bvh"
        return stem + ".bvh"

    return _run("session", job, input_dir, out_root, out_name,
                executor=executor, workers=workers, scheduler=scheduler, progress=progress, timeout=timeout)


def run_extract_poses(input_dir, out_path, *, executor="distributed", workers=2, scheduler: str | None = None,
                      progress=True, timeout: float | None = None, **extract_options) -> BatchResult:
    """Staggered poses of every clip under ``input_dir`` into the one Parquet table ``out_path`` (columns of
    :func:`pose_table`, clips in sorted order). Per-clip tables are kept in ``OUT.parquet.parts/`` (with the
    manifest and report) so a re-run only extracts new or changed clips."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ..io._common import atomic_write_bytes
    out_path = os.path.abspath(os.fspath(out_path))
    if not out_path.endswith(".parquet"):
        raise ValueError(f"out_path: {out_path} must end in .parquet")
    parts = out_path + ".parts"
    res = _run("poses", {"extract_options": extract_options}, input_dir, parts,
               lambda rel: hashlib.sha256(rel.encode()).hexdigest()[:24] + ".parquet",
               executor=executor, workers=workers, scheduler=scheduler, progress=progress, timeout=timeout)
    manifest = load_manifest(os.path.join(parts, MANIFEST))
    tables = [pq.read_table(os.path.join(parts, manifest[rel]["output"]))
              for rel in sorted(res.done + res.skipped) if rel in manifest]
    table = pa.concat_tables(tables) if tables else _pose_schema().empty_table()
    atomic_write_bytes(out_path, _table_bytes(table))
    return res
