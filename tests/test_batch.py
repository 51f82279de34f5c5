"""Batch jobs on Dask (issue 15): a real 2-process LocalCluster gives the serial run's outputs bit for bit,
a malformed clip is reported with its line and does not stop the run, and a re-run skips finished clips."""
from __future__ import annotations

import json
import math
import os

import pyarrow.parquet as pq
import pytest
from conftest import SHARED_MOCAP

import stagger_nb as sn
from stagger_nb import batch
from stagger_nb.__main__ import main
from stagger_nb.session import Session

OPS = [{"op": "cull", "percent": 50}, {"op": "succession", "root": "Hips", "s": 0.03, "l": 2.0}]


@pytest.fixture
def clips(tmp_path):
    """in/: three short real clips (one in a sub-folder) and a malformed BVH (truncated before MOTION)."""
    src = tmp_path / "in"
    (src / "sub").mkdir(parents=True)
    names = ["xia_angry_run.bvh", "bandai_run_cycle.bvh"]
    motions = [sn.read_bvh(SHARED_MOCAP / n) for n in names if (SHARED_MOCAP / n).is_file()]
    motions.append(sn.data.load("walk"))
    for i, m in enumerate(motions):
        sn.write_bvh(m.slice(0, 40), src / ("sub" if i == 1 else "") / f"clip{i}.bvh")
    text = (src / "clip0.bvh").read_text()
    (src / "sub" / "broken.bvh").write_text(text[:text.index("MOTION")] + "MOTION\nFrames: 2\nFrame Time: 0.01\n1 2\n")
    session = tmp_path / "edit.json"
    Session(sn.data.load("walk").slice(0, 30), ops=OPS).save(session)
    return src, session, len(motions)


def write_asf_amc(folder, frames=30):
    """``folder/07.asf`` (the tiny skeleton of test_io_asfamc) and ``folder/07_01.amc`` with a smooth swing."""
    from io_samples import TINY_ASF
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "07.asf").write_text(TINY_ASF)
    rows = [":FULLY-SPECIFIED", ":DEGREES"]
    for f in range(frames):
        a = 40 * math.sin(f / 4)
        rows += [str(f + 1), f"root {f * 0.5} 2 3 0 {a:.4f} 0", f"a {a:.4f}", f"b {-a:.4f}"]
    (folder / "07_01.amc").write_text("\n".join(rows) + "\n")


def _files(root):
    return {os.path.relpath(os.path.join(d, f), root): open(os.path.join(d, f), "rb").read()
            for d, _, fs in os.walk(root) for f in fs if f.endswith(".bvh")}


def test_local_cluster_matches_serial_and_reruns_skip(clips, tmp_path):
    src, session, n = clips
    serial = batch.run_session_batch(session, src, tmp_path / "serial", executor="serial", progress=False)
    # a running scheduler named by address (--scheduler): a real 2-process LocalCluster started here
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      env=dict(batch.THREAD_ENV)) as cluster:
        dist = batch.run_session_batch(session, src, tmp_path / "dist", scheduler=cluster.scheduler_address,
                                       progress=False, timeout=120)
    assert len(serial.done) == len(dist.done) == n
    want = _files(tmp_path / "serial")
    assert len(want) == n and _files(tmp_path / "dist") == want   # bit for bit
    for res in (serial, dist):
        (row,) = res.failed
        assert row["file"] == "sub/broken.bvh" and row["line"] == bad_row_line(src)
        assert f"line {row['line']}" in row["error"]
    report = json.loads((tmp_path / "dist" / batch.REPORT_JSON).read_text())
    assert report["failed"] == dist.failed and report["clips"] == n + 1
    assert "sub/broken.bvh," in (tmp_path / "dist" / batch.REPORT_CSV).read_text()
    again = batch.run_session_batch(session, src, tmp_path / "dist", executor="serial", progress=False)
    assert again.done == [] and sorted(again.skipped) == sorted(dist.done) and len(again.failed) == 1  # retried
    (src / "sub" / "broken.bvh").unlink()
    again = batch.run_session_batch(session, src, tmp_path / "dist", executor="distributed", workers=2,
                                    progress=False, timeout=120)
    assert again.done == again.failed == [] and sorted(again.skipped) == sorted(dist.done)
    assert _files(tmp_path / "dist") == want
    # a changed input runs again (the manifest keys on the input's content)
    sn.write_bvh(sn.data.load("run").slice(0, 20), src / "clip0.bvh")
    third = batch.run_session_batch(session, src, tmp_path / "dist", executor="serial", progress=False)
    assert third.done == ["clip0.bvh"]


def bad_row_line(src) -> int:
    """1-based line of the malformed file's first motion row (2 numbers where the skeleton needs more)."""
    text = (src / "sub" / "broken.bvh").read_text()
    return text[:text.index("\n1 2\n") + 1].count("\n") + 1


