"""The task a batch runs on a worker for one clip: read it, apply the session's ops (or extract its staggered
poses), write the output inside the output folder (:func:`stagger_nb.io._common.write_confined`: no symbolic
link inside it is followed, and a file the batch did not write is never replaced). Every executor runs
``_run_task``, so outputs are identical bit for bit."""
from __future__ import annotations

import hashlib
import io
import math
import os
import resource
import socket
import time
import traceback

from .discover import read_clip

__all__ = ["pose_table"]

_PINNED = False


def _pin_threads() -> None:
    """One BLAS/OpenMP thread in this worker process (once per process)."""
    global _PINNED
    if not _PINNED:
        from threadpoolctl import threadpool_limits
        threadpool_limits(1)
        _PINNED = True


def _run_task(task: dict) -> dict:
    """Run one clip; never raises: ``{"file", "ok", "output", "output_sha256", "line", "error", "quality",
    "seconds"}`` (``quality``: a session's :meth:`QualityReport.to_row <stagger_nb.quality.QualityReport.to_row>`
    of the edited clip, ``{"error": ...}`` when it could not be measured, None for extract-poses)."""
    _pin_threads()
    t0 = time.perf_counter()
    res = {"file": task["rel"], "ok": False, "output": task["out_rel"], "output_sha256": None, "line": None,
           "error": None, "quality": None}
    try:
        if task["kind"] == "session":
            data, res["quality"] = _session_bytes(task)
        else:
            data = _poses_bytes(task)
        from ..io._common import write_confined
        write_confined(task["out_root"], task["out_rel"], data, replace=task["replace"])
        res["output_sha256"] = hashlib.sha256(data).hexdigest()
        res["ok"] = True
    except Exception as e:
        res["line"] = getattr(e, "line", None)
        res["error"] = f"{type(e).__name__}: {e}" if not isinstance(e, ValueError) else str(e)
        if not isinstance(e, ValueError):
            res["error"] += " | " + traceback.format_exc(limit=3).strip().splitlines()[-2].strip()
    res["seconds"] = time.perf_counter() - t0
    res["pid"] = f"{socket.gethostname()}:{os.getpid()}"
    res["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB
    return res


def _session_bytes(task: dict) -> tuple[bytes, dict]:
    """The BVH bytes of the clip edited by the session's ops, and the edit's quality figures
    (:meth:`Session.quality <stagger_nb.session.Session.quality>`, default bounds, as one row)."""
    from ..io.bvh_write import bvh_bytes
    from ..session import Session
    motion = read_clip(task["input"])
    s = Session(motion, ops=task["ops"], extract_options=task["extract_options"] or None)
    data = bvh_bytes(s.edited())
    try:
        row = {k: None if isinstance(v, float) and not math.isfinite(v) else v
               for k, v in s.quality().to_row().items()}
    except Exception as e:
        row = {"error": f"quality: {e}" if isinstance(e, ValueError) else f"quality: {type(e).__name__}: {e}"}
    return data, row


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


def _poses_bytes(task: dict) -> bytes:
    """The Parquet bytes of the clip's staggered poses (:func:`pose_table`)."""
    motion = read_clip(task["input"])
    from .report import text_of  # a file name that is not UTF-8 is stored with \xNN escapes
    return _table_bytes(pose_table(motion, text_of(task["rel"]), **(task["extract_options"] or {})))
