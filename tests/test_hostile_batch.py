"""The batch, the readers and the session under hostile folders and names (issue 21): every case ends in a clean
error or a correct result within 60 s, nothing is overwritten that the batch did not write, nothing is written
outside OUT, and no message or report quotes a file that is not a clip (a marker string is planted in each).

Batch cases run the command line (``python -m stagger_nb``) in a subprocess with a timeout, so a hang (a FIFO
opened for reading blocks) fails the test instead of stalling the suite; reader cases run in a forked child
with the same timeout. Disk full is simulated twice: a 256 KiB tmpfs mounted over OUT where this process may
mount one, and always by a writer that raises ENOSPC past a byte budget (``io._output._write_all``, the one
function every atomic write of the package goes through)."""
from __future__ import annotations

import csv
import errno
import json
import math
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import run_forked
from tree_snapshot import snapshot

import stagger_nb as sn
from stagger_nb import batch
from stagger_nb.session import Session

REPO = Path(__file__).resolve().parents[1]
MARKER = "MARKER-7f3a-not-a-clip"
SECRET = f"{MARKER} root:*:20228:0:99999:7:::\nsecond line {MARKER}\n"
OPS = [{"op": "cull", "percent": 50}]
TIMEOUT = 60
#: A one-bone Acclaim skeleton and two frames of its motion.
ASF = (":version 1.10\n:name t\n:units\n  length 1\n  angle deg\n:root\n  order TX TY TZ RX RY RZ\n  axis XYZ\n"
       "  position 0 0 0\n  orientation 0 0 0\n:bonedata\n  begin\n    id 1\n    name b\n    direction 0 1 0\n"
       "    length 2\n    axis 0 0 0 XYZ\n    dof rx\n  end\n:hierarchy\n  begin\n    root b\n  end\n")
AMC = ":FULLY-SPECIFIED\n:DEGREES\n1\nroot 0 0 0 0 0 0\nb 5\n2\nroot 0 1 0 0 0 0\nb 6\n"


