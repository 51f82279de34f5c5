"""What a 3D view highlights over time: the joints' states (staggered pose, contact) per frame and as step keys,
and the motion trails around the playhead."""
from __future__ import annotations

import numpy as np


def highlight_keys(num_frames: int, frame_time: float, num_joints: int, pose_frames=(), contacts=(),
                   pose_window_s: float = 0.05):
    """Per-joint state over time for the sphere colours (:func:`joint_states`) as step keys: returns
    ``{joint: (times (K,) float32, states (K,) uint8)}`` for joints whose state ever changes or is not 0."""
    state = joint_states(num_frames, frame_time, num_joints, pose_frames, contacts, pose_window_s)
    out = {}
    for j in range(num_joints):
        s = state[:, j]
        if np.any(s != s[0]) or s[0] != 0:
            idx = np.concatenate([[0], np.flatnonzero(s[1:] != s[:-1]) + 1])
            out[j] = ((idx * frame_time).astype(np.float32), s[idx])
    return out


def joint_states(num_frames: int, frame_time: float, num_joints: int, pose_frames=(), contacts=(),
                 pose_window_s: float = 0.05) -> np.ndarray:
    """Per-frame joint state ``(F, J)`` uint8 for the sphere colours: 0 plain, 1 at a staggered-pose frame
    (± ``pose_window_s`` so it is seen while playing), 2 in contact (wins over 1). ``contacts``:
    ``[(joint_index, start, end), ...]`` half-open frame ranges."""
    F = int(num_frames)
    pose = np.zeros(F, dtype=bool)
    w = max(1, int(round(pose_window_s / frame_time)))
    for p in np.asarray(pose_frames, dtype=int).reshape(-1):
        if 0 <= p < F:
            pose[max(0, p - w):min(F, p + w + 1)] = True
    state = np.zeros((F, int(num_joints)), dtype=np.uint8)
    state[pose] = 1
    for j, a, b in contacts:
        state[max(0, int(a)):min(F, int(b)), int(j)] = 2
    return state


def trail_segments(points: np.ndarray, joints, frame: int, window: int) -> np.ndarray:
    """Line-segment end points ``(len(joints) * 2 window * 2, 3)`` float32 of the trails of ``joints`` (point
    indices into ``points (F, P, 3)``) over frames ``frame - window .. frame + window``: segment k of a joint
    joins frames ``a = frame - window + k`` and ``a + 1``, both clamped to the clip (outside it: a point)."""
    F = points.shape[0]
    a = np.clip(int(frame) - int(window) + np.arange(2 * int(window)), 0, F - 1)
    b = np.clip(int(frame) - int(window) + np.arange(2 * int(window)) + 1, 0, F - 1)
    out = [np.stack([points[a, j], points[b, j]], 1).reshape(-1, 3) for j in joints]
    return np.concatenate(out).astype(np.float32) if out else np.zeros((0, 3), np.float32)
