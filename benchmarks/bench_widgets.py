"""Kernel-side latency of the editors and what the 3D view sends per frame step.

Measures, with every ipywidgets message recorded by wrapping ``Widget._send`` (what would go over the comm):

- time from a slider change to the last view-update message, for ``l``, ``τ`` and cull % on a 900-frame
  31-joint clip (target <= 50 ms) and for ``σ`` on 600 frames (target <= 100 ms);
- the same slider's bare technique tail (session replay of the changed ops, no views) in the same process,
  as the baseline: the ratio is the cost of the views;
- floats sent per 3D frame step (target <= J * 3) against re-sending the clip (F * J * 3).

Run: ``.venv/bin/python benchmarks/bench_widgets.py`` (needs ../shared/mocap/cmu_131_01_walk_startstop.bvh).
"""
from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import ipywidgets
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import stagger_nb as sn  # noqa: E402
from stagger_nb.session import Session  # noqa: E402
from stagger_nb.widgets import StaggerEditor, WandEditor  # noqa: E402

CLIP = REPO.parent / "shared" / "mocap" / "cmu_131_01_walk_startstop.bvh"
LOG: list = []
_orig_send = ipywidgets.Widget._send


def _recording_send(self, msg, buffers=None):
    LOG.append((time.perf_counter(), type(self).__name__, sum(memoryview(b).nbytes for b in (buffers or []))))
    return _orig_send(self, msg, buffers)


ipywidgets.Widget._send = _recording_send


def slider_latency(widget, values):
    """Per value: seconds from ``widget.value = v`` to the last message it caused, and the message count."""
    out = []
    for v in values:
        LOG.clear()
        t0 = time.perf_counter()
        widget.value = v
        t_end = time.perf_counter()
        last = max((t for t, _, _ in LOG), default=t_end)
        out.append((last - t0, len(LOG)))
    return out


def bare_tail(session_ops_list, source, ctx=None):
    """Baseline: a fresh session replay of each op list (no views), with its heads (extraction, cull,
    pose graph, eigenbases) taken from ``ctx`` or pre-cached by a first replay."""
    s = Session(source)
    if ctx is not None:
        s._ctx = ctx
    times = []
    s.set_ops(session_ops_list[0])
    s.edited()
    for ops in session_ops_list:
        s2 = Session(source, ops)
        s2._ctx = s._ctx  # share the cached heads, not the memo
        t0 = time.perf_counter()
        s2.edited()
        times.append(time.perf_counter() - t0)
    return times


def report(name, lat, base, target_ms):
    ms = [1000 * t for t, _ in lat]
    med, worst = statistics.median(ms), max(ms)
    bmed = 1000 * statistics.median(base)
    print(f"{name:<28} median {med:7.1f} ms  max {worst:7.1f} ms  msgs/move {statistics.median([n for _, n in lat]):4.0f}"
          f"  | bare replay {bmed:6.1f} ms  views/bare x{med / max(bmed, 1e-9):5.2f}"
          f"  | target <= {target_ms} ms: {'OK' if med <= target_ms else 'MISSED'}")
    return med


