"""Interactive staggered-pose paths on 900 frames (issue 13 "Interactive paths", issue 11 item 8).

Run: ``nice .venv/bin/python benchmarks/bench_staggered_interactive.py``. Clip: CMU 01_01's first 900 frames
(``data/cmu_01_01.bvh``; the procedural walk looped to 900 frames if absent). Prints wall (min and median) and
CPU time per call, each beside a baseline run in this process:

* ``evaluate`` (goal <= 8 ms, aim 4 ms) against ``Motion.sample`` (plain slerp of the same frames) and the
  straightforward per-joint ``evaluate_reference``;
* ``succession`` + ``random_timing`` + ``evaluate`` (goal <= 15 ms);
* cull first visits: every percent 1..100 once, as the editor's slider visits them, (a) each percent refitted,
  (b) refits keyed by ``cull_keep`` (percents keeping the same poses share one); goal <= 100 ms per first
  visit; baseline: the previous refit (every sample, ``fit_samples=None``) on the same percents;
* cull local refit (default) against ``local=False`` on every distinct kept set (``--cull-only`` runs only this);
* the StaggerEditor's replay tails as pure calls (``--replays`` runs only these; issue 11 "bare replay"): the op
  chain cull(60 %) -> exaggerate(w_r) -> succession(Hips, 0.03, l) -> random_timing(0.06, seed) ->
  keep_contacts, with the cull cached, for a move of ``l`` (exaggerate cached) and of ``w_r`` (exaggerate
  recomputed; also with ``pose_offset_basis`` cached, what the session does once it keeps that basis per
  pre-exaggerate state); goal <= 25 ms CPU each; baseline: ``evaluate`` alone on the same edit.
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from stagger_nb import read_bvh, staggered
from stagger_nb.core.motion import concatenate

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the naive references live beside the tests
from references import evaluate_reference


def clip():
    for p in (REPO / "data" / "cmu_01_01.bvh", Path(os.environ.get("STAGGER_NB_DATA", "")) / "cmu_01_01.bvh"):
        if p.is_file():
            return read_bvh(p).slice(0, 900), "cmu_01_01 frames 0-900"
    from stagger_nb import data
    m = data.load("walk")
    return concatenate([m] * 3).slice(0, 900), "procedural walk looped to 900 frames (cmu_01_01 absent)"


def timed(f, repeat):
    """(min wall, median wall, mean cpu) seconds of ``f()`` over ``repeat`` runs after one warm-up."""
    f()
    ws, c0 = [], time.process_time()
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        ws.append(time.perf_counter() - t)
    return min(ws), float(np.median(ws)), (time.process_time() - c0) / repeat


def row(name, t, base=None, base_name=""):
    w, med, c = t
    r = f"  ratio {w / base[0]:.2f} x {base_name} ({1e3 * base[0]:.2f} ms)" if base else ""
    print(f"{name:<44} {1e3 * w:8.2f} ms (median {1e3 * med:7.2f}, cpu {1e3 * c:7.2f}){r}")


def cull_local_vs_full(sm):
    """First visits keyed by ``cull_keep``: the local refit (``cull(..., local=True)``, default) against the
    full refit (``local=False``) on the same kept sets, CPU time per refit."""
    keys = sorted({tuple(staggered.cull_keep(sm, pc)) for pc in range(1, 100)}, key=len)
    pcs = [next(pc for pc in range(1, 100) if tuple(staggered.cull_keep(sm, pc)) == k) for k in keys]
    out = {}
    for local in (True, False):
        staggered.cull(sm, pcs[len(pcs) // 2], local=local)          # warm-up
        walls, c0 = [], time.process_time()
        for pc in pcs:
            t = time.perf_counter()
            staggered.cull(sm, pc, local=local)
            walls.append(time.perf_counter() - t)
        out[local] = (np.array(walls), (time.process_time() - c0) / len(pcs))
    (wl, cl), (wf, cf) = out[True], out[False]
    print(f"cull refits of {len(pcs)} kept sets [goal 100 ms, aim 50 ms cpu]: "
          f"local median {1e3 * np.median(wl):.1f} ms "
          f"(max {1e3 * wl.max():.1f}, cpu {1e3 * cl:.1f}); full median {1e3 * np.median(wf):.1f} ms "
          f"(max {1e3 * wf.max():.1f}, cpu {1e3 * cf:.1f}); ratio full / local cpu {cf / cl:.2f}x")


def replays(m, sm):
    """CPU time per slider move of the StaggerEditor's replay tail (see the module docstring)."""
    root = "Hips" if "Hips" in m.skeleton.names else m.skeleton.names[0]
    culled = staggered.cull(sm, 60.0)
    ks = list(range(culled.num_poses))
    basis = staggered.pose_offset_basis(culled)
    held = staggered.exaggerate(culled, ks, 0.3)

    def tail(e, l, seed):
        return staggered.random_timing(staggered.succession(e, root=root, s=0.03, l=l), tau=0.06, seed=seed)

    ed = tail(held, 1.5, 4)
    rows = [("l move (exaggerate cached)", lambda i: staggered.keep_contacts(tail(held, 1.0 + 0.1 * (i % 7), 4), m)),
            ("w_r move", lambda i: staggered.keep_contacts(tail(staggered.exaggerate(culled, ks, 0.2 + 0.05 * (i % 7)),
                                                                1.5, 4), m)),
            ("w_r move, offset basis cached", lambda i: staggered.keep_contacts(
                tail(staggered.exaggerate(culled, ks, 0.2 + 0.05 * (i % 7), basis=basis), 1.5, 4), m)),
            ("  exaggerate alone", lambda i: staggered.exaggerate(culled, ks, 0.2 + 0.05 * (i % 7))),
            ("  exaggerate alone, basis cached", lambda i: staggered.exaggerate(culled, ks, 0.2 + 0.05 * (i % 7),
                                                                                basis=basis)),
            ("  keep_contacts alone", lambda i: staggered.keep_contacts(ed, m))]
    counter = iter(range(10 ** 9))
    t_ev = timed(lambda: staggered.evaluate(ed), 20)
    print(f"replay tails, K = {culled.num_poses} after cull(60 %) [goal <= 25 ms cpu per move]")
    for name, f in rows:
        row(name, timed(lambda: f(next(counter)), 15), t_ev, "evaluate alone")


