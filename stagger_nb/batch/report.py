"""What a batch records in its output folder: the manifest (``.stagger_nb_manifest.json``: each finished clip's
input and job keys and its output) and the reports (``batch_report.json``, ``batch_report.csv``: every failed
clip with its file, line and error), each written atomically."""
from __future__ import annotations

import csv
import io
import json
import os
from dataclasses import dataclass, field

__all__ = ["BatchResult", "MANIFEST", "REPORT_JSON", "REPORT_CSV"]

MANIFEST = ".stagger_nb_manifest.json"
REPORT_JSON = "batch_report.json"
REPORT_CSV = "batch_report.csv"


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


def load_manifest(path: str) -> dict:
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def dump_json(path: str, data) -> None:
    from ..io._common import atomic_write_bytes
    atomic_write_bytes(path, json.dumps(data, indent=1, sort_keys=True, allow_nan=False).encode("utf-8"))


def write_reports(out_root: str, report: dict, failed: list) -> str:
    """``batch_report.json`` (``report``) and ``batch_report.csv`` (the ``failed`` rows) in ``out_root``; the
    JSON report's path."""
    path = os.path.join(out_root, REPORT_JSON)
    dump_json(path, report)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=["file", "line", "error"])
    w.writeheader()
    w.writerows(failed)
    from ..io._common import atomic_write_bytes
    atomic_write_bytes(os.path.join(out_root, REPORT_CSV), buf.getvalue().encode("utf-8"))
    return path
