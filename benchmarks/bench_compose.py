"""Issue 24 (one edit, three papers): the slider paths of a propagated pose edit and of a timing region, on 900 frames.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_compose.py``. Clip: CMU 01_01's first 900 frames
(``data/cmu_01_01.bvh``; the procedural walk looped to 900 frames if absent). A session warmed as the StaggerEditor
leaves it (extraction, the wand's graph and basis, the falloff of the edited frame: ``Session`` caches them), then
a slider moved through ``N`` positions; each position is a new op list replayed to the edited Motion
(``Session.set_ops`` + ``Session.edited``), as a slider move does. CPU time (``time.process_time``) per move,
each beside its baseline in this process:

* the nudge of a propagated pose edit (``edit_pose`` with ``"propagate": true``, the angle moving) against the same
  nudge without propagation (goal: <= 50 ms CPU per move, the slider budget);
* the succession ``s`` of a timing edit in a region (``"falloff": {"frame", "sigma"}``) against the same succession
  without the region;
* the first replay of a propagated edit at a new pose (its falloff computed once from the cached basis) and
  ``guide_poses`` with a 1.5x slower copy as reference (once; its kNN tables cached after), for scale.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from stagger_nb import timewarp
from stagger_nb.session import Session

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_staggered_interactive import clip

N = 12   # slider positions per path


def per_move(session: Session, lists) -> float:
    """Mean CPU seconds of one slider move: set the op list, replay to the edited Motion."""
    t = time.process_time()
    for ops in lists:
        session.set_ops(ops)
        session.edited()
    return (time.process_time() - t) / len(lists)


def main() -> None:
    m, name = clip()
    s = Session(m)
    sm = s.extraction()
    k = sm.num_poses // 2
    print(f"{name}: {m.num_frames} frames, {sm.num_poses} poses, {m.num_joints} joints; pose {k} edited")
    nudge = lambda a, prop: [{"op": "edit_pose", "pose": k, "deltas": {"LeftArm": [0.0, 0.0, a]},  # noqa: E731
                              **({"propagate": True} if prop else {})}]
    frame = int(round(sm.pose_times[k] / m.frame_time))
    succ = lambda v, region: [{"op": "succession", "root": "LeftShoulder", "s": v, "l": 1.0,  # noqa: E731
                               **({"falloff": {"frame": frame, "sigma": None}} if region else {})}]
    t = time.process_time()
    s.set_ops(nudge(1.0, True))
    s.edited()
    print(f"  warm-up (extraction, pose graph, basis, falloff, first replay): {time.process_time() - t:.2f} s CPU")
    per_move(s, [succ(0.001, True)])                  # the region's falloff of this frame: cached once
    angles = [2.0 + 1.5 * i for i in range(N)]
    plain = per_move(s, [nudge(a, False) for a in angles])
    prop = per_move(s, [nudge(a + 0.25, True) for a in angles])
    print(f"  nudge, propagated:          {1e3 * prop:7.1f} ms CPU per move (goal <= 50)   "
          f"ratio {prop / plain:.2f} x the plain nudge ({1e3 * plain:.1f} ms)")
    values = [0.002 + 0.001 * i for i in range(N)]
    plain = per_move(s, [succ(v, False) for v in values])
    region = per_move(s, [succ(v + 0.0005, True) for v in values])
    print(f"  succession s, in a region:  {1e3 * region:7.1f} ms CPU per move             "
          f"ratio {region / plain:.2f} x the succession alone ({1e3 * plain:.1f} ms)")
    t = time.process_time()
    s.set_ops([{"op": "edit_pose", "pose": k + 1, "deltas": {"LeftArm": [0.0, 0.0, 5.0]}, "propagate": True}])
    s.edited()
    first = time.process_time() - t
    print(f"  propagated edit at a new pose (its falloff computed): {1e3 * first:.1f} ms CPU, first visit")
    slow = timewarp.linear_warp(m, int(round((m.num_frames - 1) * 1.5)) + 1)[0]
    s.use_reference("<memory:slow>", slow)
    t = time.process_time()
    s.set_ops([{"op": "guide_poses", "reference": {"path": "<memory:slow>"}}])
    s.edited()
    guide = time.process_time() - t
    t = time.process_time()
    s.set_ops([{"op": "guide_poses", "reference": {"path": "<memory:slow>"}},
               {"op": "succession", "root": "LeftShoulder", "s": 0.01, "l": 1.0}])
    s.edited()
    after = time.process_time() - t
    print(f"  guide_poses (1.5x slower copy): {guide:.2f} s CPU once (tables + DP); a succession after it "
          f"{1e3 * after:.1f} ms CPU")
    s.close(wait=True)


if __name__ == "__main__":
    main()
