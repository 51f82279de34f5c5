"""First changes of the wand and warp editors' models on CMU 01_01 (2,751 frames at 120 Hz), issue 26: each
first toggle or choice <= 300 ms CPU once the editor's open-time warm-up has run.

Each change is timed on a model bound to a fresh Session (``ModelBinding``, no widgets): ``cold`` without any
warm-up (the baseline, same process), ``warm`` after the jobs the editors submit on open have finished
(``models.views.warp_tables_first_changes`` then ``warp_replays_first_changes`` for the warp; the wand's sigma grid
and comparison heads). A change
is the model trait set as a control does (``set_control``) plus the replay it causes (``session.edited()``).
CPU time (``time.process_time``, every thread of the process: the warm-up has finished before timing) and wall
time, with the load average (the machine is shared).

The duration slider (``slider``, issue 26: sliders <= 50 ms warm): after the first duration key (-10 % / +10 %,
untimed, the editor's warm-up redone), a sequence of moves as a hand makes them: arrow keys (one frame, 1/120 s),
a drag of three-frame ticks, keys turning back (to new lengths, then to one seen), a drag of 26-frame ticks (one
pixel of the WarpEditor's duration track, 1/8x .. 2x of the clip on ~200 px).
``cold``: every move searched (the session's next-step speculation off, ``Session.warm_next_step = False``: the
path before session 12); ``warm``: with it, each move
timed once the background work the previous one started has finished (the user paused), whose CPU is printed
as ``bg``. +10 % searches 8,251 upsampled frames coarse-to-fine (no sweep): a move of a new size (the first
tick of a drag after a key) is searched in the foreground (~100-150 ms), the steps guessed are not.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_editor_first_changes.py [warp] [wand] [slider]``
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session import models as M
from stagger_nb.session.heads import DIFFUSION_MAX_FRAMES
from stagger_nb.session.models.views import warp_replays_first_changes, warp_tables_first_changes

BUDGET = 0.3
SLIDER_BUDGET = 0.05
MAX_SKIP = 16   # the WarpEditor's skip slider's largest value


def timed(fn):
    w, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w, time.process_time() - c


def warm_up(s, b) -> None:
    """What the WarpEditor warms (on open and when what chooses its tables changes): the tables, then the first
    backward toggle's replay."""
    s.warm(("warp_tables", warp_tables_first_changes(b, MAX_SKIP)), ("replay", warp_replays_first_changes(b))).result()


def warp_changes(cmu, warm: bool) -> dict:
    """The first duration key (down and up), the first free-length toggle and the first backward toggle, each on
    a fresh session (so each is a first change)."""
    D = cmu.duration
    changes = {"duration -10 %": ([], [("duration", round(0.9 * D, 3))]),
               "duration +10 %": ([], [("duration", round(1.1 * D, 3))]),
               "free length on": ([], [("free_length", True)]),
               "backward on": ([], [("backward", True)]),
               # backward after a first duration key (untimed), the editor's re-warm for it done
               "backward at -10 %": ([("duration", round(0.9 * D, 3))], [("backward", True)]),
               "backward at +10 %": ([("duration", round(1.1 * D, 3))], [("backward", True)])}
    out = {}
    for name, (pre, steps) in changes.items():
        s = Session(cmu)
        w = M.WarpModel()
        b = M.ModelBinding(w, s)
        if warm:
            warm_up(s, b)
        for k, v in pre:
            w.set_control(k, v)
            s.edited()
            if warm:   # the WarpEditor re-warms when the duration changes
                warm_up(s, b)

        def change(steps=steps, w=w, s=s):
            for k, v in steps:
                why = w.set_control(k, v)
                assert not why, why
            s.edited()
        out[name] = timed(change)
        s.close()
    return out


SLIDER_MOVES = (("key +1", 1), ("key +1 again", 1), ("drag +3 (1st tick)", 3), ("drag +3 (2nd)", 3),
                ("drag +3 (3rd)", 3), ("key -1 (turn back)", -1), ("key -1 again", -1),
                ("key +1 (to a seen one)", 1), ("drag +26 (1st tick)", 26), ("drag +26 (2nd)", 26),
                ("drag +26 (3rd)", 26))


