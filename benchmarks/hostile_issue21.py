"""Issue 21 ("Nothing lost, nothing leaked") played end to end from the outside: every case of the issue built
as a hostile user would, each in its own child process with a wall-clock timeout (60 s).

Cases (``--list`` prints them):

- batch (``python -m stagger_nb batch`` / ``extract-poses``, serial unless named "distributed"): a FIFO named
  ``x.bvh``, ``.bvh`` links to a FIFO, ``/dev/zero`` and ``/dev/urandom`` among the inputs; OUT inside IN holding
  a user's file; a symlinked OUT sub-folder; a hand-edited manifest output ``/etc/passwd`` (and a FIFO: an
  open would hang) for extract-poses; corrupt manifests; a session whose guided_warp reference is a marker file;
  inputs that are (links to) marker text files; failing names ``=HYPERLINK(...)``, ``+SUM(1)``, ``@SUM(1)``...;
  a full disk (a 512 KiB tmpfs mounted over OUT in a private mount namespace, when this process may); a
  non-UTF-8 failing name; OUT an existing file.
- exports: a joint named ``<!--<script>`` through ``export_html`` of an editor, opened in headless Chromium
  (/usr/bin/chromium via playwright): canvas drawn, plots drawn, no page error.
- C: the private entry points with hostile sizes, in forked grandchildren (a crash names the call).
- editors: 12 editors of each kind opened and closed (warm-up threads left, RSS); a typed pose time of 999, a
  count of 100000, "picked", ``model.pose_time = 1e308``, ``WandEditor.model.rx = 1e308``,
  ``StaggerEditor.model.rx = 1e308`` -> a plain message, nothing recorded, the session replays, the page
  exports; 10^5 ``edit_frame`` ops -> replayed within 10 s (CPU) or refused naming the limit.

Every case also checks: no traceback and no marker string in anything the case saw (messages, stdout, stderr,
reports: the child prints each message it got, and the parent scans the child's whole output for the marker).

Usage::

    PYTHONPATH=$PWD OPENBLAS_NUM_THREADS=1 nice python benchmarks/hostile_issue21.py [--only TEXT] [--list]

Prints PASS/FAIL per case with the reason, then a table (case, area, result, wall s); exit status 1 when any
case fails.
"""
from __future__ import annotations

import argparse
import csv
import errno
import gc
import hashlib
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))   # the snapshot test_hostile_batch takes, beside the tests
import tree_snapshot
from editor_helpers import rss_mb, wait_until, warm_threads  # the editor tests' own (beside the tests)

MARKER = "MARKER-21c0-not-a-clip"
SECRET = f"{MARKER} root:*:20228:0:99999:7:::\nsecond line {MARKER}\n"
TIMEOUT = 60.0
CASES: dict = {}


class Fail(Exception):
    """A case's failure: the reason."""


def case(area: str):
    def deco(fn):
        CASES[fn.__name__] = (area, fn)
        return fn
    return deco


def check(cond, why: str):
    if not cond:
        raise Fail(why)


def seen(label: str, text) -> str:
    """Print what a case saw (the parent scans it for the marker); returns the text."""
    if isinstance(text, bytes):
        text = text.decode("utf-8", "backslashreplace")
    print(f"--- {label}: {text[-3000:]}", file=sys.stderr, flush=True)
    return text


# --------------------------------------------------------------------------------------------------
# batch helpers
# --------------------------------------------------------------------------------------------------
def cli(*args, executor="serial", timeout=50.0):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
           "OPENBLAS_NUM_THREADS": "1"}
    argv = [sys.executable, "-m", "stagger_nb", *map(os.fsdecode, args), "--no-progress"]
    if executor:
        argv += ["--executor", executor]
    try:
        p = subprocess.run(argv, capture_output=True, timeout=timeout, env=env, cwd=REPO, start_new_session=True)
    except subprocess.TimeoutExpired:
        raise Fail(f"python -m stagger_nb {args[0]} did not end within {timeout:.0f} s") from None
    text = seen(f"{args[0]} exit {p.returncode}", p.stdout + p.stderr)
    check("Traceback" not in text, f"a traceback: {text.strip().splitlines()[-1][:200]}")
    return p, text


def job(tmp: Path, n_clips: int = 2):
    import stagger_nb as sn
    from stagger_nb.session import Session
    src = tmp / "in"
    (src / "sub").mkdir(parents=True)
    walk = sn.data.load("walk")
    sn.write_bvh(walk.slice(0, 20), src / "clip0.bvh")
    if n_clips > 1:
        sn.write_bvh(walk.slice(20, 40), src / "sub" / "clip1.bvh")
    session = tmp / "s.json"
    Session(walk.slice(0, 20), ops=[{"op": "cull", "percent": 50}]).save(session)
    secret = tmp / "secret.txt"
    secret.write_text(SECRET)
    return src, session, secret


def snapshot(root: Path, skip: Path | None = None) -> dict:
    """Every entry under ``root`` (links not followed, FIFOs not opened): path -> (kind, hash / target, mtime)."""
    return tree_snapshot.snapshot(root, skip, mtimes=True)


def no_marker_under(out: Path):
    if not out.is_dir():
        return
    for folder, _, files in os.walk(out):
        for f in files:
            p = os.path.join(folder, f)
            if stat.S_ISREG(os.lstat(p).st_mode):
                with open(p, "rb") as fh:
                    check(MARKER.encode() not in fh.read(), f"the marker is in {p}")