# -- helpers ------------------------------------------------------------------------------------------------
def cli(*args, timeout=TIMEOUT):
    """``python -m stagger_nb ARGS`` (serial, no progress bar) -> CompletedProcess; a hang fails the test."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
           "OPENBLAS_NUM_THREADS": "1"}
    argv = [sys.executable, "-m", "stagger_nb", *map(os.fsdecode, args), "--executor", "serial", "--no-progress"]
    try:
        return subprocess.run(argv, capture_output=True, timeout=timeout, env=env, cwd=REPO)
    except subprocess.TimeoutExpired:
        pytest.fail(f"python -m stagger_nb {' '.join(map(os.fsdecode, args))} did not end within {timeout} s")


def in_child(fn, timeout=TIMEOUT) -> str:
    """Run ``fn()`` in a forked child: ``"ok"`` when it returns, ``"TypeName: message"`` when it raises; a child
    still running after ``timeout`` s is killed and fails the test (a FIFO read would block forever)."""
    def body(send):
        try:
            fn()
            send("ok")
        except BaseException as e:
            send(f"{type(e).__name__}: {e}")
    return run_forked(body, timeout)[0]


def assert_clean(proc, out: Path | None = None):
    """No traceback, no marker in stdout/stderr, nor in any regular file under ``out``."""
    text = proc.stdout.decode("utf-8", "replace") + proc.stderr.decode("utf-8", "replace")
    assert "Traceback" not in text, text[-3000:]
    assert MARKER not in text, text[-3000:]
    if out is not None and out.is_dir():
        for folder, _, files in os.walk(out):
            for f in files:
                p = os.path.join(folder, f)
                if stat.S_ISREG(os.lstat(p).st_mode):
                    assert MARKER.encode() not in open(p, "rb").read(), p


def report_rows(out: Path) -> dict:
    """``{file: error}`` of the failed clips' rows of ``out/batch_report.csv`` (read with the csv module, as a
    spreadsheet would; the report has a row per clip, its status in a column)."""
    with open(out / batch.REPORT_CSV, newline="", encoding="utf-8") as f:
        return {row["file"]: row["error"] for row in csv.DictReader(f) if row["status"] == "failed"}


@pytest.fixture
def job(tmp_path):
    """in/: two short clips (one in sub/); s.json: a session culling half the poses."""
    src = tmp_path / "in"
    (src / "sub").mkdir(parents=True)
    walk = sn.data.load("walk")
    sn.write_bvh(walk.slice(0, 20), src / "clip0.bvh")
    sn.write_bvh(walk.slice(20, 40), src / "sub" / "clip1.bvh")
    session = tmp_path / "s.json"
    Session(walk.slice(0, 20), ops=OPS).save(session)
    secret = tmp_path / "secret.txt"
    secret.write_text(SECRET)
    return src, session, secret


# -- inputs that are not regular files ----------------------------------------------------------------------
def _hostile_inputs(src: Path, tmp_path: Path) -> list[str]:
    os.mkfifo(src / "x.bvh")
    os.mkfifo(tmp_path / "elsewhere.fifo")
    (src / "to_fifo.bvh").symlink_to(tmp_path / "elsewhere.fifo")
    (src / "zero.bvh").symlink_to("/dev/zero")
    (src / "urandom.bvh").symlink_to("/dev/urandom")
    (src / "environ.bvh").symlink_to("/proc/self/environ")   # a regular file to stat(): procfs is refused
    return ["environ.bvh", "to_fifo.bvh", "urandom.bvh", "x.bvh", "zero.bvh"]


@pytest.mark.parametrize("command", ["batch", "extract-poses"])
def test_fifos_devices_and_proc_files_among_inputs_are_reported_not_read(job, tmp_path, command):
    """Before: the FIFO (or a link to one, /dev/zero, /dev/urandom) hung the run before any clip ran: the
    input hash opened it without the readers' regular-file policy."""
    src, session, _ = job
    bad = _hostile_inputs(src, tmp_path)
    out = tmp_path / "out"
    args = ("batch", session, src, out) if command == "batch" else ("extract-poses", src, tmp_path / "p.parquet")
    proc = cli(*args)
    assert proc.returncode == 1, proc.stderr.decode()[-2000:]
    assert_clean(proc)
    rows = report_rows(out if command == "batch" else tmp_path / "p.parquet.parts")
    assert sorted(rows) == bad
    for name in bad:
        assert "not a regular file" in rows[name] and name in rows[name], rows[name]
    if command == "batch":
        assert (out / "clip0.bvh").is_file() and (out / "sub" / "clip1.bvh").is_file()


def _read_bvh(p):
    return lambda: sn.read_bvh(p)


@pytest.mark.parametrize("target", ["fifo", "link to fifo", "/dev/zero", "/dev/urandom", "/proc/self/environ",
                                    "folder"])
def test_readers_session_and_warp_references_refuse_what_is_not_a_regular_file(job, tmp_path, target):
    """read_bvh, read_asf_amc (either file), Session.load (the session file, its source) and a guided_warp
    reference all go through the one input policy: a clean ValueError naming the path, at once."""
    src, session, _ = job
    if target in ("fifo", "link to fifo"):
        os.mkfifo(tmp_path / "f")
        path = tmp_path / "f"
        if target == "link to fifo":
            (tmp_path / "l.bvh").symlink_to(path)
            path = tmp_path / "l.bvh"
    elif target == "folder":
        path = tmp_path / "in"
    else:
        path = Path(target)
    walk_json = json.loads(session.read_text())
    ref = dict(walk_json, ops=[{"op": "guided_warp", "reference": {"path": str(path)}, "duration": 0.5}])
    (tmp_path / "ref.json").write_text(json.dumps(ref))
    srcj = dict(walk_json, source={"path": str(path)})
    (tmp_path / "src.json").write_text(json.dumps(srcj))
    (tmp_path / "ok.asf").write_text(ASF)
    calls = {"read_bvh": lambda: sn.read_bvh(path),
             "read_asf_amc asf": lambda: sn.read_asf_amc(path, src / "clip0.bvh"),
             "read_asf_amc amc": lambda: sn.read_asf_amc(tmp_path / "ok.asf", path),
             "Session.load": lambda: Session.load(path),
             "session source": lambda: Session.load(tmp_path / "src.json"),
             "warp reference": lambda: Session.load(tmp_path / "ref.json").edited()}
    for what, call in calls.items():
        got = in_child(call)
        # all ValueErrors
        assert got.split(":")[0] in ("ValueError", "BVHError", "AMCError", "ReplayError"), (what, got)
        assert "not a regular file" in got and str(path) in got, (what, got)
        assert MARKER not in got and "PATH=" not in got, (what, got)


