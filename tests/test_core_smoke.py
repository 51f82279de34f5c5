import numpy as np

from stagger_nb.core import rotations as R


def test_quat_mul_matches_scipy(rng):
    from scipy.spatial.transform import Rotation
    a = Rotation.random(50, random_state=1)
    b = Rotation.random(50, random_state=2)
    got = R.quat_mul(a.as_quat(), b.as_quat())
    want = (a * b).as_quat()
    assert np.allclose(np.abs(np.sum(got * want, axis=-1)), 1.0, atol=1e-12)  # equal up to sign
