"""Long takes for staggered poses (issue 13, "Long takes"): extract, cull and evaluate on a real walk tiled to
10,000 / 30,000 / 100,000 frames x 31 joints.

Run: ``nice .venv/bin/python benchmarks/bench_staggered_long.py [--sizes 10000,30000,100000] [--baseline]``.
The clip is ``../shared/mocap/xia_neutral_walk.bvh`` (120 Hz) repeated with its root travel carried on (the
procedural walk if absent). For each size it prints wall and CPU time and the peak of traced memory
(tracemalloc: numpy's buffers, the interpreter's objects) of each call, then the scaling exponent
``d log t / d log n`` fitted over the sizes (1 = linear; n log n reads about 1.1 here). ``--baseline`` also
times the previous fit (every sample, ``fit_samples=None``) at the smallest size, in this process, as a
ratio. Goals: 100,000 frames within 2 GB, extract <= 10 s, exponent <= ~1.1. ``--bounded`` times only the
bounded-work paths whose results tests/test_staggered_long.py checks (refusals, 10^9 smoothing passes, 5 kHz).
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

from stagger_nb import read_bvh, staggered
from stagger_nb.core.motion import Motion, concatenate
from stagger_nb.core.rotations import quat_angle

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


def bounded_work():
    """CPU time of the bounded-work paths tests/test_staggered_long.py checks for their results (timings belong
    here, not in the tests), each with a baseline measured in this process."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    import dataclasses

    from helpers import chain_motion

    from stagger_nb.staggered.features import laplacian_smooth
    x = np.random.default_rng(0).normal(size=(5000, 8))
    _, c64, _, _ = measure(lambda: laplacian_smooth(x, 64, 0.5))
    _, c9, _, _ = measure(lambda: laplacian_smooth(x, 10 ** 9, 0.5))
    print(f"laplacian_smooth 5000 x 8, 10^9 passes {1e3 * c9:8.2f} ms cpu  ratio {c9 / max(c64, 1e-9):.2f} x 64 passes "
          f"(the loop, {1e3 * c64:.2f} ms)")
    m = chain_motion([0.5, 1.0, 1.5], duration=2.0)
    _, c_ok, _, sm = measure(lambda: staggered.extract(m))

    def refused(f):
        try:
            f()
        except ValueError:
            return
        raise AssertionError("not refused")
    _, c_bad, _, _ = measure(lambda: refused(lambda: staggered.extract(m, iterations=1e9)))
    print(f"extract refusing iterations=1e9        {1e3 * c_bad:8.2f} ms cpu  ratio {c_bad / c_ok:.3f} x a valid "
          f"extract ({1e3 * c_ok:.2f} ms)")
    tiny = dataclasses.replace(sm, frame_time=1e-9)
    _, c_t, _, _ = measure(lambda: refused(lambda: staggered.evaluate(tiny)))
    _, c_ev, _, _ = measure(lambda: staggered.evaluate(sm))
    print(f"evaluate refusing frame_time 1e-9      {1e3 * c_t:8.2f} ms cpu  ratio {c_t / max(c_ev, 1e-9):.3f} x "
          f"evaluate ({1e3 * c_ev:.2f} ms)")
    hi = chain_motion([0.2, 0.25, 0.3], duration=0.4, fps=5000.0)
    _, c_hi, _, _ = measure(lambda: staggered.extract(hi))
    print(f"extract at 5000 fps (2001 frames)      {1e3 * c_hi:8.2f} ms cpu  ratio {c_hi / c_ok:.1f} x the 120 fps "
          f"extract")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="10000,30000,100000")
    ap.add_argument("--baseline", action="store_true")
    ap.add_argument("--bounded", action="store_true", help="only the bounded-work paths of test_staggered_long")
    args = ap.parse_args()
    if args.bounded:
        return bounded_work()
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
        sm = cu = m = None   # free them before the next size (no `del`: the timed lambdas above name them)
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
