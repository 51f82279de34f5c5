"""Replay the generated hostile corpus (tests/hostile_corpus.py) in a bounded child process (issue 13).

The child runs every case once, under an address-space limit and a timeout, and prints one JSON line per
case: how it ended, its CPU time and its peak memory. Each kind is then checked here:

- hostile BVH and ASF/AMC files end in a ``ValueError`` (BVHError / AMCError) naming the file and a line;
- hostile session files end in a ``ValueError`` whose message starts with the field (``ops[0] (cull):
  percent: ...``, ``source.path: ...``, ``session: ...``), and neither the session file nor its source clip
  is changed; saving or exporting over the source clip or over a non-session file is refused;
- odd but valid BVH rigs read, take an edit, and their BVH export re-reads to the edited motion within
  1e-5 of the skeleton's height (and glTF export writes);
- every case within 10 s of CPU time and 500 MB (CPU time, not wall time: a loaded machine does not fail it).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import hostile_corpus  # noqa: E402

_AS_LIMIT = 6 << 30  # address space of the child: numpy/pyarrow threads reserve arenas, so well above 500 MB


def _limit_child():
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (_AS_LIMIT, _AS_LIMIT))


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    out = tmp_path_factory.mktemp("hostile")
    env = {**os.environ, "PYTHONPATH": str(HERE.parent) + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, str(HERE / "hostile_corpus.py"), str(out)], capture_output=True,
                          text=True, timeout=900, env=env,
                          preexec_fn=_limit_child if sys.platform.startswith("linux") else None)
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    assert proc.returncode == 0, proc.stderr[-3000:]
    return rows


def _bounds() -> tuple[float, int]:
    return hostile_corpus.MAX_SECONDS, hostile_corpus.MAX_BYTES


def _report(bad: list[dict]) -> str:
    return "\n".join(f"{r['name']!r}: {r['result']} {r.get('message', '')[:200]!r} ({r['seconds']:.2f} s CPU, "
                     f"{r['peak'] / 2**20:.0f} MB)" for r in bad)


def _assert_every_row(corpus, kind: str, at_least: int, ok) -> None:
    """The corpus's rows of ``kind`` (at least ``at_least`` of them) each end as ``ok(row)`` asks, within the
    time and memory bounds of a hostile input (:func:`_bounds`)."""
    rows = [r for r in corpus if r["kind"] == kind]
    assert len(rows) >= at_least
    secs, peak = _bounds()
    bad = [r for r in rows if not ok(r) or r["seconds"] > secs or r["peak"] > peak]
    assert not bad, _report(bad)


@pytest.mark.parametrize("kind", ["bvh", "amc"])
def test_hostile_files_end_in_a_value_error_naming_file_and_line(corpus, kind):
    _assert_every_row(corpus, kind, 120 if kind == "bvh" else 40,
                      lambda r: r["result"] == "ValueError" and r["named"] and r["line"])


def test_hostile_sessions_end_in_a_value_error_naming_the_field(corpus):
    _assert_every_row(corpus, "session", 400, lambda r: r["result"] == "ValueError" and r["named"] and r["untouched"])


def test_odd_rigs_read_edit_and_export_faithfully(corpus):
    _assert_every_row(corpus, "odd", 20, lambda r: r["result"] == "no error")


def test_numpy_scalars_are_numbers_and_numpy_bools_are_not():
    """Ops built in code often carry numpy scalars (``np.argmax`` frames, float32 sliders): accepted and
    stored as plain ints/floats (JSON-serialisable); numpy and Python bools are refused like in JSON."""
    import numpy as np

    from stagger_nb.session.ops import canonical, validate_op
    op = validate_op({"op": "edit_frame", "frame": np.int64(3), "deltas": {"a": [np.float32(1), 0, 0]}})
    assert op["frame"] == 3 and type(op["frame"]) is int and canonical(op)
    assert validate_op({"op": "cull", "count": np.int32(5)})["count"] == 5
    assert validate_op({"op": "cull", "percent": np.float32(50)})["percent"] == 50.0
    for bad in (np.bool_(True), True):
        with pytest.raises(ValueError, match=r"^op\.percent: expected a number"):
            validate_op({"op": "cull", "percent": bad})


def test_save_refuses_what_load_would_refuse(tmp_path, monkeypatch):
    """A session file over the size limit is refused on saving too (nothing written), not only on loading."""
    import stagger_nb as sn
    from stagger_nb.session import Session, files
    s = Session(sn.data.load("walk").slice(0, 20))  # no source path: the motion is embedded
    s.save(tmp_path / "ok.json")
    size = (tmp_path / "ok.json").stat().st_size
    assert Session.load(tmp_path / "ok.json").source.num_frames == 20
    monkeypatch.setattr(files, "MAX_SESSION_BYTES", size - 1)
    with pytest.raises(ValueError, match=r"^session: .* over the .*-byte limit .*embed_source=False"):
        s.save(tmp_path / "big.json")
    assert not (tmp_path / "big.json").exists()
    with pytest.raises(ValueError, match=r"^session: session file .*ok\.json: .* over the"):
        Session.load(tmp_path / "ok.json")
