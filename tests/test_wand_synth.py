"""Small synthetic motions shared by the wand tests (imported as ``test_wand_synth``), and checks of them."""
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


def test_cyclic_motion_is_periodic():
    m = cyclic_motion(F=81, period=40.0)
    q = m.local_quats
    # same pose one period later, up to the quaternion sign (rounding only)
    assert np.allclose(np.abs(np.sum(q[:41] * q[40:], axis=-1)), 1.0, atol=1e-12)


def test_loop_motion_continues_the_root():
    rp = np.cumsum(np.ones((10, 3)), axis=0)
    m = Motion(chain_skeleton(2), 0.1, rp, np.tile([0.0, 0.0, 0.0, 1.0], (10, 2, 1)))
    lm = loop_motion(m, 3)
    assert lm.num_frames == 30
    # a straight line with constant step 1 continues exactly across the joins
    assert np.allclose(np.diff(lm.root_positions, axis=0), 1.0, atol=1e-12)
