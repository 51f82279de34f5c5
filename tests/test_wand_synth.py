"""Small synthetic motions shared by the wand tests (imported as ``test_wand_synth``), and checks of them."""
from __future__ import annotations

import numpy as np
from wand_motions import chain_skeleton, cyclic_motion, loop_motion

from stagger_nb import Motion


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
