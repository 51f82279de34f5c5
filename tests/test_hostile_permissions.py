"""Permission-denied inputs and a read-only OUT, tried as a user who is not root (issue 21's leftovers).

The shell and CI run as root, for whom ``chmod`` denies nothing, so every case runs in a forked child that has
given up root (``setgroups([])``, ``setresgid`` / ``setresuid`` to ``nobody``, 65534) — what ``setpriv --reuid=65534
--regid=65534 --clear-groups`` does, done in-process because the interpreter lives under /root (mode 0700), which
``nobody`` cannot read, so ``setpriv ... python`` cannot even start it. The child first runs a batch and an
extraction as root on readable files, so every module the command line imports lazily is loaded before the
drop; it then runs each case through ``python -m stagger_nb``'s ``main`` (serial, no progress bar), its stdout and
stderr captured. The child has a timeout (``run_forked``): a hang fails the test. Run as a user who is not root,
the same cases run without the drop.

Every case must end in a clean error (exit 2, one ``error:`` line naming the file or folder and the cause) or a
report that names each clip it could not read or write (exit 1), never a traceback, never a clip silently left
out, and nothing written where the user may not write."""
from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import shutil
import tempfile
import traceback
from pathlib import Path

import pytest
from conftest import run_forked

import stagger_nb as sn
from stagger_nb import batch
from stagger_nb.session import Session

NOBODY = 65534
OPS = [{"op": "cull", "percent": 50}]
TIMEOUT = 120


def _cli(argv: list) -> dict:
    """``python -m stagger_nb ARGV --executor serial --no-progress`` in this process: exit status, stdout,
    stderr; an exception the command line lets through is ``rc="raised"`` with its traceback in stderr."""
    from stagger_nb.__main__ import main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main([*map(str, argv), "--executor", "serial", "--no-progress"])
        except BaseException:
            rc = "raised"
            err.write(traceback.format_exc())
    return {"rc": rc, "stdout": out.getvalue(), "stderr": err.getvalue()}


def _tree(base: Path) -> dict:
    """The folders and files of the cases, owned by root (the test process) with the modes below."""
    walk = sn.data.load("walk")
    clip0, clip1 = walk.slice(0, 20), walk.slice(20, 40)

    def folder(p: Path, mode: int) -> Path:
        p.mkdir(parents=True, exist_ok=True)
        os.chmod(p, mode)
        return p

    def clip(p: Path, motion, mode: int = 0o644) -> None:
        sn.write_bvh(motion, p)
        os.chmod(p, mode)

    folder(base, 0o755)
    Session(clip0, ops=OPS).save(base / "s.json")
    os.chmod(base / "s.json", 0o644)
    shutil.copy(base / "s.json", base / "s_locked.json")
    os.chmod(base / "s_locked.json", 0o600)              # root's: nobody may not read it
    # in/: a readable clip, an unreadable clip, an unreadable (unlistable) folder holding a clip
    folder(base / "in", 0o755)
    clip(base / "in" / "clip0.bvh", clip0)
    clip(base / "in" / "locked.bvh", clip1, 0o000)
    folder(base / "in" / "shut", 0o755)
    clip(base / "in" / "shut" / "clip2.bvh", clip1)
    os.chmod(base / "in" / "shut", 0o700)
    # ok/: two readable clips (one in sub/)
    folder(base / "ok" / "sub", 0o755)
    os.chmod(base / "ok", 0o755)
    clip(base / "ok" / "clip0.bvh", clip0)
    clip(base / "ok" / "sub" / "clip1.bvh", clip1)
    for name in ("out_free", "out_free2", "out_free3", "out_sub_ro"):
        folder(base / name, 0o777)                       # anyone may write here
    folder(base / "out_sub_ro" / "sub", 0o755)          # ... but not in sub/, root's
    folder(base / "out_ro", 0o755)                       # root's: nobody may not write
    folder(base / "ro_parent", 0o755)
    folder(base / "warm", 0o755)
    return {
        "denied_input": ["batch", base / "s.json", base / "in", base / "out_free"],
        "locked_session": ["batch", base / "s_locked.json", base / "ok", base / "out_free2"],
        "ro_out": ["batch", base / "s.json", base / "ok", base / "out_ro"],
        "ro_parent": ["batch", base / "s.json", base / "ok", base / "ro_parent" / "new"],
        "ro_subfolder": ["batch", base / "s.json", base / "ok", base / "out_sub_ro"],
        "extract_denied": ["extract-poses", base / "in", base / "out_free3" / "poses.parquet"],
        "extract_ro": ["extract-poses", base / "ok", base / "out_ro" / "poses.parquet"],
    }