# -- OUT and what is in it ----------------------------------------------------------------------------------
def test_out_inside_in_leaves_a_users_file_untouched(job):
    """``batch s.json in in/edited`` where in/edited/clip0.bvh is the user's own file: before, overwritten."""
    src, session, _ = job
    out = src / "edited"
    out.mkdir()
    mine = b"my own notes, not written by any batch\n"
    (out / "clip0.bvh").write_bytes(mine)
    proc = cli("batch", session, src, out)
    assert proc.returncode == 1, proc.stderr.decode()[-2000:]
    assert_clean(proc)
    assert (out / "clip0.bvh").read_bytes() == mine
    rows = report_rows(out)
    assert list(rows) == ["clip0.bvh"] and "not written by this batch" in rows["clip0.bvh"]
    assert (out / "sub" / "clip1.bvh").is_file()
    first = (out / "sub" / "clip1.bvh").read_bytes()
    # a re-run after a changed input replaces what the batch wrote, and still not the user's file
    sn.write_bvh(sn.data.load("run").slice(0, 20), src / "sub" / "clip1.bvh")
    proc = cli("batch", session, src, out)
    assert proc.returncode == 1 and (out / "clip0.bvh").read_bytes() == mine
    assert (out / "sub" / "clip1.bvh").read_bytes() != first and b"4 written" not in proc.stdout
    assert b"1 written" in proc.stdout


def test_a_symlinked_out_subfolder_or_file_is_not_written_through(job, tmp_path):
    """OUT/sub -> a folder elsewhere; OUT/clip0.bvh -> a file elsewhere: before, outputs went through both."""
    src, session, _ = job
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / "sub").symlink_to(elsewhere)
    target = tmp_path / "target.bvh"
    target.write_text("a file outside OUT\n")
    (out / "clip0.bvh").symlink_to(target)
    before = snapshot(tmp_path, skip=out)
    proc = cli("batch", session, src, out)
    assert proc.returncode == 1, proc.stderr.decode()[-2000:]
    assert_clean(proc)
    assert snapshot(tmp_path, skip=out) == before       # nothing written outside OUT
    assert os.readlink(out / "sub") == str(elsewhere) and os.readlink(out / "clip0.bvh") == str(target)
    rows = report_rows(out)
    assert sorted(rows) == ["clip0.bvh", "sub/clip1.bvh"]
    assert all("symbolic link" in e for e in rows.values()), rows


def test_out_that_is_a_file_is_a_clear_error(job, tmp_path):
    src, session, _ = job
    out = tmp_path / "out"
    out.write_text("a file\n")
    (tmp_path / "t.parquet.parts").write_text("x")
    (tmp_path / "d.parquet").mkdir()
    for args, named in ((("batch", session, src, out), out), (("extract-poses", src, tmp_path / "t.parquet"),
                                                                tmp_path / "t.parquet.parts"),
                        (("extract-poses", src, tmp_path / "d.parquet"), tmp_path / "d.parquet")):
        proc = cli(*args)
        err = proc.stderr.decode()
        assert proc.returncode == 2 and "Traceback" not in err and f"{named}: " in err, err[-2000:]
    assert out.read_text() == "a file\n" and (tmp_path / "t.parquet.parts").read_text() == "x"
    assert os.listdir(tmp_path / "d.parquet") == []


