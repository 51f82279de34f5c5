"""Small hand-built motions the wand tests share: a looping chain, a cyclic motion, a chain skeleton."""
from __future__ import annotations

import numpy as np

from stagger_nb import Motion, Skeleton, concatenate
from stagger_nb.core.rotations import rotvec_to_quat


def chain_skeleton(J: int = 4) -> Skeleton:
    """A J-joint chain with unit bones along +y."""
    offsets = np.zeros((J, 3))
    offsets[1:, 1] = 1.0
    return Skeleton(tuple(f"j{i}" for i in range(J)), np.arange(J) - 1, offsets)


def cyclic_motion(F: int = 120, period: float = 40.0, J: int = 4, noise: float = 0.0, seed: int = 0,
                  frame_time: float = 1 / 30) -> Motion:
    """Joint rotation vectors that are sinusoids of ``period`` frames with random axes/phases (seeded),
    plus optional per-frame Gaussian noise of ``noise`` radians."""
    rng = np.random.default_rng(seed)
    t = np.arange(F)[:, None, None]
    amp = rng.uniform(0.3, 0.8, size=(1, J, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(1, J, 3))
    rv = amp * np.sin(2 * np.pi * t / period + phase) + noise * rng.standard_normal((F, J, 3))
    return Motion(chain_skeleton(J), frame_time, np.zeros((F, 3)), rotvec_to_quat(rv))


def loop_motion(m: Motion, copies: int) -> Motion:
    """Repeat a cycle ``copies`` times; each copy's root continues from where the previous one ended
    (shifted by the clip's net displacement plus one average frame step), so the root does not jump back."""
    rp = m.root_positions
    step = (rp[-1] - rp[0]) / max(m.num_frames - 1, 1)
    shift = rp[-1] - rp[0] + step
    parts = [m.replace(root_positions=rp + c * shift) for c in range(copies)]
    return concatenate(parts)
