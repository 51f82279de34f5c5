"""Errors (not timings) at the clip's ends after cull 60 % and the StaggerEditor's ops, every clip.

For each BVH in the shared mocap folder and data/: extract -> cull 60 % -> each op in turn, evaluated and
compared with the source, printing per step the largest joint-rotation angle (degrees) over the first 5 and
the last 5 frames, at the very first/last frame, and the largest per-frame step of any joint in those frames
against the source's largest step anywhere (a squeezed end segment shows as a large step).

Steps: ``cull`` (alone), ``default`` (the editor's default ops at 60 %: cull + keep_contacts, run by a
Session), ``succ`` (succession from the root, s = 0.085 s/bone, l = 1: the review's case), ``succ.1`` (s = 0.1,
the slider's end), ``rt`` (random_timing tau = 0.15 s, the slider's end, seed 0). After a timing edit the
first/last 5 frames legitimately differ from the source (the motion is retimed); the first/last frame must
not (the end poses anchor the clip, §4.1).

Run: PYTHONPATH=$PWD STAGGER_NB_SHARED_MOCAP=/work/shared/mocap python benchmarks/clip_ends.py [name ...]
"""
import os
import sys
from pathlib import Path

import numpy as np

from stagger_nb import read_bvh, staggered
from stagger_nb.core.rotations import quat_angle
from stagger_nb.session import Session

shared = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or Path(__file__).resolve().parents[2] / "shared" / "mocap")
local = Path(os.environ.get("STAGGER_NB_DATA") or Path(__file__).resolve().parents[1] / "data")
files = sorted(shared.glob("*.bvh")) + sorted(local.glob("*.bvh"))
only = sys.argv[1:]
print(f"load average {os.getloadavg()[0]:.1f}; degrees: first5 / last5 max error | first / last frame error | "
      f"max step in first/last 5 frames (source's max step)")
worst = {}
for f in files:
    if only and not any(o in f.stem for o in only):
        continue
    m = read_bvh(f)
    if m.num_frames > 1200:
        print(f"{f.stem}: {m.num_frames} frames, skipped (long)")
        continue
    root = m.skeleton.names[0]
    c = staggered.cull(staggered.extract(m), 60)
    steps = {"cull": staggered.evaluate(c),
             "default": Session(m, [{"op": "cull", "percent": 60.0}, {"op": "keep_contacts"}]).edited(),
             "succ": staggered.evaluate(staggered.succession(c, root=root, s=0.085, l=1.0, ease_ends=True)),
             "succ.1": staggered.evaluate(staggered.succession(c, root=root, s=0.1, l=1.0, ease_ends=True)),
             "rt": staggered.evaluate(staggered.random_timing(c, tau=0.15, seed=0, ease_ends=True))}
    src_step = np.degrees(quat_angle(m.local_quats[1:], m.local_quats[:-1]).max())
    parts = []
    for name, e in steps.items():
        n = min(e.num_frames, m.num_frames)
        a = np.degrees(quat_angle(e.local_quats[:n], m.local_quats[:n]))       # (n, J)
        st = np.degrees(quat_angle(e.local_quats[1:n], e.local_quats[:n - 1]))
        row = (a[:5].max(), a[n - 5:n].max(), a[0].max(), a[n - 1].max(), max(st[:5].max(), st[-5:].max()))
        worst[name] = np.maximum(worst.get(name, 0), row)
        parts.append(f"{name} {row[0]:.2f}/{row[1]:.2f} | {row[2]:.2f}/{row[3]:.2f} | {row[4]:.1f}")
    print(f"{f.stem} ({m.num_frames} fr, {c.num_poses} poses, src step {src_step:.1f}): " + "; ".join(parts),
          flush=True)
print("max over clips: " + "; ".join(f"{k} {v[0]:.2f}/{v[1]:.2f} | {v[2]:.2f}/{v[3]:.2f} | {v[4]:.1f}"
                                     for k, v in worst.items()))