def test_reports_and_tables_the_batch_did_not_write_are_not_replaced(job, tmp_path):
    """A batch_report.csv of the user's in OUT (no manifest lists it), or an OUT.parquet that extract-poses
    did not write: refused before anything runs, the files untouched."""
    src, session, _ = job
    out = tmp_path / "out"
    out.mkdir()
    (out / batch.REPORT_CSV).write_text("my,own,table\n")
    proc = cli("batch", session, src, out)
    assert proc.returncode == 2 and b"batch_report.csv" in proc.stderr and b"Traceback" not in proc.stderr
    assert (out / batch.REPORT_CSV).read_text() == "my,own,table\n" and not (out / "clip0.bvh").exists()
    table = tmp_path / "t.parquet"
    table.write_bytes(b"PAR1 not really\n")
    proc = cli("extract-poses", src, table)
    assert proc.returncode == 2 and b"t.parquet" in proc.stderr and b"Traceback" not in proc.stderr
    assert table.read_bytes() == b"PAR1 not really\n"
    proc = cli("extract-poses", src, tmp_path / "u.parquet")   # a fresh table, then its re-run replaces it
    assert proc.returncode == 0, proc.stderr.decode()[-2000:]
    sn.write_bvh(sn.data.load("run").slice(0, 20), src / "clip0.bvh")
    proc = cli("extract-poses", src, tmp_path / "u.parquet")
    assert proc.returncode == 0 and b"1 written" in proc.stdout, proc.stderr.decode()[-2000:]


# -- the manifest -------------------------------------------------------------------------------------------
def test_manifest_paths_are_confined_to_out(job, tmp_path):
    """A hand-edited manifest entry naming an output outside OUT (here a FIFO, so that opening it would hang):
    before, extract-poses opened it. Now refused, naming the manifest; nothing outside is opened."""
    src, _, secret = job
    table = tmp_path / "p.parquet"
    assert cli("extract-poses", src, table).returncode == 0
    parts = tmp_path / "p.parquet.parts"
    mpath = parts / batch.MANIFEST
    os.mkfifo(tmp_path / "trap")
    for outside in (str(tmp_path / "trap"), "../trap", str(secret), "a/../../trap"):
        m = json.loads(mpath.read_text())
        entries = m["clips"] if "clips" in m else m
        entries["clip0.bvh"]["output"] = outside
        mpath.write_text(json.dumps(m))
        proc = cli("extract-poses", src, table)
        err = proc.stderr.decode()
        assert proc.returncode == 2 and str(mpath) in err and "outside" in err, err[-2000:]
        assert_clean(proc)


@pytest.mark.parametrize("content", [b'{"clip0.bvh": 5}', b'{"clip0.bvh": {"key": 1, "output": ["x"]}}',
                                     b"[" * 100_000 + b"]" * 100_000, b"\xff\xfe not json", b'"a string"',
                                     SECRET.encode()])
def test_a_corrupt_manifest_is_a_clear_error_naming_it(job, tmp_path, content):
    """Before: AttributeError / RecursionError tracebacks (or silently ignored)."""
    src, session, _ = job
    out = tmp_path / "out"
    assert cli("batch", session, src, out).returncode == 0
    (out / batch.MANIFEST).write_bytes(content)
    kept = snapshot(out)
    proc = cli("batch", session, src, out)
    err = proc.stderr.decode()
    assert proc.returncode == 2 and str(out / batch.MANIFEST) in err and "manifest" in err, err[-2000:]
    assert_clean(proc)
    assert snapshot(out) == kept