def static_off(f):
    """``f()`` with evaluate's static-joint shortcut off (every joint through the spline, the previous
    evaluate): the baseline of that shortcut, measured in this process."""
    from stagger_nb.staggered import evaluation as R
    orig = R.static_rotations
    R.static_rotations = lambda sm: (np.zeros(sm.num_joints, bool), sm.values[0])
    try:
        return f()
    finally:
        R.static_rotations = orig


def main():
    m, label = clip()
    sm = staggered.extract(m)
    if "--replays" in sys.argv:
        print(f"# {label}: K = {sm.num_poses}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        replays(m, sm)
        print(f"# load average at the end {os.getloadavg()[0]:.1f}")
        return
    if "--cull-only" in sys.argv:
        print(f"# {label}: K = {sm.num_poses}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        cull_local_vs_full(sm)
        print(f"# load average at the end {os.getloadavg()[0]:.1f}")
        return
    root = "Hips" if "Hips" in m.skeleton.names else m.skeleton.names[0]
    print(f"# {label}: {m}; K = {sm.num_poses}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    t_sample = timed(lambda: m.sample(np.arange(900) * 0.999), 50)
    t_ref = timed(lambda: evaluate_reference(sm, m.times), 3)
    t_ev = timed(lambda: staggered.evaluate(sm), 50)
    row("evaluate 900 frames [goal 8 ms, aim 4]", t_ev, t_sample, "Motion.sample")
    row("  baseline evaluate_reference (per joint)", t_ref, t_ev, "evaluate")
    row("  baseline all joints through the spline", static_off(lambda: timed(lambda: staggered.evaluate(sm), 50)),
        t_ev, "evaluate")

    def edit():
        e = staggered.random_timing(staggered.succession(sm, root=root, s=0.02, l=1.0), tau=0.05, seed=0)
        return staggered.evaluate(e)
    t_ed = timed(edit, 20)
    row("succession + tau + evaluate [goal 15 ms]", t_ed, t_ev, "evaluate alone")

    percents = list(range(1, 101))

    def visits(fit_samples, keyed):
        """Wall time of each visit that refitted, and the CPU time per refit."""
        cache, walls, c0 = {}, [], time.process_time()
        for pc in percents:
            t = time.perf_counter()
            key = tuple(staggered.cull_keep(sm, pc)) if keyed else pc
            if key not in cache:
                cache[key] = staggered.cull(sm, pc, fit_samples=fit_samples)
                walls.append(time.perf_counter() - t)
        return np.array(walls), (time.process_time() - c0) / len(walls)

    for keyed in (False, True):
        new, c_new = visits(12, keyed)
        old, c_old = visits(None, keyed)
        how = "keyed by cull_keep" if keyed else "every percent refitted"
        print(f"cull first visits of 100 percents, {how}: {new.size} refits [goal 100 ms each, aim 50]")
        print(f"  now:      per refit median {1e3 * np.median(new):7.1f} ms, max {1e3 * new.max():7.1f} ms, "
              f"cpu {1e3 * c_new:6.1f} ms; all 100 visits {new.sum():.2f} s")
        print(f"  previous: per refit median {1e3 * np.median(old):7.1f} ms, max {1e3 * old.max():7.1f} ms, "
              f"cpu {1e3 * c_old:6.1f} ms; all 100 visits {old.sum():.2f} s   ratio previous / now "
              f"(median) {np.median(old) / np.median(new):.1f}x")
    cull_local_vs_full(sm)
    replays(m, sm)
    print(f"# load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
