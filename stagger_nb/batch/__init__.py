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

Modules: :mod:`.discover` (finding and reading clips), :mod:`.tasks` (what a worker does for one clip),
:mod:`.run` (the executors and the driver), :mod:`.report` (the manifest and the reports).
"""
from __future__ import annotations

from .discover import find_clips, read_clip
from .report import MANIFEST, REPORT_CSV, REPORT_JSON, BatchResult
from .run import THREAD_ENV, run_extract_poses, run_session_batch
from .tasks import pose_table

__all__ = ["find_clips", "read_clip", "pose_table", "run_session_batch", "run_extract_poses", "BatchResult",
           "MANIFEST", "REPORT_JSON", "REPORT_CSV", "THREAD_ENV"]