def report_rows(folder: Path) -> dict:
    """``{file: error}`` of the failed clips' rows (the report has a row per clip, its status in a column)."""
    from stagger_nb import batch
    p = folder / batch.REPORT_CSV
    check(p.is_file(), f"no {batch.REPORT_CSV} in {folder}")
    with open(p, newline="", encoding="utf-8") as f:
        return {row["file"]: row["error"] for row in csv.DictReader(f) if row["status"] == "failed"}


def _not_regular_inputs(kind: str, executor="serial", command="batch"):
    def body(tmp: Path) -> str:
        src, session, _ = job(tmp)
        bad = []
        if kind in ("fifo", "all"):
            os.mkfifo(src / "x.bvh")
            bad.append("x.bvh")
        if kind in ("link to fifo", "all"):
            os.mkfifo(tmp / "elsewhere.fifo")
            (src / "to_fifo.bvh").symlink_to(tmp / "elsewhere.fifo")
            bad.append("to_fifo.bvh")
        if kind in ("/dev/zero", "all"):
            (src / "zero.bvh").symlink_to("/dev/zero")
            bad.append("zero.bvh")
        if kind in ("/dev/urandom", "all"):
            (src / "urandom.bvh").symlink_to("/dev/urandom")
            bad.append("urandom.bvh")
        out = tmp / "out"
        if command == "batch":
            p, _ = cli("batch", session, src, out, executor=executor)
            rows = report_rows(out)
        else:
            p, _ = cli("extract-poses", src, tmp / "p.parquet", executor=executor)
            rows = report_rows(tmp / "p.parquet.parts")
        check(p.returncode == 1, f"exit {p.returncode}, expected 1 (some clips failed)")
        check(sorted(rows) == sorted(bad), f"report lists {sorted(rows)}, expected {sorted(bad)}")
        for b in bad:
            check("not a regular file" in rows[b], f"{b}: {rows[b][:120]}")
        if command == "batch":
            check((out / "clip0.bvh").is_file() and (out / "sub" / "clip1.bvh").is_file(), "the good clips not written")
        else:
            import pyarrow.parquet as pq
            n = pq.read_table(tmp / "p.parquet").num_rows
            check(n > 0, "the table is empty")
        return f"exit 1, {', '.join(bad)} reported 'not a regular file', the two good clips done"
    return body


for _name, _kind, _ex, _cmd in [("batch_fifo_named_x_bvh", "fifo", "serial", "batch"),
                                ("batch_link_to_fifo", "link to fifo", "serial", "batch"),
                                ("batch_link_to_dev_zero", "/dev/zero", "serial", "batch"),
                                ("batch_link_to_dev_urandom", "/dev/urandom", "serial", "batch"),
                                ("batch_all_four_distributed", "all", None, "batch"),
                                ("extract_poses_all_four", "all", "serial", "extract-poses")]:
    CASES[_name] = ("batch", _not_regular_inputs(_kind, _ex, _cmd))


@case("batch")
def batch_out_inside_in_holding_a_users_file(tmp: Path) -> str:
    src, session, _ = job(tmp)
    out = src / "edited"
    out.mkdir()
    mine = b"my own notes, not written by any batch\n"
    (out / "clip0.bvh").write_bytes(mine)
    before = snapshot(tmp, skip=out)
    p, _ = cli("batch", session, src, out)
    check((out / "clip0.bvh").read_bytes() == mine, "the user's in/edited/clip0.bvh was overwritten")
    check(snapshot(tmp, skip=out) == before, "something outside OUT changed")
    check(p.returncode == 1, f"exit {p.returncode}, expected 1 (clip0 refused)")
    rows = report_rows(out)
    check(list(rows) == ["clip0.bvh"] and "not written by this batch" in rows["clip0.bvh"], f"report: {rows}")
    check((out / "sub" / "clip1.bvh").is_file(), "sub/clip1.bvh not written")
    p, _ = cli("batch", session, src, out)   # a second run: still untouched, OUT's files not taken as inputs
    check((out / "clip0.bvh").read_bytes() == mine and p.returncode == 1, "second run: overwritten or other exit")
    check(list(report_rows(out)) == ["clip0.bvh"], "second run: OUT's own files read as inputs")
    return "exit 1, the user's file untouched (twice), refused 'not written by this batch', nothing outside OUT"


@case("batch")
def batch_symlinked_out_subfolder(tmp: Path) -> str:
    src, session, _ = job(tmp)
    out, elsewhere = tmp / "out", tmp / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / "sub").symlink_to(elsewhere)
    before = snapshot(tmp, skip=out)
    p, _ = cli("batch", session, src, out)
    check(snapshot(tmp, skip=out) == before, f"written outside OUT: {sorted(os.listdir(elsewhere))}")
    check(os.listdir(elsewhere) == [], "written through the link")
    check(p.returncode == 1, f"exit {p.returncode}, expected 1")
    rows = report_rows(out)
    check(list(rows) == ["sub/clip1.bvh"] and "symbolic link" in rows["sub/clip1.bvh"], f"report: {rows}")
    check((out / "clip0.bvh").is_file(), "clip0 not written")
    return "exit 1, sub/clip1.bvh refused (a symbolic link in OUT), nothing written outside OUT"


