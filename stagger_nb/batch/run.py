"""Running a batch: the executors (serial, ``dask.bag`` processes, ``distributed``) and the driver behind
:func:`run_session_batch` and :func:`run_extract_poses`: which clips run, which are skipped, which outputs
may be written (never a file the manifest does not say the batch wrote, never through a symbolic link inside
OUT), and the order of what is recorded (the manifest naming every output about to be written, then a small
report, the clips, the manifest, the final report)."""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import stat
import time

from ..io._common import WriteError, atomic_write_bytes, read_confined
from .discover import clip_sha256, find_clips
from .report import REPORT_CSV, REPORT_JSON, BatchError, BatchResult, Manifest, report_failure, text_of, write_reports
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


def _output_folder(out_root) -> tuple[str, str]:
    """``(shown, real)``: OUT as named (absolute) and resolved; ``ValueError`` naming it when it exists and is
    not a folder. Not created here (nothing is written before every check has passed)."""
    shown = os.path.abspath(os.fspath(out_root))
    if os.path.lexists(shown) and not os.path.isdir(shown):
        raise ValueError(f"{shown}: exists and is not a folder; name a folder for the output")
    return shown, os.path.realpath(shown)


def _lstat(path: str):
    try:
        return os.lstat(path)
    except OSError:
        return None


