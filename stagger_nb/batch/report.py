"""What a batch records in its output folder (OUT), all of it written inside OUT only
(:func:`stagger_nb.io._common.write_confined`):

- the manifest (``.stagger_nb_manifest.json``): each clip's input and job keys, the output it names (a path
  inside OUT) and the SHA-256 of the bytes the batch wrote there, and the reports the batch writes. It is the
  record of what the batch wrote: a file in OUT that it does not list (or whose bytes changed since) is the
  user's and is never replaced. A manifest that is not one (bad JSON, wrong fields, an output outside OUT)
  is an error naming the file, its content never quoted;
- the reports (``batch_report.json``, ``batch_report.csv``): every clip with its status (done, skipped, failed),
  the quality figures of its edit (``python -m stagger_nb batch``: ``Session.quality``'s row, kept in the
  manifest so a re-run's report still has the clips it skips) and, for a failed clip, its file, line and error.
  A small report is written before any clip runs, so a run that dies or fills the disk leaves one; the final
  one replaces it atomically, or, when the disk is full, the first is overwritten in place (no new blocks)
  to say so. Names that are not valid UTF-8 are shown with ``\\xNN`` escapes; CSV cells a spreadsheet would
  evaluate (starting with ``= + - @``, tab or carriage return: the OWASP rule) are prefixed with ``'``.
"""
from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import re
from dataclasses import dataclass, field

from ..io._common import WriteError, confined_parts, overwrite_in_place, read_confined, write_confined

__all__ = ["BatchResult", "BatchError", "MANIFEST", "REPORT_JSON", "REPORT_CSV", "CSV_COLUMNS", "clip_rows"]

MANIFEST = ".stagger_nb_manifest.json"
REPORT_JSON = "batch_report.json"
REPORT_CSV = "batch_report.csv"
MANIFEST_FORMAT = "stagger_nb.batch_manifest"
MANIFEST_VERSION = 2
MAX_MANIFEST_BYTES = 64 << 20  # ~300 bytes a clip: 200,000 clips
_HEX64 = re.compile(r"[0-9a-f]{64}")


@dataclass
class BatchResult:
    """What a run did: ``done`` (relative paths run now and written), ``skipped`` (finished in an earlier run),
    ``failed`` (report rows: file, line, error), ``seconds`` (wall time), ``report`` (report JSON path),
    ``worker_peak_mb`` ({"host:pid": peak resident MB of that worker process} over the clips it ran),
    ``quality`` ({relative path: the quality row of its edit} for the done and skipped clips of a session
    batch: :meth:`QualityReport.to_row <stagger_nb.quality.QualityReport.to_row>`, or ``{"error": ...}``)."""
    done: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: list = field(default_factory=list)
    seconds: float = 0.0
    report: str = ""
    worker_peak_mb: dict = field(default_factory=dict)
    quality: dict = field(default_factory=dict)


class BatchError(ValueError):
    """A run that could not record what it did (a full disk, a stopped scheduler): the message says what
    failed and where the report is; ``result`` is the :class:`BatchResult` so far."""

    def __init__(self, message: str, result: BatchResult):
        super().__init__(message)
        self.result = result


# --------------------------------------------------------------------------------------------------
# names as text
# --------------------------------------------------------------------------------------------------
def text_of(name: str) -> str:
    """``name`` as UTF-8-safe text: the bytes of a file name that is not valid UTF-8 (surrogate escapes from
    ``os.fsdecode``) shown as ``\\xNN``."""
    if name.isprintable() or not any("\udc80" <= c <= "\udcff" for c in name):
        return name
    return "".join(f"\\x{ord(c) - 0xdc00:02x}" if "\udc80" <= c <= "\udcff" else c for c in name)


def terminal_text(name: str) -> str:
    """:func:`text_of`, with control characters (a line break in a file name) escaped too: safe to print."""
    name = text_of(name)
    if name.isprintable():
        return name
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in name)