def slider_changes(cmu, warm: bool) -> dict:
    """The duration slider's moves after a first duration key of -10 % and +10 % (see the module): ``{name: (wall,
    cpu, background cpu)}``."""
    D, ft = cmu.duration, cmu.frame_time
    out = {}
    for start in (0.9, 1.1):
        s = Session(cmu)
        s.warm_next_step = warm
        w = M.WarpModel()
        b = M.ModelBinding(w, s)
        warm_up(s, b)
        w.set_control("duration", round(start * D, 3))
        s.edited()
        warm_up(s, b)   # the WarpEditor re-warms when the duration changes

        def pause():    # the user pauses: what the last move started in the background finishes
            c = time.process_time()
            if s.next_step is not None:
                s.next_step.result()
            return time.process_time() - c
        bg = pause()
        for name, frames in SLIDER_MOVES:
            v = w.duration + frames * ft

            def move(v=v):
                why = w.set_control("duration", v)
                assert not why, why
                s.edited()
            wall, cpu = timed(move)
            bg = pause()
            out[f"{start - 1:+.0%} {name}"] = (wall, cpu, bg)
        s.close()
    return out


def wand_changes(cmu, warm: bool) -> dict:
    """The first sigma move, "compare + isomap" and "compare + diffusion" (each on a fresh session)."""
    out = {}
    for name in ("sigma", "compare isomap", "compare diffusion"):
        s = Session(cmu)
        s0 = float(s.wand_graph().default_sigma)   # as the WandEditor opens (its first paint, not timed)
        w = M.WandModel(joint="LeftUpLeg", sigma=s0, default_sigma=s0, frame_time=cmu.frame_time)
        M.ModelBinding(w, s)
        sigmas = w.sigmas_nearest_first()
        if warm:   # what WandEditor warms on open: the nearest sigma positions, then the comparisons' heads
            heads = [("isomap", None)] + ([("diffusion", float(w.sigma))]
                                          if cmu.num_frames <= DIFFUSION_MAX_FRAMES else [])
            s.warm(("wand_basis", sigmas[:5]), ("compare", heads)).result()
        s.falloff_curves(int(w.edit_frame), w.sigma)    # the first paint's falloff (not timed)
        if name == "sigma":
            target = sigmas[1]
            out[name] = timed(lambda: (w.set_control("sigma", target),
                                       s.falloff_curves(int(w.edit_frame), w.sigma)))
        else:
            kind = name.split()[1]
            out[name] = timed(lambda: s.falloff_curves(int(w.edit_frame), w.sigma, compare=[kind]))
        s.close()
    return out


def main():
    only = sys.argv[1:] or ["warp", "wand"]
    cmu = sn.io.read_bvh(str(REPO / "data" / "cmu_01_01.bvh"))
    print(f"CMU 01_01: {cmu.num_frames} frames, {cmu.duration:.2f} s; load {os.getloadavg()[0]:.1f}")
    if "slider" in only:
        cold, warm = slider_changes(cmu, False), slider_changes(cmu, True)
        for name in cold:
            (cw, cc, _), (ww, wc, wb) = cold[name], warm[name]
            print(f"duration {name:28s} cold cpu {cc * 1e3:5.0f} ms (wall {cw * 1e3:5.0f})  warm cpu {wc * 1e3:4.0f} "
                  f"ms "
                  f"(wall {ww * 1e3:4.0f}, then bg {wb * 1e3:4.0f})  {'ok' if wc <= SLIDER_BUDGET else 'OVER'} "
                  f"(<= {SLIDER_BUDGET * 1e3:.0f} ms)")
    for label, fn in (("warp", warp_changes), ("wand", wand_changes)):
        if label not in only:
            continue
        cold, warm = fn(cmu, False), fn(cmu, True)
        for name in cold:
            (cw, cc), (ww, wc) = cold[name], warm[name]
            print(f"{label} {name:18s} cold cpu {cc * 1e3:7.0f} ms (wall {cw * 1e3:6.0f})  warm cpu {wc * 1e3:5.0f} ms "
                  f"(wall {ww * 1e3:6.0f})   warm/cold {wc / max(cc, 1e-9):.2f}   "
                  f"{'ok' if wc <= BUDGET else 'OVER'} (<= {BUDGET * 1e3:.0f} ms)")
    print(f"load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