# -- messages -----------------------------------------------------------------------------------------------
def test_no_message_or_report_quotes_a_file_that_is_not_a_clip(job, tmp_path):
    """Text files named like clips, a link to one, an AMC that is not one, and a session whose guided_warp
    reference is a text file: before, "found 'MARKER...'" in stderr and in both reports."""
    src, session, secret = job
    (src / "notes.bvh").write_text(SECRET)
    (src / "link.bvh").symlink_to(secret)
    (src / "amc").mkdir()
    (src / "amc" / "07.asf").write_text(ASF)
    (src / "amc" / "07_01.amc").write_text(SECRET)
    (src / "amc2").mkdir()
    (src / "amc2" / "08.asf").write_text(SECRET)
    (src / "amc2" / "08_01.amc").write_text(AMC)
    out = tmp_path / "out"
    proc = cli("batch", session, src, out)
    assert proc.returncode == 1
    assert_clean(proc, out)
    rows = report_rows(out)
    assert sorted(rows) == ["amc/07_01.amc", "amc2/08_01.amc", "link.bvh", "notes.bvh"]
    assert "not a BVH file" in rows["notes.bvh"] and "line 1" in rows["notes.bvh"]
    assert "not an AMC file" in rows["amc/07_01.amc"] and "not an ASF file" in rows["amc2/08_01.amc"]
    warp = json.loads(session.read_text())
    warp["ops"] = [{"op": "guided_warp", "reference": {"path": str(secret)}, "duration": 0.5}]
    (tmp_path / "warp.json").write_text(json.dumps(warp))
    proc = cli("batch", tmp_path / "warp.json", src, tmp_path / "out2")
    assert proc.returncode == 1
    assert_clean(proc, tmp_path / "out2")
    assert "reference.path" in report_rows(tmp_path / "out2")["clip0.bvh"]


