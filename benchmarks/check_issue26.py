"""Issue 26's "How it will be checked", the parts without a browser, on CMU 01_01 (2,751 frames at 120 Hz), through
the editors' models bound to a Session (``ModelBinding``, no widgets), as the controls set them:

1. skip = 1 at 2.87 s is refused with a plain message and the session still replays;
2. the keytime 2.0 s -> 1.5 s at 22.83 s gives a warp (through it);
3. the first duration, free-length and backward changes each replay in <= 300 ms CPU after the WarpEditor's
   warm-up (``bench_editor_first_changes.warp_changes``), and a warm duration slider move <= 50 ms
   (``slider_changes``: key steps and a drag's ticks);
4. the wand range case (frame_range [5, 1420] with the edit at 2267, then propagate and a new sigma) leaves a
   replayable session whose next sigma applies.

Each line says ok or FAIL with its figure. Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/check_issue26.py``
"""
from __future__ import annotations

import os
import re
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

import bench_editor_first_changes as bench

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session import models as M
from stagger_nb.session.models.views import warp_view

RAW = re.compile(r"ops\[\d+\]|[A-Z][a-z]+Error|Exception|Traceback")   # an op index or an exception's name
failed = []


def report(ok: bool, what: str) -> None:
    print(f"{'ok  ' if ok else 'FAIL'} {what}")
    if not ok:
        failed.append(what)


def warp_session(cmu):
    s = Session(cmu)
    w = M.WarpModel()
    M.ModelBinding(w, s)
    return s, w


def skip_1_at_2_87(cmu) -> None:
    s, w = warp_session(cmu)
    assert w.set_control("duration", 2.87) == ""
    before = s.ops
    why = w.set_control("skip", 1)
    out = s.edited()
    report(bool(why) and not RAW.search(why) and s.ops == before and out.num_frames == round(2.87 / cmu.frame_time) + 1,
           f"skip 1 at 2.87 s refused: {why!r}; the session replays ({out.num_frames} frames, skip "
           f"{s.ops[-1]['skip']})")
    s.close()


def keytime_at_22_83(cmu) -> None:
    s, w = warp_session(cmu)
    c = time.process_time()
    why = w.set_control("duration", 22.83) or w.set_control("keytimes_text", "2:1.5")   # each replays (cold)
    v = warp_view(s)
    cpu = time.process_time() - c
    ft = cmu.frame_time
    at = float(np.interp(1.5, v["out_times"], v["warp"]))
    ok = why == "" and abs(at - 2.0) <= ft + 1e-9 and abs(v["out_times"][-1] - 22.83) <= ft \
        and bool(np.all(np.diff(v["warp"]) >= -1e-12))
    report(ok, f"keytime 2.0 s -> 1.5 s at 22.83 s gives a warp: W(1.5 s) = {at:.4f} s, "
               f"{len(v['warp'])} frames ({v['out_times'][-1]:.2f} s), ops {s.ops[-1]['keytimes']}, "
               f"{cpu * 1e3:.0f} ms CPU for both changes, cold")
    s.close()


def first_changes(cmu) -> None:
    got = bench.warp_changes(cmu, True)
    for name, (wall, cpu) in got.items():
        report(cpu <= bench.BUDGET, f"first {name}: {cpu * 1e3:.0f} ms CPU (wall {wall * 1e3:.0f}) <= "
                                    f"{bench.BUDGET * 1e3:.0f}")
    got = bench.slider_changes(cmu, True)
    for name, (wall, cpu, bg) in got.items():
        report(cpu <= bench.SLIDER_BUDGET, f"duration slider {name}: {cpu * 1e3:.0f} ms CPU (wall {wall * 1e3:.0f}; "
                                           f"then {bg * 1e3:.0f} ms in the background) <= "
                                           f"{bench.SLIDER_BUDGET * 1e3:.0f}")


def wand_range(cmu) -> None:
    s = Session(cmu)
    s0 = float(s.wand_graph().default_sigma)
    w = M.WandModel(joint="LeftUpLeg", sigma=s0, default_sigma=s0, frame_time=cmu.frame_time)
    M.ModelBinding(w, s)
    w.propagate = False
    w.edit_frame = 2267
    w.rx = 20.0
    w.frame_range = [5, 1420]
    note = w.message
    w.propagate = True
    sigmas = w.sigmas_nearest_first()
    w.sigma = sigmas[1]
    op = s.ops[-1]
    out = s.edited()
    ok1 = op["op"] == "propagate" and op["frame_range"][0] <= 2267 < op["frame_range"][1] and out is not None \
        and not RAW.search(note) and note != ""
    w.sigma = sigmas[2]
    out2 = s.edited()
    ok2 = s.ops[-1]["sigma"] == sigmas[2] and not np.array_equal(out.local_quats, out2.local_quats)
    report(ok1 and ok2, f"wand range [5, 1420] with the edit at 2267: said {note!r}; range became "
                        f"{op['frame_range']}; replays; next sigma {sigmas[2]:.4g} applies (the motion changed: "
                        f"{ok2})")
    s.close()


def main():
    cmu = sn.io.read_bvh(str(REPO / "data" / "cmu_01_01.bvh"))
    print(f"CMU 01_01: {cmu.num_frames} frames, {cmu.duration:.2f} s; load {os.getloadavg()[0]:.1f}")
    skip_1_at_2_87(cmu)
    keytime_at_22_83(cmu)
    wand_range(cmu)
    first_changes(cmu)
    print(f"load {os.getloadavg()[0]:.1f}; {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