@case("batch")
def extract_poses_manifest_output_etc_passwd(tmp: Path) -> str:
    from stagger_nb import batch
    src, _, secret = job(tmp)
    table = tmp / "p.parquet"
    p, _ = cli("extract-poses", src, table)
    check(p.returncode == 0, f"first run exit {p.returncode}")
    mpath = tmp / "p.parquet.parts" / batch.MANIFEST
    os.mkfifo(tmp / "trap")                # an output path that would hang if opened
    st0 = os.stat("/etc/passwd")
    etc = hashlib.sha256(Path("/etc/passwd").read_bytes()).hexdigest()
    for outside in ("/etc/passwd", str(tmp / "trap"), str(secret), "../../trap"):
        m = json.loads(mpath.read_text())
        entries = m["clips"] if "clips" in m else m
        entries["clip0.bvh"]["output"] = outside
        mpath.write_text(json.dumps(m))
        kept = snapshot(tmp)
        p, text = cli("extract-poses", src, table)
        check(p.returncode == 2, f"{outside}: exit {p.returncode}, expected 2")
        check(str(mpath) in text and "outside" in text, f"{outside}: the message does not name the manifest")
        check(snapshot(tmp) == kept, f"{outside}: something changed")
    check(hashlib.sha256(Path("/etc/passwd").read_bytes()).hexdigest() == etc and
          os.stat("/etc/passwd").st_mtime_ns == st0.st_mtime_ns, "/etc/passwd changed")
    return "exit 2 naming the manifest ('outside'), for /etc/passwd, a FIFO (not opened: no hang), a marker file"


@case("batch")
def batch_corrupt_manifests(tmp: Path) -> str:
    from stagger_nb import batch
    src, session, _ = job(tmp)
    out = tmp / "out"
    p, _ = cli("batch", session, src, out)
    check(p.returncode == 0, f"first run exit {p.returncode}")
    kinds = {"wrong type": b'{"clip0.bvh": 5}', "wrong field": b'{"clip0.bvh": {"key": 1, "output": ["x"]}}',
             "deep nesting": b"[" * 100_000 + b"]" * 100_000, "not UTF-8": b"\xff\xfe not json",
             "a string": b'"a string"', "a marker text": SECRET.encode(), "empty": b"",
             "v2 clips a list": b'{"format": "stagger_nb.batch_manifest", "version": 2, "clips": [1, 2]}'}
    for what, content in kinds.items():
        (out / batch.MANIFEST).write_bytes(content)
        kept = snapshot(out)
        p, text = cli("batch", session, src, out)
        check(p.returncode == 2, f"{what}: exit {p.returncode}, expected 2")
        check(str(out / batch.MANIFEST) in text and "manifest" in text, f"{what}: the manifest is not named")
        check(snapshot(out) == kept, f"{what}: OUT changed")
    return f"exit 2 naming the manifest, OUT untouched, for {len(kinds)} corrupt manifests ({', '.join(kinds)})"


@case("batch")
def batch_warp_reference_is_a_marker_file(tmp: Path) -> str:
    src, session, secret = job(tmp)
    warp = json.loads(session.read_text())
    warp["ops"] = [{"op": "guided_warp", "reference": {"path": str(secret)}, "duration": 0.5}]
    (tmp / "warp.json").write_text(json.dumps(warp))
    out = tmp / "out"
    p, text = cli("batch", tmp / "warp.json", src, out)
    no_marker_under(out)
    check(p.returncode == 1, f"exit {p.returncode}, expected 1")
    rows = report_rows(out)
    check(sorted(rows) == ["clip0.bvh", "sub/clip1.bvh"], f"report: {sorted(rows)}")
    check(all("reference.path" in e for e in rows.values()), f"report: {rows}")
    return "exit 1, each clip failed naming reference.path; no marker in stderr or reports"


@case("batch")
def batch_inputs_that_are_marker_text_files(tmp: Path) -> str:
    src, session, secret = job(tmp)
    (src / "notes.bvh").write_text(SECRET)
    (src / "link.bvh").symlink_to(secret)
    (src / "amc").mkdir()
    (src / "amc" / "07.asf").write_text(SECRET)
    (src / "amc" / "07_01.amc").write_text(SECRET)
    out = tmp / "out"
    p, _ = cli("batch", session, src, out)
    no_marker_under(out)
    p2, _ = cli("extract-poses", src, tmp / "p.parquet")
    no_marker_under(tmp / "p.parquet.parts")
    check(p.returncode == 1 and p2.returncode == 1, f"exit {p.returncode} / {p2.returncode}, expected 1")
    rows = report_rows(out)
    check(sorted(rows) == ["amc/07_01.amc", "link.bvh", "notes.bvh"], f"report: {sorted(rows)}")
    check("line 1" in rows["notes.bvh"] and "line 1" in rows["link.bvh"], f"no line named: {rows}")
    return "exit 1 (batch and extract-poses), each text file failed naming its line 1; no marker anywhere"


FORMULAS = ['=HYPERLINK("evil.example","x").bvh', "+SUM(1).bvh", "@SUM(1).bvh", "-2+3.bvh", "\tTAB.bvh",
            "\rCR.bvh", "=cmd|'-C calc'!A0.bvh"]


