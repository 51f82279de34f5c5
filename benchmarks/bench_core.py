"""Forward-kinematics speed on a CMU 01_01-sized motion (2752 frames, 31 joints), and ``import stagger_nb`` time.

Targets (issue 13): ``forward_kinematics`` <= 8 ms; ``import stagger_nb`` <= 0.25 s.
FK baselines measured in the same process:
the straightforward per-joint quaternion loop (the package's first implementation) and the
per-joint 4x4 homogeneous-matrix composition with scipy rotations (the test reference).

The import is timed in fresh interpreters (each run: ``import numpy`` alone as the baseline, then
``import stagger_nb``, wall and CPU time), best and median of several runs.

Run: ``.venv/bin/python benchmarks/bench_core.py``. Uses ``data/cmu_01_01.bvh`` when prepared,
else the procedural walk tiled to the same size (same joint count, same work).
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from stagger_nb import data, forward_kinematics
from stagger_nb.core.rotations import quat_mul, quat_rotate

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the naive references live beside the tests
from references import forward_kinematics_reference

FRAMES = 2752
TARGET_MS = 8.0
IMPORT_TARGET_S = 0.25
_IMPORT_PROBE = """
import time
t0, c0 = time.perf_counter(), time.process_time()
import {mod}
print(time.perf_counter() - t0, time.process_time() - c0)
"""


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


def timeit(fn, repeats, clock=time.perf_counter):
    fn()  # warm up
    ts = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        ts.append(clock() - t0)
    return min(ts) * 1e3, float(np.median(ts)) * 1e3


def import_times(mod: str, runs: int = 7) -> tuple[float, float, float]:
    """(best wall, median wall, best CPU) seconds of ``import mod`` in fresh interpreters."""
    repo = str(Path(__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": repo + os.pathsep + os.environ.get("PYTHONPATH", "")}
    walls, cpus = [], []
    for _ in range(runs):
        out = subprocess.run([sys.executable, "-c", _IMPORT_PROBE.format(mod=mod)], capture_output=True,
                             text=True, env=env, check=True).stdout.split()
        walls.append(float(out[0]))
        cpus.append(float(out[1]))
    return min(walls), float(np.median(walls)), min(cpus)


def main():
    try:
        src, label = data.load("cmu_01_01"), "CMU 01_01"
    except FileNotFoundError:
        src, label = data.load("walk"), "procedural walk (data/cmu_01_01.bvh not prepared)"
    idx = np.arange(FRAMES) % src.num_frames
    m = src.replace(local_quats=src.local_quats[idx], root_positions=src.root_positions[idx],
                    local_translations=None if src.local_translations is None else src.local_translations[idx])
    print(f"motion: {label}, {m.num_frames} frames x {m.num_joints} joints")

    print("load average at start: %.2f %.2f %.2f (on %d CPUs)" % (os.getloadavg() + (os.cpu_count(),)))
    fast_min, fast_med = timeit(lambda: forward_kinematics(m), 50)
    fast_cpu, _ = timeit(lambda: forward_kinematics(m), 50, clock=time.process_time)
    loop_min, loop_med = timeit(lambda: per_joint_quaternion_loop(m), 20)
    ref_min, ref_med = timeit(lambda: forward_kinematics_reference(m), 5)
    p, _ = forward_kinematics(m)
    pr, _ = forward_kinematics_reference(m)
    err = np.abs(p - pr).max() / np.abs(pr).max()

    print(f"forward_kinematics              : {fast_min:7.2f} ms (median {fast_med:.2f}; CPU best {fast_cpu:.2f})")
    print(f"baseline per-joint quat loop    : {loop_min:7.2f} ms (median {loop_med:.2f})  "
          f"ratio {fast_min / loop_min:.2f}x  ({loop_min / fast_min:.1f}x faster)")
    print(f"baseline scipy 4x4 composition  : {ref_min:7.2f} ms (median {ref_med:.2f})  "
          f"ratio {fast_min / ref_min:.3f}x  ({ref_min / fast_min:.1f}x faster)")
    print(f"max relative position difference vs scipy reference: {err:.1e}")
    print(f"target forward_kinematics <= {TARGET_MS:.0f} ms: wall {'met' if fast_min <= TARGET_MS else 'MISSED'}, "
          f"CPU {'met' if fast_cpu <= TARGET_MS else 'MISSED'}")

    np_best, np_med, np_cpu = import_times("numpy")
    sn_best, sn_med, sn_cpu = import_times("stagger_nb")
    sc_best, _, _ = import_times("scipy.spatial.transform")
    print(f"import numpy (baseline)         : {np_best:6.3f} s (median {np_med:.3f}; CPU best {np_cpu:.3f})")
    print(f"import scipy.spatial.transform  : {sc_best:6.3f} s (no longer imported by import stagger_nb)")
    print(f"import stagger_nb               : {sn_best:6.3f} s (median {sn_med:.3f}; CPU best {sn_cpu:.3f})  "
          f"ratio to numpy {sn_best / np_best:.2f}x")
    print(f"target import stagger_nb <= {IMPORT_TARGET_S} s: wall {'met' if sn_best <= IMPORT_TARGET_S else 'MISSED'}, "
          f"CPU {'met' if sn_cpu <= IMPORT_TARGET_S else 'MISSED'}")
    print("load average at end: %.2f %.2f %.2f" % os.getloadavg())


if __name__ == "__main__":
    main()
