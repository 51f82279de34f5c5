"""Batch jobs over a folder of clips, on Dask: one saved session applied to every clip, or staggered poses of
every clip into one Parquet table.

Command line (``python -m stagger_nb``)::

    python -m stagger_nb batch SESSION.json INPUT_DIR OUTPUT_DIR [--scheduler ADDRESS] [--workers N]
    python -m stagger_nb extract-poses INPUT_DIR OUT.parquet [--scheduler ADDRESS] [--workers N]

Clips are ``*.bvh`` files and CMU ``*.amc`` motions (read with the ``*.asf`` of the same folder: ``NN.asf``
for ``NN_MM.amc``, else the folder's only ``.asf``), found recursively and processed in sorted order.

Executors (``executor=``): ``"serial"`` (this process, the reference), ``"processes"`` (``dask.bag`` over the
paths on Dask's multiprocessing scheduler), ``"distributed"`` (``distributed.Client.map``: a ``LocalCluster`` of
worker processes with one thread each, or the running scheduler named by ``scheduler=``). Every executor runs
the same task function, so outputs are identical bit for bit.

Guarantees:

- a failing clip never stops the run: it is recorded in the report (``file``, ``line`` for a parse error,
  ``error``) and the others go on;
- outputs are written atomically (:func:`stagger_nb.io._common.atomic_write_bytes`) and never over an input
  (an output path that is an input file is an error for that clip; OUTPUT_DIR may not be INPUT_DIR);
- a re-run skips finished clips: a manifest in the output (``.stagger_nb_manifest.json``) maps each clip to
  the SHA-256 of its input bytes and of the job (session ops / extraction options); only clips whose key
  changed, or whose output is missing, run again;
- a progress bar (tqdm) counts clips done;
- inner threads are pinned to one per worker (``OMP/OPENBLAS/MKL_NUM_THREADS=1`` in the environment of
  worker processes the batch starts, and ``threadpoolctl.threadpool_limits(1)`` inside every task) so that
  N workers use N cores, not N x cores.
"""
from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import os
import resource
import socket
import time
import traceback
from dataclasses import dataclass, field

__all__ = ["find_clips", "run_session_batch", "run_extract_poses", "BatchResult", "MANIFEST", "REPORT_JSON",
           "REPORT_CSV", "THREAD_ENV"]

MANIFEST = ".stagger_nb_manifest.json"
REPORT_JSON = "batch_report.json"
REPORT_CSV = "batch_report.csv"
#: Environment given to the worker processes a batch starts: one BLAS / OpenMP thread each.
THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "VECLIB_MAXIMUM_THREADS": "1", "NUMEXPR_NUM_THREADS": "1"}
_EXECUTORS = ("serial", "processes", "distributed")


# --------------------------------------------------------------------------------------------------
# finding and reading clips
# --------------------------------------------------------------------------------------------------
def _asf_for(amc: str) -> str | None:
    folder, name = os.path.split(amc)
    asfs = sorted(f for f in os.listdir(folder) if f.lower().endswith(".asf"))
    subject = name.split("_")[0].lower()
    for f in asfs:
        if os.path.splitext(f)[0].lower() == subject:
            return os.path.join(folder, f)
    return os.path.join(folder, asfs[0]) if len(asfs) == 1 else None


def find_clips(input_dir, exclude=None) -> list[str]:
    """Relative paths (``/``-separated, sorted) of the ``.bvh`` and ``.amc`` files under ``input_dir``;
    ``exclude`` (a folder) is skipped, e.g. an output folder inside the input folder."""
    root = os.path.abspath(os.fspath(input_dir))
    if not os.path.isdir(root):
        raise ValueError(f"input_dir: {input_dir} is not a folder")
    skip = os.path.realpath(exclude) if exclude is not None else None
    found = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith(".")
                         and os.path.realpath(os.path.join(folder, d)) != skip)
        for f in files:
            if f.lower().endswith((".bvh", ".amc")) and not f.startswith("."):
                found.append(os.path.relpath(os.path.join(folder, f), root).replace(os.sep, "/"))
    return sorted(found)


def read_clip(path: str):
    """The Motion of a ``.bvh`` file, or of a ``.amc`` file with its folder's ``.asf``."""
    from ..io import read_asf_amc, read_bvh
    if path.lower().endswith(".amc"):
        asf = _asf_for(path)
        if asf is None:
            raise ValueError(f"{path}: no .asf skeleton beside it (NN.asf for NN_MM.amc, or one .asf)")
        return read_asf_amc(asf, path)
    return read_bvh(path)


def _sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


# --------------------------------------------------------------------------------------------------
# the task run on a worker
# --------------------------------------------------------------------------------------------------
_PINNED = False


def _pin_threads() -> None:
    """One BLAS/OpenMP thread in this worker process (once per process)."""
    global _PINNED
    if not _PINNED:
        from threadpoolctl import threadpool_limits
        threadpool_limits(1)
        _PINNED = True