@pytest.fixture(scope="module")
def nonroot():
    """``(base, {case: {"rc", "stdout", "stderr"}})``: every case run once, as nobody, in one forked child."""
    base = Path(tempfile.mkdtemp(prefix="stagger_nb_nonroot_"))   # /tmp: nobody can reach it (pytest's tmp_path
    try:                                                           # sits in a folder only root may enter)
        cases = _tree(base)
        warm = [["batch", base / "s.json", base / "ok", base / "warm" / "out"],
                ["extract-poses", base / "ok", base / "warm" / "poses.parquet"]]

        def body(send):
            try:
                for argv in warm:   # as root: imports everything the command line loads lazily
                    if _cli(argv)["rc"] != 0:
                        raise RuntimeError(f"the warm-up run {argv[0]} failed")
                if os.geteuid() == 0:
                    os.setgroups([])
                    os.setresgid(NOBODY, NOBODY, NOBODY)
                    os.setresuid(NOBODY, NOBODY, NOBODY)
                res = {"uid": os.geteuid(), "cases": {k: _cli(a) for k, a in cases.items()}}
            except BaseException as e:
                res = {"setup_error": f"{type(e).__name__}: {e}"}
            send(json.dumps(res))

        text, status = run_forked(body, TIMEOUT)
        assert status == 0, f"the child ended with status {status}: {text[-2000:]}"
        res = json.loads(text)
        if "setup_error" in res and "Operation not permitted" in res["setup_error"]:
            pytest.skip(f"cannot give up root in this container to test as a user who is not root: "
                        f"{res['setup_error']}")
        assert "setup_error" not in res, res
        assert res["uid"] != 0
        yield base, res["cases"]
    finally:
        for folder, dirs, _ in os.walk(base):   # root may remove anything; make the folders listable first
            for d in dirs:
                os.chmod(os.path.join(folder, d), 0o755)
        shutil.rmtree(base, ignore_errors=True)


def assert_clean(res: dict, rc: int) -> str:
    text = res["stdout"] + res["stderr"]
    assert res["rc"] == rc, text[-3000:]
    assert "Traceback" not in text, text[-3000:]
    return text


def failed_rows(out: Path) -> dict:
    with open(out / batch.REPORT_CSV, newline="", encoding="utf-8") as f:
        return {r["file"]: r["error"] for r in csv.DictReader(f) if r["status"] == "failed"}


def test_unreadable_clips_and_folders_are_failed_clips_named_with_the_cause(nonroot):
    base, cases = nonroot
    text = assert_clean(cases["denied_input"], 1)
    out = base / "out_free"
    failed = failed_rows(out)
    assert set(failed) == {"locked.bvh", "shut/"}, failed        # the unlistable folder is not silently left out
    for rel, error in failed.items():
        assert "permission denied" in error.lower(), (rel, error)
        assert str(base / "in" / rel.rstrip("/")) in error, (rel, error)
        assert rel.rstrip("/") in text
    assert (out / "clip0.bvh").is_file()
    report = json.loads((out / batch.REPORT_JSON).read_text())
    assert report["done"] == ["clip0.bvh"]


def test_an_unreadable_session_file_is_a_clear_error(nonroot):
    base, cases = nonroot
    text = assert_clean(cases["locked_session"], 2)
    assert str(base / "s_locked.json") in text and "permission denied" in text.lower(), text
    assert os.listdir(base / "out_free2") == []


@pytest.mark.parametrize("case, folder", [("ro_out", "out_ro"), ("ro_parent", "ro_parent")])
def test_an_output_folder_nobody_may_write_is_a_clear_error_and_nothing_is_written(nonroot, case, folder):
    base, cases = nonroot
    text = assert_clean(cases[case], 2)
    errors = [line for line in cases[case]["stderr"].splitlines() if line.startswith("error:")]
    assert len(errors) == 1, text
    assert str(base / folder) in errors[0] and "permission denied" in errors[0].lower(), errors
    assert os.listdir(base / folder) == []


def test_an_output_subfolder_nobody_may_write_fails_its_clips_only(nonroot):
    base, cases = nonroot
    assert_clean(cases["ro_subfolder"], 1)
    out = base / "out_sub_ro"
    failed = failed_rows(out)
    assert list(failed) == ["sub/clip1.bvh"], failed
    assert str(out / "sub") in failed["sub/clip1.bvh"] and "permission denied" in failed["sub/clip1.bvh"].lower()
    assert (out / "clip0.bvh").is_file() and os.listdir(out / "sub") == []
    assert json.loads((out / batch.REPORT_JSON).read_text())["done"] == ["clip0.bvh"]


def test_extract_poses_reports_unreadable_clips_and_refuses_a_read_only_table_folder(nonroot):
    import pyarrow.parquet as pq
    base, cases = nonroot
    text = assert_clean(cases["extract_denied"], 1)
    assert "locked.bvh" in text and "shut" in text, text
    table = pq.read_table(base / "out_free3" / "poses.parquet")
    assert set(table.column("clip").to_pylist()) == {"clip0.bvh"}
    text = assert_clean(cases["extract_ro"], 2)
    assert str(base / "out_ro") in text and "permission denied" in text.lower(), text
    assert os.listdir(base / "out_ro") == []
