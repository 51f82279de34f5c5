"""StaggerEditor slider moves (cull %, s, l, τ, w_r) replayed by the session as the editor replays them
(``Session.check_ops`` then ``set_ops`` + ``edited``), in one process: the CPU of each move's replay on the
thread that waits for it (the kernel's), with and without the warm-up of the next slider step
(``Session.warm_next_step``, session/warm.py ``next_step``), and where a cold move's CPU goes (one timed
call per op of the w_r and τ moves).

Clips: CMU 01_01 (data/cmu_01_01.bvh, 2,751 frames, 31 joints, 120 Hz), the full clip and its first 900 frames;
the contact layer (``keep_contacts``) off and on. The op list is the editor's (canonical order: cull 50 %,
exaggerate w_r 0.5, succession s 0.05 l 1 from Hips, random timing τ 0.05), each slider moved 8 steps of its
control (percent 5, s 0.005, l 0.05, τ 0.005, w_r 0.05) one way, with a pause after each move as between two
key presses (for the next-step warm-up, until it is done; its CPU is counted apart, as "background").

Printed per clip, layer and slider: median CPU ms of a move's replay cold (``warm_next_step = False``: every
move computes its ops, today's path) and with the next step warmed (the move the warm-up foresaw: cache hits),
the ratio, and the background CPU per move; the results of both paths are checked bit for bit equal.

Run: ``OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD nice .venv/bin/python benchmarks/bench_slider_moves.py [--frames 900]
[--layer off,on] [--sliders cull,s,l,tau,w_r]``.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import stagger_nb as sn
from stagger_nb import staggered
from stagger_nb.session import Session

START = {"percent": 50.0, "w_r": 0.5, "s": 0.05, "l": 1.0, "tau": 0.05}
STEP = {"cull": ("percent", -5.0), "s": ("s", 0.005), "l": ("l", 0.05), "tau": ("tau", 0.005), "w_r": ("w_r", 0.05)}
MOVES = 8


def editor_ops(p: dict, layer: bool) -> list:
    """The StaggerEditor's op list for these slider values (stagger_params_to_ops' canonical order)."""
    ops = [{"op": "cull", "percent": p["percent"]}, {"op": "exaggerate", "w_r": p["w_r"]},
           {"op": "succession", "root": "Hips", "s": p["s"], "l": p["l"]},
           {"op": "random_timing", "tau": p["tau"], "seed": 0}]
    return ops + ([{"op": "keep_contacts"}] if layer else [])


def values(slider: str) -> list[dict]:
    field, step = STEP[slider]
    out = []
    for i in range(1, MOVES + 1):
        p = dict(START)
        p[field] = round(START[field] + i * step, 4) + 0.0   # as the model snaps a control's value
        out.append(p)
    return out


def move(s: Session, ops: list) -> tuple:
    """CPU ms (this thread) of one editor move: check_ops, set_ops, edited."""
    c = time.thread_time()
    s.check_ops(ops)
    s.set_ops(ops)
    out = s.edited()
    return 1000 * (time.thread_time() - c), out


def session(m, layer: bool, warm: bool) -> Session:
    s = Session(m, ops=editor_ops(START, layer))
    s.warm_next_step = warm
    s.edited()                                   # warm: extraction, cull, the first replay, the layer's tables
    return s


def sweep(s: Session, slider: str, layer: bool) -> tuple[list, list, list]:
    """Per move of ``slider`` from the start values: foreground CPU ms, background CPU ms (the next-step warm-up
    after it), edited motion."""
    s.check_ops(editor_ops(START, layer))       # the slider starts from here (cached)
    if s.next_step is not None:
        s.next_step.result(timeout=600)          # (a step guessed from the last slider's return: let it end)
    fg, bg, out = [], [], []
    for p in values(slider):
        ms, e = move(s, editor_ops(p, layer))
        fg.append(ms)
        out.append(e)
        c = time.process_time()
        if s.next_step is not None and s.warm_next_step:
            s.next_step.result(timeout=600)      # the pause between two key presses
        bg.append(1000 * (time.process_time() - c))
    return fg, bg, out


def where(m, layer: bool, dw: float = 0.05) -> str:
    """CPU ms of each op of a w_r move (every op after the cull computed anew, as a cold move computes them),
    after the same calls at another w_r (first-call costs out of the way)."""
    ex = staggered.cull(staggered.extract(m), percent=START["percent"])
    basis = staggered.pose_offset_basis(ex, m)       # cached per state by the session (heads.offset_basis)
    if dw:
        where(m, layer, 0.0)
    parts = {}
    c = time.thread_time()
    e = staggered.exaggerate(ex, list(range(ex.num_poses)), START["w_r"] + dw, basis=basis)
    parts["exaggerate"] = time.thread_time() - c
    c = time.thread_time()
    su = staggered.succession(e, root="Hips", s=START["s"], l=START["l"])
    parts["succession"] = time.thread_time() - c
    c = time.thread_time()
    r = staggered.random_timing(su, tau=START["tau"], seed=0)
    parts["random_timing"] = time.thread_time() - c
    c = time.thread_time()
    if layer:
        staggered.keep_contacts(r, m)
        parts["keep_contacts (incl. evaluate)"] = time.thread_time() - c
    else:
        staggered.evaluate(r)
        parts["evaluate"] = time.thread_time() - c
    return ", ".join(f"{k} {1000 * v:.1f}" for k, v in parts.items())


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", default="900,full", help="comma list of frame counts or 'full'")
    ap.add_argument("--layer", default="off,on")
    ap.add_argument("--sliders", default="cull,s,l,tau,w_r")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore", DeprecationWarning)
    full = sn.data.load("cmu_01_01")
    print(f"load average {os.getloadavg()[0]:.1f}; {MOVES} moves per slider; CPU ms of a move's replay (median)")
    for fr in args.frames.split(","):
        m = full if fr == "full" else full.slice(0, int(fr))
        for layer in [x == "on" for x in args.layer.split(",")]:
            tag = f"cmu_01_01 {m.num_frames} frames, layer {'on' if layer else 'off'}"
            print(f"{tag}: the ops of a cold w_r move (CPU ms): {where(m, layer)}")
            cold_s, warm_s = session(m, layer, False), session(m, layer, True)
            for slider in args.sliders.split(","):
                cold, _, a = sweep(cold_s, slider, layer)
                hot, bg, b = sweep(warm_s, slider, layer)
                same = all(np.array_equal(x.local_quats, y.local_quats)
                           and np.array_equal(x.root_positions, y.root_positions) for x, y in zip(a, b))
                assert same, f"{slider}: the warmed replay differs from the cold one"
                mc, mh = statistics.median(cold), statistics.median(hot[1:])   # the first move has no step yet
                print(f"  {slider:>4}: cold {mc:6.1f}  next step warmed {mh:6.1f}  ratio x{mh / mc:.3f}  "
                      f"(first move {hot[0]:.1f}; background {statistics.median(bg[:-1]):.1f} per move; "
                      f"bit-identical {same})")
            cold_s.close()
            warm_s.close()
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
