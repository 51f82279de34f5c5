"""Issue 24's region check as a table: a succession limited to a magic-wand region, against the same succession
without it, on every walk and hop clip of the issue's held-out check, for three delays.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/compose_region.py [clip ...]`` (default: the clips of
``tests/test_compose_heldout.py``). Per clip and ``s`` (seconds per bone, ``l = 1``, root: the left shoulder or
clavicle; region: the wand's falloff at the default sigma around the pose mid-clip, read at the poses): the
smallest share of the unscaled change a refinement keeps where the falloff is >= 0.9 ("inside", goal >= 0.8) and
the largest where it is <= 0.05 ("outside", goal <= 0.1; "-" where no pose is that far), the poses counted.
Numbers, not CPU time: run it with ``PYTHONPATH`` on another tree to compare two versions of the saturation.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.append(str(REPO))          # after PYTHONPATH: another tree given there is the one measured

from stagger_nb import data, read_bvh
from stagger_nb.session import Session

CLIPS = ["walk", "cmu_01_01", "xia_neutral_walk.bvh", "bandai_walk.bvh", "cmu_131_01_walk_startstop.bvh",
         "iclone_cmu_07_01_walk.bvh"]
ROOTS = ("LeftShoulder", "Shoulder_L", "CC_Base_L_Clavicle", "LeftArm")
DELAYS = (0.01, 0.02, 0.03)


def load(name: str):
    return read_bvh(REPO.parent / "shared" / "mocap" / name) if name.endswith(".bvh") else data.load(name)


def shares(s: Session, root: str, frame: int, delay: float):
    """(inside min, outside max or None, poses inside, poses outside) of one succession in a region."""
    plain = {"op": "succession", "root": root, "s": delay, "l": 1.0}
    s.set_ops([plain])
    unscaled = s.staggered().refinements - s.extraction().refinements
    s.set_ops([dict(plain, falloff={"frame": frame, "sigma": None})])
    scaled = s.staggered().refinements - s.extraction().refinements
    w = s.pose_falloff(frame)
    moved = np.abs(unscaled) > 0
    ratio = np.where(moved, np.abs(scaled) / np.where(moved, np.abs(unscaled), 1.0), np.nan)
    inside, outside = w >= 0.9, w <= 0.05
    out = float(np.nanmax(ratio[outside])) if np.any(moved[outside]) else None
    return float(np.nanmin(ratio[inside])), out, int(inside.sum()), int(outside.sum())


def main(names) -> None:
    import stagger_nb
    print(f"stagger_nb from {Path(stagger_nb.__file__).parent}")
    print(f"{'clip':34s} {'poses':>5s} {'in':>3s} {'out':>3s} " + " ".join(f"{'s=' + str(d):>15s}" for d in DELAYS))
    print(f"{'':34s} {'':>5s} {'':>3s} {'':>3s} " + " ".join(f"{'inside outside':>15s}" for _ in DELAYS))
    for name in names:
        s = Session(load(name))
        m = s.source
        root = next(n for n in ROOTS if n in m.skeleton.names)
        sm = s.extraction()
        frame = int(round(sm.pose_times[sm.num_poses // 2] / m.frame_time))
        cells = []
        for d in DELAYS:
            lo, hi, n_in, n_out = shares(s, root, frame, d)
            cells.append(f"{lo:7.2f} {'-' if hi is None else f'{hi:.2f}':>7s}")
        print(f"{name:34s} {sm.num_poses:5d} {n_in:3d} {n_out:3d} " + " ".join(f"{c:>15s}" for c in cells))


if __name__ == "__main__":
    main(sys.argv[1:] or CLIPS)