def main():
    if not CLIP.is_file():
        print(f"skip: {CLIP} not present")
        return
    full = sn.read_bvh(CLIP)
    m900, m600 = full.slice(0, 900), full.slice(0, 600)
    print(f"clip: {CLIP.name}: {m900} and {m600}")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at start (other jobs slow every figure)")
    results = {}

    # -- StaggerEditor: l, tau, cull ---------------------------------------------------------------------
    t0 = time.perf_counter()
    e = StaggerEditor(m900, precompute=True)
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    e.warm_thread.join()
    print(f"StaggerEditor build {t_build:.2f} s (extraction {len(e.session.extraction().pose_times)} candidate "
          f"poses); cull cache warmed in the background in {time.perf_counter() - t0:.2f} s more")
    e.cull.value = 60
    e.s.value = 0.03
    ls = [1.25, 1.5, 2.0, 2.5, 3.0, 3.5, 1.0, 2.25, 2.75, 1.75]
    lat = slider_latency(e.l, ls)
    base = bare_tail([[{"op": "cull", "percent": 60.0}, {"op": "succession", "root": e.root.value, "s": 0.03, "l": l}]
                      for l in ls], m900, ctx=e.session._ctx)
    results["l"] = report("StaggerEditor l (900 fr)", lat, base, 50)
    taus = [0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.1]
    lat = slider_latency(e.tau, taus)
    base = bare_tail([[{"op": "cull", "percent": 60.0}, {"op": "succession", "root": e.root.value, "s": 0.03, "l": 1.75},
                       {"op": "random_timing", "tau": t, "seed": 0, "joints": None}] for t in taus], m900,
                     ctx=e.session._ctx)
    results["tau"] = report("StaggerEditor tau (900 fr)", lat, base, 50)
    culls = [55.0, 50.0, 45.0, 40.0, 35.0, 30.0, 70.0, 80.0, 90.0, 100.0]
    lat = slider_latency(e.cull, culls)
    base = bare_tail([([{"op": "cull", "percent": c}] if c < 100 else []) +
                      [{"op": "succession", "root": e.root.value, "s": 0.03, "l": 1.75},
                       {"op": "random_timing", "tau": 0.1, "seed": 0, "joints": None}] for c in culls], m900,
                     ctx=e.session._ctx)
    results["cull"] = report("StaggerEditor cull % (warm)", lat, base, 50)
    e.close()
    e_cold = StaggerEditor(m900, session=Session(m900), precompute=False)
    lat = slider_latency(e_cold.cull, [50.0, 30.0])
    print(f"{'StaggerEditor cull % (cold)':<28} first visit of a cull value: "
          f"{', '.join(f'{1000 * t:.0f} ms' for t, _ in lat)} (staggered.cull refits the splines; cached afterwards)")
    e_cold.close()

    # -- WandEditor: sigma ------------------------------------------------------------------------------
    t0 = time.perf_counter()
    w = WandEditor(m600, frame=300, joint="LeftHip", rotation=(20.0, 0.0, 0.0))
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    w.warm_thread.join()
    print(f"WandEditor build {t_build:.2f} s; {len(w._sigma_grid)} sigma bases warmed in the background in "
          f"{time.perf_counter() - t0:.2f} s more")
    grid = w._sigma_grid
    sig = [float(grid[i]) for i in (16, 17, 18, 19, 14, 13, 12, 20, 22, 10)]
    lat = slider_latency(w.sigma, sig)
    base = bare_tail([[{"op": "propagate", "frame": 300, "deltas": {"LeftHip": [20.0, 0.0, 0.0]},
                        "sigma": x, "frame_range": None}] for x in sig], m600, ctx=w.session._ctx)
    results["sigma"] = report("WandEditor sigma (600 fr)", lat, base, 100)
    w.close()
    w_cold = WandEditor(m600, frame=300, joint="LeftHip", rotation=(20.0, 0.0, 0.0), precompute=False)
    lat = slider_latency(w_cold.sigma, [float(grid[20]), float(grid[8])])
    print(f"{'WandEditor sigma (cold)':<28} first visit of a sigma value: "
          f"{', '.join(f'{1000 * t:.0f} ms' for t, _ in lat)} (one eigendecomposition of the 600x600 kernel)")
    w_cold.close()

    # -- SkeletonView: floats per frame step ------------------------------------------------------------
    from stagger_nb.widgets import SkeletonView
    J = m900.num_joints
    for ghost in (False, True):
        v = SkeletonView(m900, ghost=m900 if ghost else None)
        v.show_ghost = ghost
        counts = []
        for f in range(1, 101):
            LOG.clear()
            v.frame = f
            counts.append(sum(nb for _, _, nb in LOG) // 4)
        print(f"SkeletonView frame step{' + ghost' if ghost else '         '}: {statistics.median(counts):.0f} floats "
              f"per step (max {max(counts)}; J*3 = {J * 3}; re-sending the clip = {m900.num_frames * J * 3}, "
              f"ratio {statistics.median(counts) / (m900.num_frames * J * 3):.5f})"
              + ("  target <= J*3: " + ("OK" if max(counts) <= J * 3 else "MISSED") if not ghost else
                 "  (ghost doubles it: one more J*3 array)"))
        v.close()
    big = sn.Motion(m900.skeleton, m900.frame_time, np.zeros((3000, 3)), np.tile(m900.local_quats[:1], (3000, 1, 1)))
    t0 = time.perf_counter()
    v = SkeletonView(big)
    t_b = time.perf_counter() - t0
    t0 = time.perf_counter()
    for f in range(1, 301):
        v.frame = f
    print(f"SkeletonView 3000 frames: build {t_b * 1000:.0f} ms, frame step {1000 * (time.perf_counter() - t0) / 300:.2f} ms")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return results


if __name__ == "__main__":
    main()