def _cell(value) -> str:
    """A CSV cell a spreadsheet shows as text: ``'`` before a leading ``= + - @``, tab or carriage return. A
    number (``-1.250``) is written as it is; a non-finite one (NaN, inf) as an empty cell."""
    if isinstance(value, float):
        return f"{value:.3f}" if math.isfinite(value) else ""
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    s = "" if value is None else text_of(str(value))
    return "'" + s if s[:1] in ("=", "+", "-", "@", "\t", "\r") else s


def _finite(value):
    """``value`` with every non-finite float (NaN, inf) inside it replaced by None: strict JSON."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def _rows_text(rows: list) -> list:
    return [{k: (text_of(v) if isinstance(v, str) else v) for k, v in row.items()} for row in rows]


# --------------------------------------------------------------------------------------------------
# the manifest
# --------------------------------------------------------------------------------------------------
class Manifest:
    """The record of a batch's output folder ``root`` (see the module docstring). ``clips``:
    ``{rel: {"key": {...} or None, "output": path in root, "output_sha256": hex or None}}`` (``None``: written,
    or being written, by the batch, bytes not known); ``reports``: the report names the batch writes there;
    ``table_sha256``: the SHA-256 of the Parquet table extract-poses writes beside ``root`` (two while a new
    table replaces the old one, so that either is known to be the batch's if the run stops in between)."""

    def __init__(self, root: str, shown: str):
        self.root, self.shown = root, shown
        self.clips: dict = {}
        self.reports: list = []
        self.table_sha256: list = []

    @property
    def path(self) -> str:
        return os.path.join(self.shown, MANIFEST)

    def _bad(self, why: str) -> ValueError:
        return ValueError(f"{self.path}: not a valid batch manifest ({why}); it is not used. Delete it (the batch "
                          "then replaces none of the files in the folder) or restore it")

    @classmethod
    def load(cls, root: str, shown: str) -> Manifest:
        m = cls(root, shown)
        if not os.path.lexists(os.path.join(root, MANIFEST)):
            return m
        try:
            raw = read_confined(root, MANIFEST, what="manifest", max_bytes=MAX_MANIFEST_BYTES)
        except ValueError as e:
            raise m._bad(str(e).split(": ", 1)[-1]) from None
        try:
            data = json.loads(raw.decode("utf-8"))
        except UnicodeDecodeError as e:
            raise m._bad(f"not UTF-8 text at byte {e.start}") from None
        except json.JSONDecodeError as e:
            raise m._bad(f"not JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None
        except (ValueError, RecursionError):
            raise m._bad("JSON nested too deeply or holding too long a number") from None
        if not isinstance(data, dict):
            raise m._bad("not a JSON object")
        if "format" in data:
            if data.get("format") != MANIFEST_FORMAT or data.get("version") != MANIFEST_VERSION:
                raise m._bad(f"its format is not {MANIFEST_FORMAT} version {MANIFEST_VERSION}")
            if set(data) - {"format", "version", "clips", "reports", "table_sha256"}:
                raise m._bad("unknown fields")
            clips, reports, table = data.get("clips", {}), data.get("reports", []), data.get("table_sha256", [])
        else:  # written by a batch before version 2: {rel: {"key", "output"}}
            clips, reports, table = data, [REPORT_JSON, REPORT_CSV], []
        if not isinstance(clips, dict):
            raise m._bad("'clips' is not an object")
        if not (isinstance(reports, list) and all(r in (REPORT_JSON, REPORT_CSV) for r in reports)):
            raise m._bad("'reports' is not a list of report names")
        if not (isinstance(table, list) and len(table) <= 2
                and all(isinstance(t, str) and _HEX64.fullmatch(t) for t in table)):
            raise m._bad("'table_sha256' is not a list of SHA-256")
        for n, entry in enumerate(clips.values(), 1):
            why = _entry_problem(entry)
            if why:
                raise m._bad(f"entry {n} of {len(clips)}: {why}")
        m.clips, m.reports, m.table_sha256 = dict(clips), list(reports), table
        return m

    def wrote(self, out_rel: str) -> bool:
        """Did the batch write the file now at ``out_rel`` (listed, and its bytes those it wrote)?"""
        entries = [e for e in self.clips.values() if e["output"] == out_rel]
        if not entries:
            return False
        if any(e.get("output_sha256") is None for e in entries):
            return True
        try:
            digest = hashlib.sha256(read_confined(self.root, out_rel, what="output")).hexdigest()
        except ValueError:
            return False
        return any(e.get("output_sha256") == digest for e in entries)

    def to_bytes(self) -> bytes:
        data = {"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION, "clips": self.clips,
                "reports": sorted(self.reports), "table_sha256": self.table_sha256}
        return json.dumps(data, indent=1, sort_keys=True, allow_nan=False).encode("utf-8")

    def save(self) -> None:
        write_confined(self.root, MANIFEST, self.to_bytes(), replace=True)


def _entry_problem(entry) -> str | None:
    """Why a manifest entry is not one (its values are not quoted), or None."""
    if (not isinstance(entry, dict) or "output" not in entry
            or set(entry) - {"key", "output", "output_sha256", "quality"}):
        return "not an object with 'key' and 'output'"
    if "quality" in entry and not _quality_row(entry["quality"]):
        return "'quality' is not a row of figures"
    key = entry.get("key")
    if key is not None and not (isinstance(key, dict) and set(key) == {"input_sha256", "job_sha256"}
                                and all(isinstance(v, str) and _HEX64.fullmatch(v) for v in key.values())):
        return "'key' is not the input and job SHA-256"
    try:
        confined_parts(entry["output"], "output")
    except ValueError:
        return "its output is outside the output folder (an absolute path, '..', or not a path)"
    digest = entry.get("output_sha256")
    if digest is not None and not (isinstance(digest, str) and _HEX64.fullmatch(digest)):
        return "'output_sha256' is not a SHA-256"
    return None


def _quality_row(row) -> bool:
    """Whether ``row`` is a quality row as the batch writes it: None, or an object of at most 32 known-size
    scalars (text of at most 2,000 characters) keyed by short names."""
    if row is None:
        return True
    return (isinstance(row, dict) and len(row) <= 32
            and all(isinstance(k, str) and len(k) <= 64 for k in row)
            and all(v is None or isinstance(v, (bool, int)) or (isinstance(v, float) and math.isfinite(v))
                    or (isinstance(v, str) and len(v) <= 2000) for v in row.values()))


# --------------------------------------------------------------------------------------------------
# the reports
# --------------------------------------------------------------------------------------------------
#: Columns of ``batch_report.csv``: the clip, its status (``done``, ``skipped``: finished in an earlier run, or
#: ``failed``), the line of a parse error, the quality figures of the edit (``python -m stagger_nb batch``: its
#: :meth:`QualityReport.to_row <stagger_nb.quality.QualityReport.to_row>`, mild bounds; cm of a 170 cm body,
#: degrees; empty for extract-poses and for failed clips), and the error last.
CSV_COLUMNS = ("file", "status", "line", "quality_ok", "summary", "foot_travel_cm", "foot_height_cm", "floor_cm",
               "pelvis_cm", "pelvis_vs_no_layer_cm", "added_pop_deg", "pop_joint", "knots_out_of_order",
               "detail_ratio", "moved_cm", "error")
#: The quality row's key behind each quality column.
_QUALITY_KEYS = {"quality_ok": "ok", "summary": "summary", "foot_travel_cm": "foot_travel",
                 "foot_height_cm": "foot_height", "floor_cm": "floor", "pelvis_cm": "pelvis",
                 "pelvis_vs_no_layer_cm": "pelvis_vs_baseline", "added_pop_deg": "added_pop",
                 "pop_joint": "added_pop_joint", "knots_out_of_order": "knots_out_of_order",
                 "detail_ratio": "detail", "moved_cm": "moved"}


def clip_rows(report: dict) -> list:
    """One row per clip of ``report`` (its ``done``, ``skipped`` and ``failed`` clips, sorted by file), with the
    quality figures ``report["quality"]`` holds for it: dicts keyed by :data:`CSV_COLUMNS`."""
    quality = report.get("quality") or {}
    rows = []
    for status in ("done", "skipped"):
        for rel in report.get(status, []):
            q = quality.get(rel) or {}
            row = {"file": rel, "status": status, "error": q.get("error")}
            row.update({col: q.get(key) for col, key in _QUALITY_KEYS.items()})
            rows.append(row)
    rows += [dict(r, status="failed") for r in report.get("failed", [])]
    return sorted(rows, key=lambda r: (str(r.get("file")), r["status"]))


def _csv_bytes(rows: list, quote_all: bool = False) -> bytes:
    buf = io.StringIO()
    w = csv.writer(buf, quoting=csv.QUOTE_ALL if quote_all else csv.QUOTE_MINIMAL)
    w.writerow(CSV_COLUMNS)
    w.writerows([_cell(r.get(c)) for c in CSV_COLUMNS] for r in rows)
    return buf.getvalue().encode("utf-8")


def _json_bytes(report: dict) -> bytes:
    report = _finite(dict(report))   # NaN / inf figures as null: strict JSON
    for k in ("done", "skipped"):
        if k in report:
            report[k] = [text_of(r) for r in report[k]]
    if "quality" in report:
        report["quality"] = {text_of(rel): row for rel, row in report["quality"].items()}
    if "failed" in report:
        report["failed"] = _rows_text(report["failed"])
    for k in ("input_dir", "output"):
        if isinstance(report.get(k), str):
            report[k] = text_of(report[k])
    return json.dumps(report, indent=1, sort_keys=True, allow_nan=False).encode("utf-8")


def write_reports(root: str, shown: str, report: dict) -> str:
    """``batch_report.json`` (``report``) and ``batch_report.csv`` (one row per clip: :func:`clip_rows`) in
    ``root``, atomically; the JSON report's path. ``WriteError`` when either cannot be written."""
    write_confined(root, REPORT_JSON, _json_bytes(report), replace=True)
    write_confined(root, REPORT_CSV, _csv_bytes(clip_rows(report)), replace=True)
    return os.path.join(shown, REPORT_JSON)


def report_failure(root: str, shown: str, report: dict, status: str) -> bool:
    """Say ``status`` (why the run could not record itself) in the reports however the disk allows: an atomic
    write, else an overwrite in place of the report there (a full disk has no room for a new file, but the old
    one's blocks are reused). True when the JSON report says so."""
    report = dict(report, status=status)
    said = False
    small = {k: report.get(k) for k in ("status", "input_dir", "output", "executor", "clips")}
    small.update({f"{k}_count": len(report.get(k, [])) for k in ("done", "skipped", "failed")})
    for name, full, brief, pad_at in ((REPORT_JSON, _json_bytes(report), _json_bytes(small), None),
                                      (REPORT_CSV, _csv_bytes(clip_rows(report) + [
                                          {"file": "(this run)", "status": "failed", "error": status}], quote_all=True),
                                       _csv_bytes([{"file": "(this run)", "status": "failed", "error": status}],
                                                  quote_all=True), -3)):
        ok = False
        try:
            write_confined(root, name, full, replace=True)
            ok = True
        except WriteError:
            for data in (full, brief):
                try:
                    overwrite_in_place(root, name, data, pad_at=pad_at)
                    ok = True
                    break
                except (WriteError, ValueError):
                    continue
        said = said or (ok and name == REPORT_JSON)
    return said
