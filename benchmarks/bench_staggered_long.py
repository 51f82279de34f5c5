"""Long takes for staggered poses (issue 13, "Long takes"): extract, cull and evaluate on a real walk tiled to
10,000 / 30,000 / 100,000 frames x 31 joints.

Run: ``nice .venv/bin/python benchmarks/bench_staggered_long.py [--sizes 10000,30000,100000] [--baseline]``.
The clip is ``../shared/mocap/xia_neutral_walk.bvh`` (120 Hz) repeated with its root travel carried on (the
procedural walk if absent). For each size it prints wall and CPU time and the peak of traced memory
(tracemalloc: numpy's buffers, the interpreter's objects) of each call, then the scaling exponent
``d log t / d log n`` fitted over the sizes (1 = linear; n log n reads about 1.1 here). ``--baseline`` also
times the previous fit (every sample, ``fit_samples=None``) at the smallest size, in this process, as a
ratio. Goals: 100,000 frames within 2 GB, extract <= 10 s, exponent <= ~1.1.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from stagger_nb import read_bvh, staggered  # noqa: E402
from stagger_nb.core.motion import Motion, concatenate  # noqa: E402
from stagger_nb.core.rotations import quat_angle  # noqa: E402

# ../shared/mocap beside the repository; STAGGER_NB_SHARED_MOCAP (as tests/conftest.py) or STAGGER_NB_SHARED
# (its parent) point elsewhere, e.g. from a git worktree
MOCAP = (Path(os.environ["STAGGER_NB_SHARED_MOCAP"]) if os.environ.get("STAGGER_NB_SHARED_MOCAP")
         else Path(os.environ.get("STAGGER_NB_SHARED", REPO.parent / "shared")) / "mocap")
CLIP = MOCAP / "xia_neutral_walk.bvh"


def walk_clip():
    if CLIP.is_file():
        return read_bvh(CLIP), str(CLIP.name)
    from stagger_nb import data
    return data.load("walk"), "procedural walk (xia_neutral_walk.bvh absent)"


def tiled(m: Motion, n: int) -> Motion:
    """``m`` repeated to ``n`` frames, each copy's root translation continued from where the last one ended
    (horizontal travel only), so the take walks on instead of jumping back."""
    reps = int(np.ceil(n / m.num_frames))
    step = m.root_positions[-1] - m.root_positions[0]
    step[1] = 0.0
    parts = [Motion(m.skeleton, m.frame_time, m.root_positions + r * step, m.local_quats, m.local_translations)
             for r in range(reps)]
    return concatenate(parts).slice(0, n)


def measure(f):
    """(wall s, cpu s, peak traced MB, result) of one call."""
    tracemalloc.start()
    tracemalloc.reset_peak()
    w, c = time.perf_counter(), time.process_time()
    out = f()
    w, c = time.perf_counter() - w, time.process_time() - c
    peak = tracemalloc.get_traced_memory()[1] / 2 ** 20
    tracemalloc.stop()
    return w, c, peak, out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="10000,30000,100000")
    ap.add_argument("--baseline", action="store_true")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    src, label = walk_clip()
    ref = np.random.default_rng(1).uniform(size=1_000_000)
    t0 = time.perf_counter()
    for _ in range(20):
        np.sqrt(ref) * ref + ref
    t_ref = (time.perf_counter() - t0) / 20
    print(f"# staggered long takes: {label} tiled; {src.num_joints} joints @ {1 / src.frame_time:.0f} Hz")
    print(f"# load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; reference numpy op "
          f"(sqrt*x+x on 1e6 floats) {1e3 * t_ref:.2f} ms")
    print(f"{'frames':>8} {'call':<10} {'wall s':>8} {'cpu s':>8} {'peak MB':>8}  notes")
    rows = {}
    for n in sizes:
        m = tiled(src, n)
        ticks = []
        w, c, pk, sm = measure(lambda: staggered.extract(m, progress=ticks.append))
        rows.setdefault("extract", []).append((n, w, c, pk))
        print(f"{n:>8} {'extract':<10} {w:>8.2f} {c:>8.2f} {pk:>8.0f}  K = {sm.num_poses}, "
              f"{len(ticks)} progress calls, fit mean residual {sm.metadata['fit']['mean_residual_rad']:.4f} rad")
        w, c, pk, out = measure(lambda: staggered.evaluate(sm))
        err = float(quat_angle(out.local_quats, m.local_quats).max())
        rows.setdefault("evaluate", []).append((n, w, c, pk))
        print(f"{n:>8} {'evaluate':<10} {w:>8.2f} {c:>8.2f} {pk:>8.0f}  reconstruction max {err:.1e} rad")
        del out
        w, c, pk, cu = measure(lambda: staggered.cull(sm, 50))
        rows.setdefault("cull 50%", []).append((n, w, c, pk))
        print(f"{n:>8} {'cull 50%':<10} {w:>8.2f} {c:>8.2f} {pk:>8.0f}  K = {cu.num_poses}")
        if args.baseline and n == sizes[0]:
            w0, c0, pk0, _ = measure(lambda: staggered.extract(m, fit_samples=None))
            print(f"{n:>8} {'extract*':<10} {w0:>8.2f} {c0:>8.2f} {pk0:>8.0f}  * previous fit (every sample): "
                  f"ratio previous / now {w0 / rows['extract'][-1][1]:.1f}x wall")
            w0, c0, pk0, _ = measure(lambda: staggered.cull(sm, 50, fit_samples=None))
            print(f"{n:>8} {'cull 50%*':<10} {w0:>8.2f} {c0:>8.2f} {pk0:>8.0f}  * previous fit: ratio "
                  f"{w0 / rows['cull 50%'][-1][1]:.1f}x wall")
        del sm, cu, m
    if len(sizes) > 1:
        print("# scaling exponent d log(cpu) / d log(n) over " + ", ".join(map(str, sizes)))
        for k, v in rows.items():
            n = np.log([r[0] for r in v])
            c = np.log([max(r[2], 1e-6) for r in v])
            print(f"  {k:<10} {np.polyfit(n, c, 1)[0]:.2f}")
    import resource
    print(f"# load average at the end {os.getloadavg()[0]:.1f}; process peak RSS "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 10:.0f} MB (all sizes, clips included)")


if __name__ == "__main__":
    main()