def test_reader_and_session_messages_name_the_file_and_line_not_its_content(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text(SECRET)
    (tmp_path / "nul.bvh").write_bytes(b"\0\0" + MARKER.encode())
    (tmp_path / "notsession.json").write_text(json.dumps({MARKER: 1}))
    (tmp_path / "string.json").write_text(json.dumps(MARKER))
    (tmp_path / "format.json").write_text(json.dumps({"format": MARKER}))
    (tmp_path / "ok.asf").write_text(ASF)
    src = dict(Session(sn.data.load("walk").slice(0, 10)).to_json(), source={"path": str(secret)})
    (tmp_path / "src.json").write_text(json.dumps(src))
    cases = [(lambda: sn.read_bvh(secret), "line 1: expected 'HIERARCHY': not a BVH file"),
             (lambda: sn.read_bvh(tmp_path / "nul.bvh"), "line 1: expected 'HIERARCHY': not a BVH file"),
             (lambda: sn.read_asf_amc(tmp_path / "ok.asf", secret), "line 1: not an AMC file"),
             (lambda: sn.read_asf_amc(secret, secret), "line 1: not an ASF file"),
             (lambda: Session.load(secret), "not valid JSON"),
             (lambda: Session.load(tmp_path / "notsession.json"), "not a stagger_nb session file"),
             (lambda: Session.load(tmp_path / "string.json"), "not a stagger_nb session file"),
             (lambda: Session.load(tmp_path / "format.json"), "not a stagger_nb session file"),
             (lambda: Session.load(tmp_path / "src.json"), "source.path")]
    for call, want in cases:
        with pytest.raises(ValueError) as e:
            call()
        assert want in str(e.value) and MARKER not in str(e.value), str(e.value)
    # a clip's own bad token is still quoted (it is the clip's content)
    with pytest.raises(sn.BVHError, match=r"line 1: expected 'HIERARCHY', found 'MOTION'"):
        sn.io.bvh.parse_bvh(b"MOTION\nFrames: 1\n", "m.bvh")


# -- names and cells ----------------------------------------------------------------------------------------
FORMULAS = ['=HYPERLINK("evil.example","x").bvh', "+SUM(1).bvh", "@SUM(1).bvh", "-2+3.bvh",
            "\tTAB.bvh", "=cmd|'-C calc'!A0.bvh", "\rCR.bvh"]


def test_csv_cells_a_spreadsheet_would_evaluate_are_escaped(job, tmp_path):
    """Failing clips named as formulas: before, written bare into batch_report.csv (a spreadsheet runs them)."""
    src, session, _ = job
    for name in FORMULAS:
        (src / name).write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\n}\nMOTION\n"
                                "Frames: 2\nFrame Time: 0.01\n1\n")
    out = tmp_path / "out"
    proc = cli("batch", session, src, out)
    assert proc.returncode == 1
    assert_clean(proc)
    with open(out / batch.REPORT_CSV, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    assert rows[0] == list(batch.report.CSV_COLUMNS) and rows[0][:3] == ["file", "status", "line"]
    cells = [c for row in rows for c in row]
    assert not any(c[:1] in ("=", "+", "-", "@", "\t", "\r") for c in cells), cells
    assert sorted(r[0] for r in rows[1:] if r[1] == "failed") == sorted("'" + n for n in FORMULAS)
    report = json.loads((out / batch.REPORT_JSON).read_text())
    assert sorted(r["file"] for r in report["failed"]) == sorted(FORMULAS)   # JSON: the names as they are


#: Joint names a spreadsheet would evaluate (BVH names are one token: no spaces).
FORMULA_JOINTS = ["=cmd|'/Ccalc'!A0", "+SUM(1)", "-2+3", "@SUM(1)"]


def test_formula_joint_names_in_the_quality_columns_are_escaped(tmp_path):
    """The joint that pops is named as a formula: its name lands in the CSV's pop_joint column (issue 21's
    leftover: only file names were tried). Each cell is prefixed with ``'``; the JSON report keeps the name."""
    walk = sn.data.load("walk").slice(0, 60)
    ops = [{"op": "succession", "root": "LeftShoulder", "s": 0.1, "l": 4.0}]
    assert Session(walk, ops=ops).quality().added_pop_joint == "LeftArm"   # the edit pops LeftArm
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    sn.write_bvh(walk, tmp_path / "walk.bvh")
    text = (tmp_path / "walk.bvh").read_text()
    assert text.count("JOINT LeftArm\n") == 1
    for i, name in enumerate(FORMULA_JOINTS):
        (src / f"clip{i}.bvh").write_text(text.replace("JOINT LeftArm\n", f"JOINT {name}\n"))
    session = tmp_path / "s.json"
    Session(walk, ops=ops).save(session)
    proc = cli("batch", session, src, out)
    assert proc.returncode == 0, proc.stderr.decode()[-3000:]
    assert_clean(proc)
    with open(out / batch.REPORT_CSV, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert [r["file"] for r in rows] == [f"clip{i}.bvh" for i in range(len(FORMULA_JOINTS))]
    assert [r["pop_joint"] for r in rows] == ["'" + n for n in FORMULA_JOINTS]
    assert not any(c[:1] in ("=", "+", "-", "@", "\t", "\r") for r in rows for c in r.values()), rows
    for r in rows:   # the figures are numbers still (no quote before them)
        assert float(r["added_pop_deg"]) > 0 and float(r["foot_travel_cm"]) >= 0, r
    report = json.loads((out / batch.REPORT_JSON).read_text())
    assert [report["quality"][f"clip{i}.bvh"]["added_pop_joint"] for i in range(len(FORMULA_JOINTS))] == FORMULA_JOINTS


def _strict_json(path: Path):
    """The JSON at ``path`` read as a strict parser does: NaN / Infinity tokens are errors."""
    def refuse(token):
        raise AssertionError(f"{path.name}: non-standard JSON token {token}")
    return json.loads(path.read_text(), parse_constant=refuse)


def test_nan_inf_and_overflowing_values_through_the_batch_report(job, tmp_path):
    """nan / inf / -inf in a clip's MOTION: a failed clip naming the file and line; a root height of 1e308 on
    one frame (finite, but its foot travel overflows to inf): a done clip whose non-finite figures are empty
    cells in the CSV and null in the JSON, strict JSON in both reports and the manifest, its quality not ok."""
    src, session, _ = job
    text = (src / "clip0.bvh").read_text().splitlines()
    start = text.index("MOTION") + 3                          # the first frame's line (0-based)
    for name, value in (("nan", "nan"), ("inf", "inf"), ("minus_inf", "-inf")):
        lines = list(text)
        toks = lines[start + 2].split()
        toks[4] = value
        lines[start + 2] = " ".join(toks)
        (src / f"{name}.bvh").write_text("\n".join(lines) + "\n")
    lines = list(text)
    toks = lines[start + 2].split()
    toks[1] = "1e308"                                         # root Y on the third frame
    lines[start + 2] = " ".join(toks)
    (src / "huge.bvh").write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    proc = cli("batch", session, src, out)
    assert proc.returncode == 1, proc.stderr.decode()[-3000:]
    assert_clean(proc)
    failed = report_rows(out)
    assert sorted(failed) == ["inf.bvh", "minus_inf.bvh", "nan.bvh"], failed
    for name, value in (("nan", "nan"), ("inf", "inf"), ("minus_inf", "-inf")):
        assert f"{name}.bvh, line {start + 3}" in failed[f"{name}.bvh"] and repr(value) in failed[f"{name}.bvh"]
    report = _strict_json(out / batch.REPORT_JSON)
    _strict_json(out / batch.MANIFEST)
    assert sorted(report["done"]) == ["clip0.bvh", "huge.bvh", "sub/clip1.bvh"]
    q = report["quality"]["huge.bvh"]
    assert q["ok"] is False and q["foot_travel"] is None          # inf: null, not the token Infinity
    assert all(v is None or not isinstance(v, float) or math.isfinite(v) for v in q.values()), q
    with open(out / batch.REPORT_CSV, newline="", encoding="utf-8") as f:
        row = {r["file"]: r for r in csv.DictReader(f)}["huge.bvh"]
    assert row["status"] == "done" and row["quality_ok"] == "False" and row["foot_travel_cm"] == "", row
    assert not any(c.strip().lower() in ("nan", "inf", "-inf", "infinity") for c in row.values()), row


def test_write_reports_turns_non_finite_figures_into_empty_cells_and_null(tmp_path):
    """A quality row holding NaN / inf given to the report writer (a caller's report, not a batch's): strict JSON
    (null), empty CSV cells, the finite figures kept; a negative figure stays a number (no ``'`` before it)."""
    report = {"status": "finished", "done": ["a.bvh"], "skipped": [], "failed": [],
              "quality": {"a.bvh": {"ok": False, "summary": "x", "foot_travel": float("nan"),
                                    "foot_height": float("inf"), "floor": float("-inf"), "pelvis": -1.25,
                                    "added_pop": 2.0, "added_pop_joint": "@SUM(1)"}}}
    batch.report.write_reports(str(tmp_path), str(tmp_path), report)
    q = _strict_json(tmp_path / batch.REPORT_JSON)["quality"]["a.bvh"]
    assert q["foot_travel"] is None and q["foot_height"] is None and q["floor"] is None
    assert q["pelvis"] == -1.25 and q["added_pop_joint"] == "@SUM(1)"
    with open(tmp_path / batch.REPORT_CSV, newline="", encoding="utf-8") as f:
        (row,) = list(csv.DictReader(f))
    assert (row["foot_travel_cm"], row["foot_height_cm"], row["floor_cm"]) == ("", "", "")
    assert row["pelvis_cm"] == "-1.250" and row["added_pop_deg"] == "2.000" and row["pop_joint"] == "'@SUM(1)"


def test_a_failing_clip_whose_name_is_not_utf8_is_reported(job, tmp_path):
    """Before: exit 2, no CSV, no file named (UnicodeEncodeError writing the report)."""
    src, session, _ = job
    bad = os.path.join(os.fsencode(src), b"bad\xff\xfe.bvh")
    with open(bad, "wb") as f:
        f.write(b"HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n")
    out = tmp_path / "out"
    proc = cli("batch", session, src, out)
    assert proc.returncode == 1, proc.stderr.decode()[-2000:]
    assert_clean(proc)
    rows = report_rows(out)
    assert list(rows) == ["bad\\xff\\xfe.bvh"], rows
    assert b"bad\\xff\\xfe.bvh" in proc.stderr
    report = json.loads((out / batch.REPORT_JSON).read_text())
    assert [r["file"] for r in report["failed"]] == ["bad\\xff\\xfe.bvh"]
    assert (out / "clip0.bvh").is_file()


# -- disk full ----------------------------------------------------------------------------------------------
def _mount_tmpfs(where: Path, size: str) -> bool:
    where.mkdir()
    try:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                           capture_output=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return r.returncode == 0


def test_disk_full_on_a_real_tiny_tmpfs_leaves_a_report_saying_so(job, tmp_path):
    """OUT on a 512 KiB tmpfs: a first run fits; then a file of the user's fills the disk and two clips need
    running. Before: exit 2 and the previous run's report ("finished", no failure) left as it was. Now the
    report is overwritten in place (its blocks exist) to say the disk is full, and the run ends in a clear
    error; with space again, the next run goes on."""
    src, session, _ = job
    out = tmp_path / "out"
    if not _mount_tmpfs(out, "512k"):
        pytest.skip("this process may not mount a tmpfs (test_disk_full_simulated covers the same path)")
    try:
        assert cli("batch", session, src, out).returncode == 0
        fd = os.open(out / "filler.bin", os.O_WRONLY | os.O_CREAT)
        try:
            while True:
                os.write(fd, b"\0" * 4096)
        except OSError as e:
            assert e.errno == errno.ENOSPC
        finally:
            os.close(fd)
        size = (out / "filler.bin").stat().st_size
        sn.write_bvh(sn.data.load("run").slice(0, 20), src / "clip0.bvh")
        sn.write_bvh(sn.data.load("walk").slice(40, 60), src / "new.bvh")
        proc = cli("batch", session, src, out)
        err = proc.stderr.decode()
        assert proc.returncode == 2 and "Traceback" not in err and "No space left on device" in err, err[-2000:]
        report = json.loads((out / batch.REPORT_JSON).read_text())
        assert report["status"].startswith("failed: ") and "No space left on device" in report["status"]
        assert report["clips"] == 3 and (out / "filler.bin").stat().st_size == size
        os.unlink(out / "filler.bin")
        proc = cli("batch", session, src, out)
        assert proc.returncode == 0 and b"2 written, 1 skipped" in proc.stdout, proc.stderr.decode()[-2000:]
    finally:
        subprocess.run(["umount", str(out)], capture_output=True, timeout=20)


def test_disk_full_simulated_leaves_a_report_saying_so(job, tmp_path, monkeypatch):
    """The writer every atomic write goes through raises ENOSPC once 40 KB are written (in this process: the
    serial executor). The first report (small) is written before any clip; the final one does not fit, so the
    first is rewritten in place (no new blocks) to say the disk is full, and the run ends in a clear error."""
    from stagger_nb.io import _output
    src, session, _ = job
    for k in range(4):
        sn.write_bvh(sn.data.load("walk").slice(0, 30), src / f"more{k}.bvh")
    real, budget = _output._write_all, [40_000]

    def full_disk(fd, data):
        if len(data) > budget[0]:
            budget[0] = 0
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        budget[0] -= len(data)
        real(fd, data)
    monkeypatch.setattr(_output, "_write_all", full_disk)
    out = tmp_path / "out"
    with pytest.raises(ValueError, match=r"No space left on device") as e:
        batch.run_session_batch(session, src, out, executor="serial", progress=False)
    assert str(out / batch.REPORT_JSON) in str(e.value)
    report = json.loads((out / batch.REPORT_JSON).read_text())
    assert report["status"].startswith("failed: ") and "No space left on device" in report["status"]
    assert report["clips"] == 6
    result = e.value.result
    assert len(result.done) + len(result.failed) == 6 and result.failed
    assert all("No space left on device" in row["error"] for row in result.failed)
    # what the batch did write is recorded (a re-run with space again does not refuse its own outputs)
    monkeypatch.setattr(_output, "_write_all", real)
    again = batch.run_session_batch(session, src, out, executor="serial", progress=False)
    assert not again.failed and sorted(again.done + again.skipped) == sorted(result.done + [
        r["file"] for r in result.failed])
