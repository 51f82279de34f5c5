"""detect_contacts with forward kinematics of the effectors' and feet's chains only (now) against full FK
of every joint (the previous default, ``positions=forward_kinematics(m)[0]``), in the same process.

Clip: ../shared/mocap/xia_neutral_walk.bvh (or the procedural walk) looped to about 100,000 frames, the long
take of issue 13. Prints CPU time (least of 3) of both, their ratio, that the contacts are equal, and the
load average. Run: PYTHONPATH=$PWD STAGGER_NB_SHARED_MOCAP=/work/shared/mocap python benchmarks/bench_contacts.py
"""
import os
import time
from pathlib import Path

from stagger_nb import data, read_bvh, staggered
from stagger_nb.core.kinematics import forward_kinematics
from stagger_nb.core.motion import concatenate

# ../shared/mocap beside the repository, or STAGGER_NB_SHARED_MOCAP (e.g. from a git worktree)
p = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or Path(__file__).resolve().parents[2] / "shared" / "mocap")
p = p / "xia_neutral_walk.bvh"
m = read_bvh(p) if p.is_file() else data.load("walk")
m = concatenate([m] * max(1, 100_000 // m.num_frames))
print(f"{p.name if p.is_file() else 'procedural walk'} looped: {m.num_frames} frames x {m.num_joints} joints; "
      f"load average {os.getloadavg()[0]:.1f}")


def full():
    return staggered.detect_contacts(m, positions=forward_kinematics(m)[0])


def chains():
    return staggered.detect_contacts(m)


best = {}
for _ in range(3):
    for f in (full, chains):
        t = time.process_time()
        out = f()
        best[f] = min(best.get(f, 1e9), time.process_time() - t)
same = full() == chains()
print(f"detect_contacts CPU least of 3: effector chains {best[chains]:.2f} s vs full FK {best[full]:.2f} s "
      f"(ratio {best[chains] / best[full]:.2f}); {len(out)} contacts, equal: {same}; "
      f"load average {os.getloadavg()[0]:.1f}")
