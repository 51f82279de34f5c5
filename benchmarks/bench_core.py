"""Forward-kinematics speed on a CMU 01_01-sized motion (2752 frames, 31 joints).

Target (issue 2): ``forward_kinematics`` <= 10 ms. Baselines measured in the same process:
the straightforward per-joint quaternion loop (the package's first implementation) and the
per-joint 4x4 homogeneous-matrix composition with scipy rotations (the test reference).

Run: ``.venv/bin/python benchmarks/bench_core.py``. Uses ``data/cmu_01_01.bvh`` when prepared,
else the procedural walk tiled to the same size (same joint count, same work).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from stagger_nb import data, forward_kinematics  # noqa: E402
from stagger_nb.core.reference import forward_kinematics_reference  # noqa: E402
from stagger_nb.core.rotations import quat_mul, quat_rotate  # noqa: E402

FRAMES = 2752
TARGET_MS = 10.0


def per_joint_quaternion_loop(motion):
    """Baseline: one quat_mul + quat_rotate per joint over all frames, (F, J, 4) layout."""
    lq = np.asarray(motion.local_quats)
    tr = motion.translations()
    parents = motion.skeleton.parents
    F, J, _ = lq.shape
    wq = np.empty((F, J, 4))
    pos = np.empty((F, J, 3))
    wq[:, 0], pos[:, 0] = lq[:, 0], tr[:, 0]
    for j in range(1, J):
        p = parents[j]
        wq[:, j] = quat_mul(wq[:, p], lq[:, j])
        pos[:, j] = pos[:, p] + quat_rotate(wq[:, p], tr[:, j])
    return pos, wq


def timeit(fn, repeats):
    fn()  # warm up
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts) * 1e3, float(np.median(ts)) * 1e3


def main():
    try:
        src, label = data.load("cmu_01_01"), "CMU 01_01"
    except FileNotFoundError:
        src, label = data.load("walk"), "procedural walk (data/cmu_01_01.bvh not prepared)"
    idx = np.arange(FRAMES) % src.num_frames
    m = src.replace(local_quats=src.local_quats[idx], root_positions=src.root_positions[idx],
                    local_translations=None if src.local_translations is None else src.local_translations[idx])
    print(f"motion: {label}, {m.num_frames} frames x {m.num_joints} joints")

    fast_min, fast_med = timeit(lambda: forward_kinematics(m), 50)
    loop_min, loop_med = timeit(lambda: per_joint_quaternion_loop(m), 20)
    ref_min, ref_med = timeit(lambda: forward_kinematics_reference(m), 5)
    p, _ = forward_kinematics(m)
    pr, _ = forward_kinematics_reference(m)
    err = np.abs(p - pr).max() / np.abs(pr).max()

    print(f"forward_kinematics              : {fast_min:7.2f} ms (median {fast_med:.2f})")
    print(f"baseline per-joint quat loop    : {loop_min:7.2f} ms (median {loop_med:.2f})  "
          f"ratio {fast_min / loop_min:.2f}x  ({loop_min / fast_min:.1f}x faster)")
    print(f"baseline scipy 4x4 composition  : {ref_min:7.2f} ms (median {ref_med:.2f})  "
          f"ratio {fast_min / ref_min:.3f}x  ({ref_min / fast_min:.1f}x faster)")
    print(f"max relative position difference vs scipy reference: {err:.1e}")
    print(f"target forward_kinematics <= {TARGET_MS:.0f} ms: {'met' if fast_min <= TARGET_MS else 'MISSED'}")


if __name__ == "__main__":
    main()