def _run(kind: str, job: dict, input_dir, out_root: str, out_name, *, executor, workers, scheduler, progress,
         timeout, precheck=None) -> tuple[BatchResult, Manifest]:
    if executor not in _EXECUTORS:
        raise ValueError(f"executor: expected one of {', '.join(_EXECUTORS)}, got {executor!r}")
    if scheduler and executor != "distributed":
        executor = "distributed"
    in_root = os.path.abspath(os.fspath(input_dir))
    shown, out_real = _output_folder(out_root)
    if os.path.realpath(in_root) == out_real:
        raise ValueError(f"output: {shown} is the input folder; choose another folder (inputs are never replaced)")
    t0 = time.perf_counter()
    unlisted = []   # sub-folders that cannot be listed: failed rows, never left out silently
    rels = find_clips(in_root, exclude=out_real, unlisted=unlisted)
    manifest = Manifest.load(out_real, shown) if os.path.isdir(out_real) else Manifest(out_real, shown)
    for name in (REPORT_JSON, REPORT_CSV):
        st = _lstat(os.path.join(out_real, name))
        if st is not None and (name not in manifest.reports or not stat.S_ISREG(st.st_mode)):
            raise ValueError(f"{os.path.join(shown, name)}: exists and was not written by a batch (the manifest "
                             "does not list it); it is not replaced: move it or choose another output folder")
    if precheck is not None:
        precheck(manifest)
    try:
        os.makedirs(out_real, exist_ok=True)
    except OSError as e:
        raise ValueError(f"{shown}: cannot create the output folder: {e.strerror or e}") from None
    job_hash = hashlib.sha256(json.dumps(job, sort_keys=True).encode()).hexdigest()
    inputs = {os.path.realpath(os.path.join(in_root, r)) for r in rels}
    result, tasks, keys, before = BatchResult(), [], {}, {}
    result.failed += [{"file": rel, "line": None, "error": message} for rel, message in unlisted]
    for rel in rels:
        src = os.path.join(in_root, rel)
        out_rel = out_name(rel)
        out = os.path.join(out_real, out_rel)
        try:
            key = {"input_sha256": clip_sha256(src), "job_sha256": job_hash}
        except ValueError as e:
            result.failed.append({"file": rel, "line": None, "error": str(e)})
            continue
        if os.path.realpath(out) in inputs:
            result.failed.append({"file": rel, "line": None, "error": f"output {out} is an input file; not written"})
            continue
        entry, st = manifest.clips.get(rel), _lstat(out)
        if entry and entry["key"] == key and entry["output"] == out_rel and st and stat.S_ISREG(st.st_mode):
            result.skipped.append(rel)
            if entry.get("quality") is not None:
                result.quality[rel] = entry["quality"]
            continue
        replace = False
        if st is not None:
            shown_out = os.path.join(shown, out_rel)
            why = ("is a symbolic link; nothing is written through it" if stat.S_ISLNK(st.st_mode) else
                   "exists and is not a regular file; it is not replaced" if not stat.S_ISREG(st.st_mode) else
                   None if manifest.wrote(out_rel) else
                   "exists and was not written by this batch (its manifest does not list it, or the file changed "
                   "since); it is not replaced: move it, or choose another output folder")
            if why:
                result.failed.append({"file": rel, "line": None, "error": f"output {shown_out}: {why}"})
                continue
            replace = True
        keys[rel], before[rel] = key, entry
        # named before it is written: a run that dies leaves the manifest saying the batch may have written it
        manifest.clips[rel] = {"key": None, "output": out_rel, "output_sha256": None}
        tasks.append({"kind": kind, "rel": rel, "input": src, "out_root": out_real, "out_rel": out_rel,
                      "replace": replace, **job})
    manifest.reports = [REPORT_JSON, REPORT_CSV]
    report = {"status": "running: this report is replaced when the run ends; if it is still here, the run "
                        "did not end (stopped, or the disk filled)",
              "input_dir": in_root, "output": shown, "executor": executor, "scheduler": scheduler,
              "workers": workers, "clips": len(rels), "done": [], "skipped": result.skipped,
              "failed": sorted(result.failed, key=lambda row: row["file"]), "quality": dict(result.quality)}
    result.report = os.path.join(shown, REPORT_JSON)
    try:  # the manifest naming what is about to be written, then the first report: small, atomic
        manifest.save()
        write_reports(out_real, shown, report)
    except WriteError as e:
        _give_up(out_real, shown, report, result, str(e), "nothing was run")
    try:
        results = _execute(tasks, executor, workers, scheduler, progress, timeout)
    except Exception as e:
        _give_up(out_real, shown, report, result, f"the run stopped: {type(e).__name__}: {e}",
                 "the clips finished before it stopped are not recorded", cause=e)
    for r in sorted(results, key=lambda r: r["file"]):
        result.worker_peak_mb[r["pid"]] = max(result.worker_peak_mb.get(r["pid"], 0.0), r["peak_rss_mb"])
        rel = r["file"]
        if r["ok"]:
            result.done.append(rel)
            manifest.clips[rel] = {"key": keys[rel], "output": r["output"], "output_sha256": r["output_sha256"]}
            if r.get("quality") is not None:
                manifest.clips[rel]["quality"] = result.quality[rel] = r["quality"]
        else:
            old = before[rel]
            if old is not None:  # unchanged output (the task writes last): still the batch's, to be run again
                manifest.clips[rel] = dict(old, key=None)
            elif _lstat(os.path.join(out_real, r["output"])) is None:
                del manifest.clips[rel]
            result.failed.append({"file": rel, "line": r["line"], "error": r["error"]})
    result.failed.sort(key=lambda row: row["file"])
    result.seconds = time.perf_counter() - t0
    report.update(status="finished", done=result.done, failed=result.failed, seconds=round(result.seconds, 3),
                  quality={rel: result.quality[rel] for rel in sorted(result.quality)},
                  worker_peak_mb={k: round(v, 1) for k, v in result.worker_peak_mb.items()})
    errors = []
    try:
        manifest.save()
    except WriteError as e:
        errors.append(str(e))
    try:
        if not errors:
            write_reports(out_real, shown, report)
    except WriteError as e:
        errors.append(str(e))
    if errors:
        _give_up(out_real, shown, report, result, "; ".join(errors),
                 f"{len(result.done)} clips written, {len(result.failed)} failed")
    return result, manifest


def _give_up(out_real: str, shown: str, report: dict, result: BatchResult, why: str, what: str, cause=None):
    """Say ``why`` in the reports as far as the disk allows, then raise :class:`BatchError`."""
    said = os.path.isdir(out_real) and report_failure(out_real, shown, report, f"failed: {why}")
    where = (f"the report {result.report} says so" if said else "no report could be written")
    raise BatchError(f"{why}; {what}; {where}", result) from cause


def _load_session(session_path):
    from ..session import Session
    try:
        return Session.load(session_path)
    except ValueError as e:
        if "source" not in str(e).split(":", 1)[0]:
            raise
        from .. import data
        return Session.load(session_path, source=data.load("walk").slice(0, 2))  # the source is not used