def _run_task(task: dict) -> dict:
    """Run one clip; never raises: ``{"file", "ok", "output", "line", "error", "seconds"}``."""
    _pin_threads()
    t0 = time.perf_counter()
    res = {"file": task["rel"], "ok": False, "output": task["out_rel"], "line": None, "error": None}
    try:
        if task["kind"] == "session":
            _task_session(task)
        else:
            _task_poses(task)
        res["ok"] = True
    except Exception as e:  # noqa: BLE001 - recorded per file, the run goes on
        res["line"] = getattr(e, "line", None)
        res["error"] = f"{type(e).__name__}: {e}" if not isinstance(e, ValueError) else str(e)
        if not isinstance(e, ValueError):
            res["error"] += " | " + traceback.format_exc(limit=3).strip().splitlines()[-2].strip()
    res["seconds"] = time.perf_counter() - t0
    res["pid"] = f"{socket.gethostname()}:{os.getpid()}"
    res["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB
    return res


def _task_session(task: dict) -> None:
    from ..session import Session
    motion = read_clip(task["input"])
    s = Session(motion, ops=task["ops"], extract_options=task["extract_options"] or None)
    os.makedirs(os.path.dirname(task["output"]), exist_ok=True)
    s.export_bvh(task["output"])


def _pose_schema():
    import pyarrow as pa
    return pa.schema([("clip", pa.string()), ("pose", pa.int32()), ("pose_time", pa.float64()),
                      ("priority", pa.float64()), ("probability", pa.float64()),
                      ("refinements", pa.list_(pa.float64())), ("fit_residual", pa.float64())])


def pose_table(motion, clip: str, **extract_options):
    """``pyarrow.Table`` of the staggered poses of ``motion`` (Coleman et al. 2008, §4): one row per pose with
    ``clip``, ``pose`` (index k), ``pose_time`` (s), ``priority`` (``w_k = P(t_k)(t_{k+1} - t_{k-1})``, inf at
    the ends, §4.1), ``probability`` (``P(t_k)``), ``refinements`` (list of J seconds, ``r_{k,i}``),
    ``fit_residual`` (rad: RMS angle of the displacement maps, §4.1.1, over the segment starting at the pose; the
    last pose takes the segment ending at it)."""
    import numpy as np
    import pyarrow as pa

    from .. import staggered
    sm = staggered.extract(motion, **extract_options)
    K = len(sm.pose_times)
    prio = staggered.pose_priorities(sm.pose_times, sm.pose_probability)
    d = np.asarray(sm.displacements)                     # (K-1, J, M, 3) rotation vectors
    counts = np.asarray(sm.displacement_counts)          # (K-1, J)
    ang2 = np.einsum("pjmc,pjmc->pjm", d, d)
    valid = np.arange(d.shape[2])[None, None, :] < counts[..., None]
    seg = np.sqrt((ang2 * valid).sum(axis=(1, 2)) / np.maximum(valid.sum(axis=(1, 2)), 1))  # (K-1,)
    resid = np.append(seg, seg[-1]) if K > 1 else np.zeros(K)
    return pa.table({"clip": [clip] * K, "pose": np.arange(K, dtype=np.int32),
                     "pose_time": np.asarray(sm.pose_times, float), "priority": np.asarray(prio, float),
                     "probability": np.asarray(sm.pose_probability, float),
                     "refinements": [list(map(float, r)) for r in np.asarray(sm.refinements)],
                     "fit_residual": resid.astype(float)}, schema=_pose_schema())


def _table_bytes(table) -> bytes:
    import pyarrow.parquet as pq
    buf = io.BytesIO()
    pq.write_table(table, buf)
    return buf.getvalue()


def _task_poses(task: dict) -> None:
    from ..io._common import atomic_write_bytes
    motion = read_clip(task["input"])
    table = pose_table(motion, task["rel"], **(task["extract_options"] or {}))
    os.makedirs(os.path.dirname(task["output"]), exist_ok=True)
    atomic_write_bytes(task["output"], _table_bytes(table))


# --------------------------------------------------------------------------------------------------
# executors
# --------------------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------------------
# the driver
# --------------------------------------------------------------------------------------------------
@dataclass
class BatchResult:
    """What a run did: ``done`` (relative paths run now and written), ``skipped`` (finished in an earlier run),
    ``failed`` (report rows: file, line, error), ``seconds`` (wall time), ``report`` (report JSON path),
    ``worker_peak_mb`` ({"host:pid": peak resident MB of that worker process} over the clips it ran)."""
    done: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: list = field(default_factory=list)
    seconds: float = 0.0
    report: str = ""
    worker_peak_mb: dict = field(default_factory=dict)


def _load_manifest(path: str) -> dict:
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def _dump_json(path: str, data) -> None:
    from ..io._common import atomic_write_bytes
    atomic_write_bytes(path, json.dumps(data, indent=1, sort_keys=True, allow_nan=False).encode("utf-8"))


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
    manifest = _load_manifest(manifest_path)
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
    _dump_json(manifest_path, manifest)
    result.seconds = time.perf_counter() - t0
    report = {"input_dir": in_root, "output": out_root, "executor": executor, "scheduler": scheduler,
              "workers": workers, "clips": len(rels), "done": result.done, "skipped": result.skipped,
              "failed": result.failed, "seconds": round(result.seconds, 3),
              "worker_peak_mb": {k: round(v, 1) for k, v in result.worker_peak_mb.items()}}
    result.report = os.path.join(out_root, REPORT_JSON)
    _dump_json(result.report, report)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=["file", "line", "error"])
    w.writeheader()
    w.writerows(result.failed)
    from ..io._common import atomic_write_bytes
    atomic_write_bytes(os.path.join(out_root, REPORT_CSV), buf.getvalue().encode("utf-8"))
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
    manifest = _load_manifest(os.path.join(parts, MANIFEST))
    tables = [pq.read_table(os.path.join(parts, manifest[rel]["output"]))
              for rel in sorted(res.done + res.skipped) if rel in manifest]
    table = pa.concat_tables(tables) if tables else _pose_schema().empty_table()
    atomic_write_bytes(out_path, _table_bytes(table))
    return res