def test_extract_poses_table_and_processes_executor(clips, tmp_path):
    src, _, n = clips
    write_asf_amc(src / "amc")
    n += 1
    a = batch.run_extract_poses(src, tmp_path / "a.parquet", executor="serial", progress=False)
    b = batch.run_extract_poses(src, tmp_path / "b.parquet", executor="processes", workers=2, progress=False)
    ta, tb = pq.read_table(tmp_path / "a.parquet"), pq.read_table(tmp_path / "b.parquet")
    assert ta.equals(tb) and len(a.failed) == len(b.failed) == 1
    assert sorted(set(ta.column("clip").to_pylist())) == sorted(a.done) and len(a.done) == n
    assert "amc/07_01.amc" in a.done   # ASF/AMC: NN_MM.amc read with NN.asf
    m = sn.read_bvh(src / "clip0.bvh")
    rows = [r for r in ta.to_pylist() if r["clip"] == "clip0.bvh"]
    from stagger_nb import staggered
    sm = staggered.extract(m)
    assert [r["pose_time"] for r in rows] == list(sm.pose_times)
    assert all(len(r["refinements"]) == m.num_joints and r["fit_residual"] >= 0 for r in rows)
    assert rows[0]["priority"] == float("inf") and rows[-1]["priority"] == float("inf")


def test_cli_refuses_output_over_input_and_reports(clips, tmp_path, capsys):
    src, session, n = clips
    assert main(["batch", str(session), str(src), str(src), "--no-progress"]) == 2
    assert "input folder" in capsys.readouterr().err
    assert main(["batch", str(session), str(src), str(tmp_path / "o"), "--executor", "serial", "--no-progress"]) == 1
    out = capsys.readouterr()
    assert f"{n} written" in out.out and "sub/broken.bvh" in out.err and "line" in out.err


# -- the quality figures of each clip (issue "Edits an animator would keep", item 3) -----------------------------
def _csv(out):
    import csv
    with open(out / batch.REPORT_CSV, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_the_report_carries_each_clips_quality(tmp_path):
    """Each edited clip's row is its Session.quality() (mild bounds) computed apart; a re-run that skips the
    clips still reports their figures (kept in the manifest); names a spreadsheet would evaluate are escaped in
    every row, done ones too."""
    from stagger_nb import quality
    src = tmp_path / "in"
    src.mkdir()
    walk, run = sn.data.load("walk").slice(0, 90), sn.data.load("run").slice(0, 60)
    sn.write_bvh(walk, src / "-walk.bvh")
    sn.write_bvh(run, src / "run.bvh")
    (src / "broken.bvh").write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n")
    ops = [{"op": "succession", "root": "Hips", "s": 0.03, "l": 2.0}, {"op": "random_timing", "tau": 0.1, "seed": 1},
           {"op": "keep_contacts"}]
    session = tmp_path / "edit.json"
    Session(walk, ops=ops).save(session)
    out = tmp_path / "out"
    res = batch.run_session_batch(session, src, out, executor="serial", progress=False)
    assert sorted(res.done) == ["-walk.bvh", "run.bvh"] and len(res.failed) == 1
    want = {name: Session(sn.read_bvh(src / name), ops=ops).quality().to_row() for name in res.done}
    assert res.quality == want
    assert set(want["run.bvh"]) == set(quality.ROW_FIELDS)
    assert want["run.bvh"]["pelvis_vs_baseline"] is not None        # the layer judged against no layer
    report = json.loads((out / batch.REPORT_JSON).read_text())
    assert report["quality"] == want
    rows = {r["file"]: r for r in _csv(out)}
    assert set(rows) == {"'-walk.bvh", "run.bvh", "broken.bvh"}
    r = rows["run.bvh"]
    q = want["run.bvh"]
    assert r["status"] == "done" and r["summary"] == q["summary"] and r["quality_ok"] == str(q["ok"])
    assert float(r["foot_travel_cm"]) == pytest.approx(q["foot_travel"], abs=5e-4)
    assert float(r["pelvis_vs_no_layer_cm"]) == pytest.approx(q["pelvis_vs_baseline"], abs=5e-4)
    assert int(r["knots_out_of_order"]) == q["knots_out_of_order"] and r["error"] == ""
    assert rows["broken.bvh"]["status"] == "failed" and rows["broken.bvh"]["summary"] == ""
    assert "line" in rows["broken.bvh"]["error"]
    # a re-run skips both clips and still reports their figures
    again = batch.run_session_batch(session, src, out, executor="serial", progress=False)
    assert sorted(again.skipped) == sorted(want) and again.quality == want
    rows = {r["file"]: r for r in _csv(out)}
    assert rows["run.bvh"]["status"] == "skipped" and rows["run.bvh"]["summary"] == q["summary"]
    assert json.loads((out / batch.REPORT_JSON).read_text())["quality"] == want


def test_a_manifest_whose_quality_is_not_figures_is_refused(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    sn.write_bvh(sn.data.load("walk").slice(0, 40), src / "a.bvh")
    session = tmp_path / "edit.json"
    Session(sn.data.load("walk").slice(0, 30), ops=OPS).save(session)
    out = tmp_path / "out"
    batch.run_session_batch(session, src, out, executor="serial", progress=False)
    path = out / batch.MANIFEST
    data = json.loads(path.read_text())
    assert set(data["clips"]["a.bvh"]["quality"]) >= {"ok", "summary"}
    data["clips"]["a.bvh"]["quality"] = {"summary": {"nested": "object"}}
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="'quality' is not a row of figures"):
        batch.run_session_batch(session, src, out, executor="serial", progress=False)