def run_session_batch(session_path, input_dir, output_dir, *, executor="distributed", workers=2,
                      scheduler: str | None = None, progress=True, timeout: float | None = None) -> BatchResult:
    """Apply the ops of the saved session ``session_path`` to every clip under ``input_dir``; write each edited
    clip as BVH to ``output_dir``, mirroring the folder layout (``a/b.amc`` -> ``a/b.bvh``).

    The session's own source clip is not needed (its ops are what is applied); ``scheduler`` names a running
    ``distributed`` scheduler (``tcp://host:8786``), otherwise ``executor`` decides. Returns a
    :class:`BatchResult`; the report (``batch_report.json`` / ``.csv``) lists every failed clip with its line.
    Raises ``ValueError`` naming the file for a bad session, OUT that is a file, a corrupt manifest or a report
    the batch did not write; :class:`BatchError` (a ValueError, with ``.result``) when the run cannot record
    what it did (a full disk).
    """
    session = _load_session(session_path)
    job = {"ops": session.ops, "extract_options": dict(getattr(session, "extract_options", None) or {})}
    in_root = os.path.abspath(os.fspath(input_dir))

    def out_name(rel: str) -> str:  # a/b.amc -> a/b.bvh, or a/b.amc.bvh when a/b.bvh is an input too
        stem = os.path.splitext(rel)[0]
        if rel.lower().endswith(".amc") and os.path.exists(os.path.join(in_root, stem + ".bvh")):
            return rel + ".bvh"
        return stem + ".bvh"

    return _run("session", job, input_dir, output_dir, out_name, executor=executor, workers=workers,
                scheduler=scheduler, progress=progress, timeout=timeout)[0]


def _part_name(rel: str) -> str:
    return hashlib.sha256(rel.encode("utf-8", "surrogateescape")).hexdigest()[:24] + ".parquet"


def run_extract_poses(input_dir, out_path, *, executor="distributed", workers=2, scheduler: str | None = None,
                      progress=True, timeout: float | None = None, **extract_options) -> BatchResult:
    """Staggered poses of every clip under ``input_dir`` into the one Parquet table ``out_path`` (columns of
    :func:`pose_table`, clips in sorted order). Per-clip tables are kept in ``OUT.parquet.parts/`` (with the
    manifest and report) so a re-run only extracts new or changed clips. An existing ``out_path`` is replaced
    only when the manifest says extract-poses wrote it (and it is unchanged since)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    out_path = os.path.abspath(os.fspath(out_path))
    if not out_path.endswith(".parquet"):
        raise ValueError(f"out_path: {out_path} must end in .parquet")
    if os.path.isdir(out_path):
        raise ValueError(f"{out_path}: is a folder; name a .parquet file for the table")
    parts = out_path + ".parts"
    st = _lstat(out_path)

    def owned_table(manifest: Manifest) -> None:
        if st is None:
            return
        ours = stat.S_ISREG(st.st_mode) and bool(manifest.table_sha256)
        if ours:
            folder, name = os.path.split(os.path.realpath(out_path))
            try:
                ours = hashlib.sha256(read_confined(folder, name, what="table")).hexdigest() in manifest.table_sha256
            except ValueError:
                ours = False
        if not ours:
            raise ValueError(f"{out_path}: exists and was not written by extract-poses (the manifest in "
                             f"{parts} does not list it, or it changed since); it is not replaced")

    res, manifest = _run("poses", {"extract_options": extract_options}, input_dir, parts, _part_name,
                         executor=executor, workers=workers, scheduler=scheduler, progress=progress,
                         timeout=timeout, precheck=owned_table)
    root, tables = os.path.realpath(parts), []
    for rel in sorted(res.done + res.skipped):
        name = _part_name(rel)
        try:
            tables.append(pq.read_table(pa.BufferReader(read_confined(root, name, what="per-clip table"))))
        except (ValueError, OSError) as e:  # ArrowInvalid is a ValueError; its text names no content
            raise BatchError(f"{os.path.join(parts, name)} (the poses of {text_of(rel)}): not a readable "
                             f"Parquet table ({type(e).__name__}); delete it to extract the clip again", res) from None
    table = pa.concat_tables(tables) if tables else _pose_schema().empty_table()
    data = _table_bytes(table)
    digest = hashlib.sha256(data).hexdigest()
    try:  # the new table named first (the old one too): a run that dies in between leaves either known
        manifest.table_sha256 = [digest] + [h for h in manifest.table_sha256[:1] if h != digest]
        manifest.save()
        atomic_write_bytes(out_path, data, replace=st is not None)
        manifest.table_sha256 = [digest]
        manifest.save()
    except WriteError as e:
        raise BatchError(f"{e}; the per-clip tables in {parts} are kept", res) from None
    return res