@case("batch")
def batch_formula_file_names(tmp: Path) -> str:
    from stagger_nb import batch
    src, session, _ = job(tmp)
    for name in FORMULAS:
        (src / name).write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\n}\nMOTION\n"
                                "Frames: 2\nFrame Time: 0.01\n1\n")
    out = tmp / "out"
    p, _ = cli("batch", session, src, out)
    check(p.returncode == 1, f"exit {p.returncode}")
    for folder in (out,):
        with open(folder / batch.REPORT_CSV, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        cells = [c for row in rows for c in row]
        bad = [c for c in cells if c[:1] in ("=", "+", "-", "@", "\t", "\r")]
        check(not bad, f"cells a spreadsheet evaluates: {bad[:3]}")
        status = rows[0].index("status")
        failed = [r[0] for r in rows[1:] if r[status] == "failed"]
        check(sorted(failed) == sorted("'" + n for n in FORMULAS), f"failed names: {failed}")
    rep = json.loads((out / batch.REPORT_JSON).read_text())
    check(sorted(r["file"] for r in rep["failed"]) == sorted(FORMULAS), "the JSON report does not keep the names")
    return f"{len(FORMULAS)} formula names each prefixed with ' in the CSV (OWASP), kept as they are in the JSON"


@case("batch")
def batch_non_utf8_failing_name(tmp: Path) -> str:
    from stagger_nb import batch
    src, session, _ = job(tmp)
    with open(os.path.join(os.fsencode(src), b"bad\xff\xfe.bvh"), "wb") as f:
        f.write(b"HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n")
    out = tmp / "out"
    p, text = cli("batch", session, src, out)
    check(p.returncode == 1, f"exit {p.returncode}, expected 1")
    rows = report_rows(out)
    check(list(rows) == ["bad\\xff\\xfe.bvh"], f"report: {rows}")
    check("bad\\xff\\xfe.bvh" in text, "stderr does not name the file")
    rep = json.loads((out / batch.REPORT_JSON).read_text())
    check([r["file"] for r in rep["failed"]] == ["bad\\xff\\xfe.bvh"], "JSON report")
    return "exit 1, the CSV, JSON and stderr name bad\\xff\\xfe.bvh"


@case("batch")
def batch_out_is_an_existing_file(tmp: Path) -> str:
    src, session, _ = job(tmp)
    out = tmp / "out"
    out.write_text("a file\n")
    p, text = cli("batch", session, src, out)
    check(p.returncode == 2 and f"{out}: " in text, f"exit {p.returncode}; OUT not named")
    check(out.read_text() == "a file\n", "OUT (a file) changed")
    (tmp / "t.parquet.parts").write_text("x")
    p, text = cli("extract-poses", src, tmp / "t.parquet")
    check(p.returncode == 2 and "t.parquet.parts" in text, f"extract-poses: exit {p.returncode}")
    check((tmp / "t.parquet.parts").read_text() == "x", "the parts file changed")
    return "exit 2 naming OUT (batch) and OUT.parquet.parts (extract-poses), both files untouched"


def _mount_tmpfs(where: Path, size: str) -> str | None:
    """None when a tmpfs is mounted over ``where``, else why not."""
    try:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                           capture_output=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"mount: {e}"
    return None if r.returncode == 0 else f"mount -t tmpfs: {r.stderr.decode(errors='replace').strip()}"


@case("batch")
def batch_disk_full_tiny_tmpfs(tmp: Path) -> str:
    """Run by the parent under ``unshare -m`` (a private mount namespace: the mount ends with the child)."""
    import stagger_nb as sn
    from stagger_nb import batch
    src, session, _ = job(tmp)
    out = tmp / "out"
    out.mkdir()
    why = _mount_tmpfs(out, "512k")
    if why:
        raise Fail(f"NOT RUN: {why} (tests/test_hostile_batch.py simulates ENOSPC instead)")
    try:
        p, _ = cli("batch", session, src, out)
        check(p.returncode == 0, f"first run exit {p.returncode}")
        fd = os.open(out / "filler.bin", os.O_WRONLY | os.O_CREAT)
        try:
            while True:
                os.write(fd, b"\0" * 4096)
        except OSError as e:
            check(e.errno == errno.ENOSPC, f"filling: {e}")
        finally:
            os.close(fd)
        size = (out / "filler.bin").stat().st_size
        sn.write_bvh(sn.data.load("run").slice(0, 20), src / "clip0.bvh")
        sn.write_bvh(sn.data.load("walk").slice(40, 60), src / "new.bvh")
        p, text = cli("batch", session, src, out)
        check(p.returncode == 2 and "No space left on device" in text, f"full: exit {p.returncode}")
        rep = json.loads((out / batch.REPORT_JSON).read_text())
        check(rep["status"].startswith("failed: ") and "No space left" in rep["status"], f"report: {rep['status']}")
        check((out / "filler.bin").stat().st_size == size, "the user's file changed")
        os.unlink(out / "filler.bin")
        p, text = cli("batch", session, src, out)
        check(p.returncode == 0 and "2 written, 1 skipped" in text, f"with space again: exit {p.returncode}")
    finally:
        subprocess.run(["umount", "-l", str(out)], capture_output=True, timeout=20)
    return "512 KiB tmpfs over OUT, filled: exit 2 'No space left on device', the report says so; freed: 2 written"


# --------------------------------------------------------------------------------------------------
# exports
# --------------------------------------------------------------------------------------------------
def _export_pages(tmp: Path, which: str) -> str:
    import stagger_nb as sn
    from stagger_nb.widgets import StaggerEditor, export_html
    if not Path("/usr/bin/chromium").is_file():
        raise Fail("NOT RUN: /usr/bin/chromium is missing")
    from playwright.sync_api import sync_playwright
    run = sn.data.load("run")
    names = list(run.skeleton.names)
    names[names.index("LeftForeArm")] = "<!--<script>"
    names[names.index("RightForeArm")] = "</script><!--"
    sk = run.skeleton
    run = run.replace(skeleton=sn.Skeleton(tuple(names), sk.parents, sk.offsets, channels=sk.channels,
                                           end_sites=sk.end_sites))
    path = tmp / "w.bvh"
    sn.write_bvh(run, path)
    run = sn.read_bvh(path)                             # the round trip keeps the names
    check("<!--<script>" in run.skeleton.names, "the BVH round trip lost the joint name")
    editor = StaggerEditor(run, precompute=False)
    editor.model.s = 0.05
    t0 = time.perf_counter()
    pages = ([export_html(editor, tmp / "editor.html", title="<!-- a </script> title")] if which == "editor" else
             [export_html(run, tmp / "motion.html"), export_html(editor.session, tmp / "session.html")])
    seen("export", f"{len(pages)} pages written in {time.perf_counter() - t0:.1f} s")
    n_figs = len(editor.figures())
    editor.close()
    got = []
    args = ["--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking"]
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", headless=True, args=args, timeout=30000)
        try:
            for page_path in pages:
                errors: list = []
                page = browser.new_page(viewport={"width": 1280, "height": 800})
                page.on("pageerror", lambda e: errors.append(str(e)[:200]))
                page.on("console", lambda m: errors.append(m.text[:200]) if m.type == "error" else None)
                page.goto(page_path.as_uri(), wait_until="load", timeout=30000)
                page.wait_for_function("() => document.body.dataset.ready === '1' || document.body.dataset.error",
                                       timeout=30000)
                shown = page.evaluate("() => document.body.dataset.error || null")
                check(shown is None, f"{page_path.name}: the page shows an error: {shown}")
                page.wait_for_selector("#sn-view canvas", timeout=15000)
                page.wait_for_timeout(500)
                png = page.locator("#sn-view canvas").screenshot()
                from io import BytesIO

                from PIL import Image, ImageStat
                dev = max(ImageStat.Stat(Image.open(BytesIO(png)).convert("RGB")).stddev)
                n_plots = page.locator(".sn-plot").count()
                drawn = page.evaluate("() => document.querySelectorAll('.sn-plot .main-svg').length")
                traces = page.locator(".sn-plot .scatterlayer .trace").count()
                check(dev > 5, f"{page_path.name}: the canvas is blank (stddev {dev:.1f})")
                if page_path.name == "editor.html":
                    check(n_plots == n_figs > 0 and drawn >= n_plots and traces > 0,
                          f"editor.html: {n_plots} plot divs, {drawn} drawn, {traces} traces ({n_figs} figures)")
                check(not errors, f"{page_path.name}: page errors {errors[:2]}")
                seen("page", f"{page_path.name} checked at {time.perf_counter() - t0:.1f} s")
                got.append(f"{page_path.name}: canvas stddev {dev:.0f}, {n_plots} plots {traces} traces")
                page.close()
        finally:
            browser.close()
    return "; ".join(got) + "; no page error"


CASES["export_html_editor_page_comment_joint_name_in_chromium"] = ("exports", lambda t: _export_pages(t, "editor"))
CASES["export_html_motion_session_pages_comment_joint_name"] = ("exports", lambda t: _export_pages(t, "motion"))


# --------------------------------------------------------------------------------------------------
# C entry points
# --------------------------------------------------------------------------------------------------
def _forked(calls, timeout=40.0):
    """Run ``calls`` (description, thunk) in a forked grandchild that announces each: (counts, crash or None)."""
    import select
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        try:
            for k, (_, thunk) in enumerate(calls):
                os.write(w, f"call {k}\n".encode())
                try:
                    thunk()
                    outcome = "ok"
                except Exception as e:
                    outcome = type(e).__name__
                os.write(w, f"done {k} {outcome}\n".encode())
        finally:
            os._exit(0)
    os.close(w)
    buf = b""
    end = time.monotonic() + timeout
    while True:
        ready, _, _ = select.select([r], [], [], max(0.0, end - time.monotonic()))
        if not ready:
            os.kill(pid, signal.SIGKILL)
            break
        chunk = os.read(r, 65536)
        if not chunk:
            break
        buf += chunk
    os.close(r)
    status = os.waitpid(pid, 0)[1]
    lines = buf.decode().splitlines()
    counts: dict = {}
    for ln in lines:
        if ln.startswith("done "):
            counts[ln.split()[2]] = counts.get(ln.split()[2], 0) + 1
    if os.WIFSIGNALED(status) or not lines or not lines[-1].startswith(f"done {len(calls) - 1} "):
        last = next((int(ln.split()[1]) for ln in reversed(lines) if ln.startswith("call ")), None)
        return counts, (f"signal {os.WTERMSIG(status)}" if os.WIFSIGNALED(status) else f"status {status}") + \
            f" during {calls[last][0] if last is not None else 'the first call'}"
    return counts, None


@case("C")
def c_entry_points_hostile_sizes(tmp: Path) -> str:
    import numpy as np

    from stagger_nb.io import bvh_block
    from stagger_nb.staggered import _kernels
    cparse, cspline = bvh_block._cparse, _kernels._cspline
    if cparse is None or cspline is None:
        raise Fail("NOT RUN: the C extensions are not built")

    def block(**change):
        rng = np.random.default_rng(0)
        P, M, n = 3, 4, 5
        ctrl = rng.normal(size=(16, P))
        ctrl /= np.linalg.norm(ctrl.reshape(4, 4, P), axis=1).repeat(4, axis=0)
        kw = dict(stage=0, ctrl=ctrl, arcp=np.abs(rng.normal(size=(9, P))) % 1.0,
                  table=rng.normal(size=(3, P * M)) * 0.1, counts=np.full(P, M, np.int64), M=M,
                  idx=rng.integers(0, P, n).astype(np.int64), t=rng.uniform(0, 1, n), out=np.zeros((4, n)), so=n,
                  work=np.zeros((56, n)), taylor=_kernels._TAYLOR_ARR.copy(), limits=_kernels._LIMITS_ARR.copy())
        for k, v in change.items():
            kw[k] = v(kw[k]) if callable(v) else v
        order = ["stage", "ctrl", "arcp", "table", "counts", "M", "idx", "t", "out", "so", "work", "taylor", "limits"]
        return lambda: cspline.rotations_block(*[kw[k] for k in order])

    def with_item(i, v):
        def f(a):
            a = a.copy()
            a.reshape(-1)[i] = v
            return a
        return f
    hostile = {"so = (2**63-1)//3 + 1 (3 so + n wraps)": block(so=(2**63 - 1) // 3 + 1),
               "so = 2**62": block(so=2**62), "so = 2**61 + 1": block(so=2**61 + 1), "so = -1": block(so=-1),
               "M wraps P M 24": block(M=2**64 // 72 + 1), "M = 2**62": block(M=2**62),
               "t NaN": block(t=with_item(2, np.nan)), "t = -3": block(t=with_item(2, -3.0)),
               "t = 1e300": block(t=with_item(1, 1e300)), "idx -1": block(idx=with_item(0, -1)),
               "idx 2**62": block(idx=with_item(0, 2**62)), "counts 2**62": block(counts=with_item(0, 2**62)),
               "out too short": block(out=np.zeros((4, 2))), "work too short": block(work=np.zeros((56, 1))),
               "stage 7": block(stage=7), "t float32": block(t=lambda a: a.astype(np.float32)),
               "make_continuous(zeros(8), 2**62)": lambda: cparse.make_continuous(np.zeros(8), 2**62),
               "make_continuous(zeros(8), 2**63-1)": lambda: cparse.make_continuous(np.zeros(8), 2**63 - 1),
               "make_continuous(zeros(8), -1)": lambda: cparse.make_continuous(np.zeros(8), -1),
               "make_continuous(zeros(8), 0)": lambda: cparse.make_continuous(np.zeros(8), 0),
               "make_continuous(zeros(8), 3)": lambda: cparse.make_continuous(np.zeros(8), 3),
               "make_continuous(float32)": lambda: cparse.make_continuous(np.zeros(8, np.float32), 2),
               "parse_rows rows 2**62": lambda: cparse.parse_rows(b"1 2 3\n", 0, 6, 2**62, np.zeros(3),
                                                                  np.zeros(3, np.int64), np.ones(3, np.int64)),
               "parse_rows stride 2**62": lambda: cparse.parse_rows(b"1 2 3\n", 0, 6, 1, np.zeros(3),
                                                                    np.zeros(3, np.int64),
                                                                    np.full(3, 2**62, np.int64)),
               "parse_rows stop past the text": lambda: cparse.parse_rows(b"1 2 3\n", 0, 2**62, 1, np.zeros(3),
                                                                          np.zeros(3, np.int64),
                                                                          np.ones(3, np.int64)),
               "quats_from_tangents out too short": lambda: cparse.quats_from_tangents(np.zeros(6), "ZXY",
                                                                                       np.zeros((1, 4)))}
    calls = [(k, v) for k, v in hostile.items()]
    counts, crash = _forked(calls)
    check(crash is None, f"crashed: {crash}")
    check(set(counts) <= {"ValueError", "TypeError"}, f"outcomes {counts} (expected every call refused)")
    # and a valid call still works (the checks refuse only what is wrong)
    counts2, crash2 = _forked([("valid rotations_block", block()),
                               ("valid make_continuous", lambda: cparse.make_continuous(np.zeros(8), 2))])
    check(crash2 is None and counts2 == {"ok": 2}, f"valid calls: {counts2} {crash2}")
    return f"{len(calls)} hostile calls each refused ({counts}), no crash; valid calls still run"


# --------------------------------------------------------------------------------------------------
# editors
# --------------------------------------------------------------------------------------------------
def _twelve_editors(kind_name: str):
    def body(tmp: Path) -> str:
        import weakref

        import stagger_nb as sn
        from stagger_nb import widgets
        kind = getattr(widgets, kind_name)
        m = sn.data.load("walk").slice(0, 200)
        kind(m).close()                       # imports and first-use allocations before measuring
        wait_until(lambda: not warm_threads(), 20)
        gc.collect()
        rss0, threads0 = rss_mb(), threading.active_count()
        for _ in range(12):
            kind(m).close()
        one = wait_until(lambda: len(warm_threads()) <= 1, 20)
        gc.collect()
        left, all_left, rss1 = len(warm_threads()), threading.active_count(), rss_mb()
        check(one, f"{len(warm_threads())} warm-up threads alive 20 s after 12 {kind_name}s closed")
        check(all_left - threads0 <= 1, f"threads {threads0} -> {all_left} after 12 {kind_name}s")
        check(rss1 - rss0 < 200, f"RSS {rss0:.0f} -> {rss1:.0f} MB")
        # closed then dropped: garbage-collected (nothing of the package keeps it alive)
        ed = kind(m)
        ed.close()
        ref = weakref.ref(ed)
        del ed
        check(wait_until(lambda: gc.collect() >= 0 and ref() is None, 20), "a closed, dropped editor is not collected")
        # dropped without close() (a re-run cell: ipywidgets' registry keeps the widget): its warm-up still ends
        kind(m)
        check(wait_until(lambda: len(warm_threads()) <= 1, 30),
              f"{len(warm_threads())} warm-up threads 30 s after an unclosed editor was dropped")
        return (f"12 closed: warm-up threads left {left}, all threads {threads0} -> {all_left}, RSS {rss0:.0f} -> "
                f"{rss1:.0f} MB; a closed dropped editor collected; an unclosed one's warm-up ended")
    return body


for _kind in ("StaggerEditor", "WandEditor", "WarpEditor"):
    CASES[f"editors_12_{_kind}_opened_and_closed"] = ("editors", _twelve_editors(_kind))


def from_browser(widget, **state) -> None:
    widget._handle_msg({"content": {"data": {"method": "update", "state": state, "buffer_paths": []}}, "buffers": []})


RAW = ("ops[", "Error", "Exception", "zero-size array", "got shape", "math domain", "Traceback")


def _still_replays(ed, tmp: Path, label: str) -> str:
    """The editor's session saves, loads and replays; its page exports; a valid change is recorded."""
    from stagger_nb.session import Session
    from stagger_nb.widgets import export_html
    check(not ed.error, f"{label}: the editor shows an error: {ed.error[:200]}")
    p = tmp / f"{label}.json"
    ed.session.save(p)
    again = Session.load(p, source=ed.session.source)
    edited = again.edited()
    check(edited.num_frames > 0, f"{label}: the saved session does not replay")
    ed.session.edited()
    page = export_html(ed, tmp / f"{label}.html")
    check(page.stat().st_size > 1000, f"{label}: the page does not export")
    return f"session of {len(ed.session.ops)} ops replays, page exported"


def _refused_plainly(ed, label: str, ops0, sentence_words=()) -> str:
    text = seen(f"{label} message", ed.message.value)
    import html
    import re
    plain = html.unescape(re.sub(r"<[^>]*>", "", text))
    check(plain.strip(), f"{label}: no message shown")
    for w in RAW:
        check(w not in plain, f"{label}: raw text {w!r} in the message: {plain[:200]}")
    for w in sentence_words:
        check(w in plain, f"{label}: {w!r} not in the message: {plain[:200]}")
    check(ed.session.ops == ops0, f"{label}: ops changed to {ed.session.ops}")
    return plain


def _editor_case(kind: str, action):
    def body(tmp: Path) -> str:
        import traitlets

        import stagger_nb as sn
        from stagger_nb import widgets
        walk = sn.data.load("walk")
        ed = getattr(widgets, kind)(walk, precompute=False) if kind != "WarpEditor" else widgets.WarpEditor(walk)
        try:
            ops0 = ed.session.ops
            try:
                words = action(ed)
                plain = _refused_plainly(ed, kind, ops0, words)      # typed: the message line says why
            except traitlets.TraitError as e:                       # set on the model: the TraitError says why
                plain = seen("TraitError", str(e))
                for w in RAW:
                    check(w not in plain or w == "Error", f"raw text {w!r} in the TraitError: {plain[:200]}")
                for w in getattr(action, "words", ()):
                    check(w in plain, f"{w!r} not in the TraitError: {plain[:200]}")
                check(ed.session.ops == ops0, f"ops changed to {ed.session.ops}")
            # the next valid change applies, the message clears, the session replays
            if kind == "StaggerEditor" and ed.model.cull_by == "count":
                ed.model.count = 5
            elif kind == "StaggerEditor":
                ed.model.percent = 50.0
            else:
                ed.model.sigma = ed.model.sigma * 1.5 if kind == "WandEditor" else ed.model.sigma
                if kind == "WandEditor":
                    ed.model.rx = 12.0
                else:
                    ed.model.duration = round(ed.model.duration * 0.8, 2)
            check(ed.session.ops != ops0, "the next valid change is not recorded")
            rest = _still_replays(ed, tmp, kind)
            return f"refused: '{plain.strip()[:90]}'; next change recorded; {rest}"
        finally:
            ed.close()
    return body


def _typed_pose_time(ed):
    ed.model.pose = 2
    from_browser(ed.controls["pose_time"], value=999.0)
    return ("pose time must lie between",)


def _typed_count(ed):
    from_browser(ed.controls["cull_by"], index=1)   # "by count"
    from_browser(ed.controls["count"], value=100000)
    return ("count",)


def _model_pose_time(ed):
    ed.model.pose = 2
    ed.model.pose_time = 1e308
    return _model_pose_time.words


def _model_rx(ed):
    ed.model.rx = 1e308
    return _model_rx.words


_model_pose_time.words = ("pose time must lie between",)
_model_rx.words = ("360",)


for _name, _kind, _act in [("stagger_typed_pose_time_999", "StaggerEditor", _typed_pose_time),
                           ("stagger_typed_count_100000", "StaggerEditor", _typed_count),
                           ("stagger_model_pose_time_1e308", "StaggerEditor", _model_pose_time),
                           ("stagger_model_rx_1e308", "StaggerEditor", _model_rx),
                           ("wand_model_rx_1e308", "WandEditor", _model_rx)]:
    CASES[_name] = ("editors", _editor_case(_kind, _act))


@case("editors")
def stagger_choose_picked_after_a_retime(tmp: Path) -> str:
    import stagger_nb as sn
    from stagger_nb.widgets import StaggerEditor
    ed = StaggerEditor(sn.data.load("walk"), precompute=False)
    try:
        ed.model.percent = 50.0
        ed.model.pose = 2
        ed.model.pose_time = 0.5 * (ed.model.pose_times[1] + ed.model.pose_times[2])
        before = list(ed.session.staggered().pose_times)
        ops_before = [o for o in ed.session.ops if o["op"] == "retime"]
        for index, mode in ((2, "picked"), (1, "by count"), (0, "by %")):
            from_browser(ed.controls["cull_by"], index=index)
            seen(f"{mode} message", ed.message.value + ed.error)
            check(not ed.error, f"{mode}: {ed.error[:200]}")
            check(list(ed.session.staggered().pose_times) == before, f"{mode}: the poses changed")
            check([o for o in ed.session.ops if o["op"] == "retime"] == ops_before, f"{mode}: the retime changed")
        rest = _still_replays(ed, tmp, "picked")
        return f"'picked', 'by count', 'by %' after a retime: same poses, no error; {rest}"
    finally:
        ed.close()


@case("editors")
def session_1e5_edit_frame_ops(tmp: Path) -> str:
    import stagger_nb as sn
    from stagger_nb.session import Session
    walk = sn.data.load("walk")
    names = walk.skeleton.names
    ops = [{"op": "edit_frame", "frame": k % walk.num_frames, "deltas": {names[1 + k % 30]: [1e-3, 0.0, 0.0]}}
           for k in range(100_000)]
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        s = Session(walk, ops)
        got = s.edited()
    except ValueError as e:
        msg = seen("refused", str(e))
        check("100000" in msg.replace(",", "") or "limit" in msg, f"refused without naming the limit: {msg[:200]}")
        return f"refused in {time.perf_counter() - w0:.1f} s: {msg[:120]}"
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    check(got.num_frames == walk.num_frames, "wrong frames")
    # a hostile session file with the same ops loads and replays too
    p = tmp / "many.json"
    s.save(p)
    c1 = time.process_time()
    Session.load(p).edited()
    cpu2 = time.process_time() - c1
    check(cpu <= 10 and cpu2 <= 10, f"replay CPU {cpu:.1f} s / from file {cpu2:.1f} s (budget 10 s)")
    return f"10^5 edit_frame ops replayed: CPU {cpu:.1f} s (wall {wall:.1f} s); loaded from a file: CPU {cpu2:.1f} s"


# --------------------------------------------------------------------------------------------------
# driver
# --------------------------------------------------------------------------------------------------
def run_child(name: str, tmp: str) -> int:
    area, fn = CASES[name]
    t0 = time.perf_counter()
    try:
        why = fn(Path(tmp))
        ok = True
    except Fail as e:
        why, ok = str(e), False
    except BaseException as e:
        import traceback
        tb = traceback.format_exc().strip().splitlines()
        why, ok = f"unexpected {type(e).__name__}: {str(e)[:300]} ({tb[-3].strip() if len(tb) > 2 else ''})", False
    print("RESULT " + json.dumps({"ok": ok, "why": why, "seconds": time.perf_counter() - t0}), flush=True)
    sys.stdout.flush()
    os._exit(0)   # no interpreter teardown waiting on threads: the parent's timeout measures the case


def run_case(name: str, seconds: float) -> dict:
    tmp = tempfile.mkdtemp(prefix=f"h21-{name[:20]}-")
    argv = [sys.executable, str(Path(__file__).resolve()), "--case", name, "--tmp", tmp]
    if name == "batch_disk_full_tiny_tmpfs" and shutil.which("unshare"):
        argv = ["unshare", "-m", "--propagation", "private"] + argv
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
                            env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    try:
        out, err = proc.communicate(timeout=seconds)
        timed_out = False
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        timed_out = True
    wall = time.perf_counter() - t0
    text = (out + err).decode("utf-8", "backslashreplace")
    res = None
    for line in out.decode("utf-8", "backslashreplace").splitlines():
        if line.startswith("RESULT "):
            res = json.loads(line[7:])
    if timed_out:
        res = {"ok": False, "why": f"did not end within {seconds:.0f} s"}
    elif res is None:
        res = {"ok": False, "why": f"the child died (exit {proc.returncode}): {text.strip()[-300:]}"}
    if MARKER in text or MARKER in res["why"]:
        res = {"ok": False, "why": "the marker string was in what the case saw; " + res["why"]}
    if name == "batch_disk_full_tiny_tmpfs" and argv[0] != "unshare":   # a child killed before its umount
        subprocess.run(["umount", "-l", os.path.join(tmp, "out")], capture_output=True, timeout=20)
    shutil.rmtree(tmp, ignore_errors=True)
    res.update(name=name, area=CASES[name][0], wall=wall,
               status="NOT RUN" if res["why"].startswith("NOT RUN") else ("PASS" if res["ok"] else "FAIL"))
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case")
    ap.add_argument("--tmp")
    ap.add_argument("--only", default=None, help="run the cases whose name contains this text")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--seconds", type=float, default=TIMEOUT)
    a = ap.parse_args()
    if a.case:
        return run_child(a.case, a.tmp)
    names = [n for n in CASES if a.only is None or a.only in n]
    if a.list:
        print("\n".join(f"{CASES[n][0]:8s} {n}" for n in names))
        return 0
    results = []
    for n in names:
        r = run_case(n, a.seconds)
        results.append(r)
        print(f"{r['status']:7s} {n} ({r['wall']:.1f} s): {r['why']}", flush=True)
    print()
    w = max(len(r["name"]) for r in results)
    print(f"| {'case':{w}s} | area    | result  | wall s |")
    print(f"|{'-' * (w + 2)}|---------|---------|--------|")
    for r in results:
        print(f"| {r['name']:{w}s} | {r['area']:7s} | {r['status']:7s} | {r['wall']:6.1f} |")
    n_fail = sum(r["status"] == "FAIL" for r in results)
    n_not = sum(r["status"] == "NOT RUN" for r in results)
    print(f"\n{len(results)} cases: {len(results) - n_fail - n_not} pass, {n_fail} fail, {n_not} not run")
    return 1 if n_fail else 0


if __name__ == "__main__":
    sys.exit(main())
