"""``python -m stagger_nb``: batch jobs over a folder of clips (see :mod:`stagger_nb.batch`).

    python -m stagger_nb batch SESSION.json INPUT_DIR OUTPUT_DIR [--scheduler ADDRESS] [--workers N]
    python -m stagger_nb extract-poses INPUT_DIR OUT.parquet [--scheduler ADDRESS] [--workers N]

Exit status: 0 when every clip was written (or skipped as finished), 1 when some clips failed (listed in the
report), 2 on a usage error or a run that could not record what it did (a full disk: the message and the
report say so).
"""
from __future__ import annotations

import argparse
import sys


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m stagger_nb", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    def common(p):
        p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="a running distributed scheduler (tcp://host:8786); default: local worker processes")
        p.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
        p.add_argument("--executor", choices=("distributed", "processes", "serial"), default="distributed",
                       help="distributed (LocalCluster or --scheduler), processes (dask.bag), serial (one process)")
        p.add_argument("--no-progress", action="store_true", help="no progress bar")

    b = sub.add_parser("batch", help="apply a saved session's ops to every clip, writing edited BVH files")
    b.add_argument("session")
    b.add_argument("input_dir")
    b.add_argument("output_dir")
    common(b)
    e = sub.add_parser("extract-poses", help="staggered poses of every clip into one Parquet table")
    e.add_argument("input_dir")
    e.add_argument("out")
    common(e)
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers must be at least 1")
    from . import batch
    from .batch.report import terminal_text
    kw = dict(executor=args.executor, workers=args.workers, scheduler=args.scheduler, progress=not args.no_progress)
    try:
        if args.command == "batch":
            res = batch.run_session_batch(args.session, args.input_dir, args.output_dir, **kw)
        else:
            res = batch.run_extract_poses(args.input_dir, args.out, **kw)
    except ValueError as err:  # a bad argument or file (named), a corrupt manifest, a full disk
        res = getattr(err, "result", None)
        if res is not None:
            _failed(res, terminal_text)
        print(f"error: {terminal_text(str(err))}", file=sys.stderr)
        return 2
    print(f"{len(res.done)} written, {len(res.skipped)} skipped (finished earlier), {len(res.failed)} failed "
          f"in {res.seconds:.1f} s; report: {terminal_text(res.report)}")
    rows = [r for r in res.quality.values() if "ok" in r]
    if rows:   # the edits' quality (mild bounds), each clip's summary in the report
        bad = sum(not r["ok"] for r in rows)
        print(f"quality: {len(rows) - bad} of {len(rows)} edited clips inside the mild bounds"
              + (f", {bad} out of bounds (see the report's summary column)" if bad else ""))
    _failed(res, terminal_text)
    return 1 if res.failed else 0


def _failed(res, shown) -> None:
    for row in res.failed:  # the error names the line; names and errors printed as safe text
        print(f"  failed: {shown(row['file'])}: {shown(str(row['error']))}", file=sys.stderr)

if __name__ == "__main__":
    sys.exit(main())
