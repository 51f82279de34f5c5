"""Gait phase marks for the issue-24 tests: frames where a walk or a hop sequence is at the same phase, step after
step, and frames half a cycle away (the opposite phase). Found from the motion itself, not from the wand.

* walks: the two feet's separation along the direction of travel, ``s(t) = (p_left - p_right) · d(t)`` (``d``
  the horizontal direction of the pelvis' smoothed velocity): a maximum is the left foot at its farthest ahead
  (the same phase of every gait cycle), a minimum the right foot's (the opposite phase); the arms swing against
  the legs, so the left arm is at its two extremes there;
* hops (both feet together, CMU 01_01): the pelvis height, smoothed 30 ms: maxima 10 units above its median are
  the flight apexes (the same phase of every hop); half-way between two apexes of a series of hops, the body is
  on the ground (the opposite phase).
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import find_peaks

from stagger_nb import forward_kinematics

#: (left foot, right foot, left upper arm) joint names of each rig
RIGS = {
    "cmu": ("LeftFoot", "RightFoot", "LeftArm"),
    "cmu_131": ("LeftAnkle", "RightAnkle", "LeftShoulder"),
    "bandai": ("Foot_L", "Foot_R", "UpperArm_L"),
    "iclone": ("CC_Base_L_Foot", "CC_Base_R_Foot", "CC_Base_L_Upperarm"),
}


def rig_of(motion) -> tuple:
    names = set(motion.skeleton.names)
    for feet in RIGS.values():
        if set(feet) <= names:
            return feet
    raise KeyError(f"no rig of RIGS fits joints {sorted(names)[:6]}...")


def walk_marks(motion, left: str, right: str, prominence: float = 0.4):
    """``(same, opposite)`` frame indices of a walk (see the module docstring)."""
    pos = forward_kinematics(motion)[0]
    ft = motion.frame_time
    travel = [np.ptp(pos[:, i, 0]) + np.ptp(pos[:, i, 2]) for i in range(min(3, motion.num_joints))]
    pelvis = pos[:, int(np.argmax(travel))]          # the root, or the Hips that carries the travel (Bandai)
    v = np.gradient(gaussian_filter1d(pelvis, 0.5 / ft, axis=0), axis=0)
    v[:, 1] = 0.0
    d = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12)
    names = list(motion.skeleton.names)
    s = np.einsum("fi,fi->f", pos[:, names.index(left)] - pos[:, names.index(right)], d)
    s = gaussian_filter1d(s, 0.03 / ft)
    hi, _ = find_peaks(s, prominence=prominence * np.ptp(s))
    lo, _ = find_peaks(-s, prominence=prominence * np.ptp(s))
    return hi, lo


def hop_marks(motion):
    """``(apexes, between)`` frame indices of a hop sequence (see the module docstring): the flight apexes and
    the frames half-way between two consecutive apexes of one series (hops at most 1.5 median hop periods
    apart), where the body is on the ground between the landing and the next take-off."""
    ft = motion.frame_time
    y = gaussian_filter1d(motion.root_positions[:, 1], 0.03 / ft)
    hi, _ = find_peaks(y, prominence=10.0)
    hi = hi[y[hi] > np.median(y) + 10.0]
    gap = np.diff(hi)
    series = gap <= 1.5 * np.median(gap)
    return hi, ((hi[:-1] + hi[1:]) // 2)[series]
