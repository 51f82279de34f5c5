"""Every quaternion helper of stagger_nb.core.rotations against scipy or a naive reference."""
import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from stagger_nb.core import rotations as R

N = 200


def rand_quats(n=N, seed=0):
    return Rotation.random(n, random_state=seed).as_quat()


def same_rotation(a, b, atol):
    """|<a, b>| == 1: equal up to the sign q ~ -q."""
    return np.allclose(np.abs(np.sum(a * b, axis=-1)), 1.0, atol=atol)


def naive_axis_matrix(axis, deg):
    """Elementary rotation matrix written out by hand (column vectors)."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    if axis == "X":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "Y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_quat_mul_and_conj_match_scipy():
    a, b = Rotation.random(N, random_state=1), Rotation.random(N, random_state=2)
    got = R.quat_mul(a.as_quat(), b.as_quat())
    assert same_rotation(got, (a * b).as_quat(), 1e-12)  # rounding of a 16-term product
    inv = R.quat_conj(a.as_quat())
    assert same_rotation(inv, a.inv().as_quat(), 1e-15)  # exact negation
    ident = R.quat_mul(a.as_quat(), inv)
    assert np.allclose(ident, R.IDENTITY, atol=1e-12)  # rounding
    assert R.quat_inv is R.quat_conj


def test_quat_mul_broadcasts():
    a = rand_quats(5, 3)
    b = rand_quats(7, 4)
    got = R.quat_mul(a[:, None], b[None, :])
    assert got.shape == (5, 7, 4)
    assert np.allclose(got[2, 3], R.quat_mul(a[2], b[3]), atol=0)  # same arithmetic


def test_one_quaternion_product_for_rows_and_last_axis():
    """quat_mul_components is the one product: on the rows of component-first (4, N) arrays (the kernels'
    layout) it gives quat_mul's bits, which match scipy (above); a 0-d component set works too."""
    from stagger_nb.staggered import _kernels
    a, b = rand_quats(seed=7), rand_quats(seed=8)
    A, B = np.ascontiguousarray(a.T), np.ascontiguousarray(b.T)
    rows = R.quat_mul_components(A, B, np.empty_like(A), np.empty(A.shape[1]))
    assert np.array_equal(rows.T, R.quat_mul(a, b))                    # same operations in the same order
    assert np.array_equal(_kernels.qmul_into(A, B, np.empty_like(A), np.empty(A.shape[1])), rows)
    assert np.array_equal(R.quat_mul(a[0], b[0]), R.quat_mul(a[:1], b[:1])[0])
    # the written-out Hamilton product of one pair, by hand
    (x1, y1, z1, w1), (x2, y2, z2, w2) = a[0], b[0]
    want = [w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2]
    assert np.array_equal(R.quat_mul(a[0], b[0]), want)


def test_quat_rotate_matches_scipy_and_matrix(rng):
    q = rand_quats(seed=5)
    v = rng.normal(size=(N, 3))
    want = Rotation.from_quat(q).apply(v)
    assert np.allclose(R.quat_rotate(q, v), want, atol=1e-12)  # rounding
    assert np.allclose(np.einsum("nij,nj->ni", R.quat_to_matrix(q), v), want, atol=1e-12)  # rounding
    assert np.allclose(R.quat_rotate(-q, v), want, atol=1e-12)  # q and -q rotate alike


def test_matrix_round_trip():
    q = rand_quats(seed=6)
    m = R.quat_to_matrix(q)
    assert np.allclose(m, Rotation.from_quat(q).as_matrix(), atol=1e-14)  # same scipy code path
    assert same_rotation(R.matrix_to_quat(m), q, 1e-12)  # rounding through the matrix
    assert R.quat_to_matrix(q.reshape(10, 20, 4)).shape == (10, 20, 3, 3)


def test_normalize_and_identity():
    q = rand_quats(seed=7) * np.linspace(0.1, 10, N)[:, None]
    assert np.allclose(np.linalg.norm(R.quat_normalize(q), axis=-1), 1.0, atol=1e-15)  # rounding
    assert np.array_equal(R.quat_normalize(np.zeros(4)), R.IDENTITY)
    assert R.quat_identity((2, 3)).shape == (2, 3, 4)
    assert np.array_equal(R.quat_identity(), R.IDENTITY)


def test_log_exp_round_trip_and_scipy():
    q = rand_quats(seed=8)
    v = R.quat_log(q)
    assert np.allclose(R.quat_exp(v), q, atol=1e-12)  # exact inverse up to rounding (even for w < 0)
    qh = R.quat_hemisphere(q)
    assert np.allclose(2 * R.quat_log(qh), Rotation.from_quat(q).as_rotvec(), atol=1e-12)  # rounding
    assert np.allclose(R.quat_to_rotvec(q), Rotation.from_quat(q).as_rotvec(), atol=1e-12)  # rounding
    r = Rotation.random(N, random_state=9).as_rotvec()
    assert same_rotation(R.rotvec_to_quat(r), Rotation.from_rotvec(r).as_quat(), 1e-12)  # rounding


@pytest.mark.parametrize("half_angle", [0.0, 1e-300, 1e-150, 1e-20, 1e-12, 1e-9, 1e-7, 1e-6, 2e-6, 1e-3])
def test_log_exp_small_angles(half_angle):
    axis = np.array([0.48, -0.6, 0.64])  # unit
    q = np.concatenate([np.sin(half_angle) * axis, [np.cos(half_angle)]])
    v = R.quat_log(q)
    # closed form: axis * half_angle, relative accuracy near machine epsilon
    assert np.allclose(v, axis * half_angle, rtol=1e-14, atol=1e-300)
    back = R.quat_exp(axis * half_angle)
    assert np.allclose(back, q, rtol=1e-15, atol=1e-300)  # sin(h)/h Taylor branch is exact to double here
    assert np.all(np.isfinite(v)) and np.all(np.isfinite(back))


def test_log_of_negative_identity_is_the_same_rotation():
    q = np.array([0.0, 0.0, 0.0, -1.0])
    assert same_rotation(R.quat_exp(R.quat_log(q)), q, 1e-15)
    assert np.allclose(R.quat_to_rotvec(q), 0.0)


def test_quat_angle_matches_scipy_and_is_sign_blind():
    a, b = rand_quats(seed=10), rand_quats(seed=11)
    want = (Rotation.from_quat(a).inv() * Rotation.from_quat(b)).magnitude()
    assert np.allclose(R.quat_angle(a, b), want, atol=1e-12)  # rounding
    assert np.allclose(R.quat_angle(a, -b), want, atol=1e-12)  # q ~ -q
    assert np.allclose(R.quat_angle(a), Rotation.from_quat(a).magnitude(), atol=1e-12)
    assert np.allclose(R.quat_angle(-a), Rotation.from_quat(a).magnitude(), atol=1e-12)


def test_hemisphere_and_continuity(rng):
    q = rand_quats(seed=12)
    h = R.quat_hemisphere(q)
    assert np.all(h[:, 3] >= 0) and same_rotation(h, q, 1e-15)
    assert np.array_equal(R.quat_hemisphere(-h), h) or np.all(h[:, 3] == 0)
    # a smooth path with random sign flips becomes continuous again, each frame the same rotation
    path = Slerp([0, 1], Rotation.from_quat(rand_quats(2, 13)))(np.linspace(0, 1, 50)).as_quat()
    flipped = path * rng.choice([-1.0, 1.0], size=(50, 1))
    c = R.quat_continuous(flipped, axis=0)
    assert np.all(np.sum(c[1:] * c[:-1], axis=-1) >= 0)
    assert same_rotation(c, path, 1e-15)
    # along another axis: (J, F, 4) continuous over F
    two = np.stack([flipped, -flipped])
    c2 = R.quat_continuous(two, axis=1)
    assert np.all(np.sum(c2[:, 1:] * c2[:, :-1], axis=-1) >= 0)


def test_slerp_endpoints_scipy_and_constant_speed():
    q0, q1 = rand_quats(1, 14)[0], rand_quats(1, 15)[0]
    if np.dot(q0, q1) < 0:
        q1 = -q1
    t = np.linspace(0, 1, 21)
    s = R.slerp(q0, q1, t)
    assert np.allclose(s[0], q0, atol=1e-15) and np.allclose(s[-1], q1, atol=1e-12)  # rounding of sin ratios
    want = Slerp([0, 1], Rotation.from_quat([q0, q1]))(t).as_quat()
    assert same_rotation(s, want, 1e-12)  # rounding
    steps = R.quat_angle(s[:-1], s[1:])
    assert np.allclose(steps, R.quat_angle(q0, q1) / 20, atol=1e-12)  # constant angular speed
    # shorter arc: -q1 gives the same rotations
    assert same_rotation(R.slerp(q0, -q1, t), s, 1e-12)
    # nearly equal quaternions: the linear branch keeps unit norm and endpoints
    q2 = R.quat_normalize(q0 + 1e-12)
    s2 = R.slerp(q0, q2, t)
    assert np.allclose(np.linalg.norm(s2, axis=-1), 1.0, atol=1e-15) and np.allclose(s2[-1], q2, atol=1e-15)


def test_slerp_broadcasts_per_element_t():
    a, b = rand_quats(30, 16), rand_quats(30, 17)
    t = np.linspace(0, 1, 30)
    got = R.slerp(a, b, t)
    want = np.stack([R.slerp(a[i], b[i], t[i]) for i in range(30)])
    assert np.allclose(got, want, atol=1e-15)  # same arithmetic per element


def test_quat_bezier_endpoints_and_collinear_controls():
    c = rand_quats(4, 18)
    t = np.linspace(0, 1, 11)
    b = R.quat_bezier(c[0], c[1], c[2], c[3], t)
    assert same_rotation(b[0], c[0], 1e-12) and same_rotation(b[-1], c[3], 1e-12)  # interpolates the ends
    assert np.allclose(np.linalg.norm(b, axis=-1), 1.0, atol=1e-14)
    # controls evenly spaced on the geodesic: the curve is slerp(q0, q3, t)
    q0, q3 = c[0], c[3] * np.sign(np.dot(c[0], c[3]))
    q1, q2 = R.slerp(q0, q3, 1 / 3), R.slerp(q0, q3, 2 / 3)
    assert same_rotation(R.quat_bezier(q0, q1, q2, q3, t), R.slerp(q0, q3, t), 1e-12)  # rounding
    # by hand: de Casteljau with scipy's Slerp at one parameter
    tt = 0.3

    def s(a, b_, x):
        return Slerp([0, 1], Rotation.from_quat([a, b_ * np.sign(np.dot(a, b_))]))([x]).as_quat()[0]
    d = s(s(c[0], c[1], tt), s(c[1], c[2], tt), tt)
    e = s(s(c[1], c[2], tt), s(c[2], c[3], tt), tt)
    assert same_rotation(R.quat_bezier(c[0], c[1], c[2], c[3], tt), s(d, e, tt), 1e-12)


TAIT_BRYAN = ["".join(p) for p in itertools.permutations("XYZ")]
PROPER = ["XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ"]


@pytest.mark.parametrize("order", TAIT_BRYAN + PROPER)
def test_euler_orders_against_hand_matrices(order, rng):
    ang = rng.uniform(-170, 170, size=(40, 3))
    ang[:, 1] = rng.uniform(5, 85, size=40) if order in PROPER else rng.uniform(-85, 85, size=40)
    q = R.euler_to_quat(ang, order)
    # intrinsic: first listed axis outermost, R = R_a1 R_a2 R_a3
    want = np.stack([naive_axis_matrix(order[0], a[0]) @ naive_axis_matrix(order[1], a[1])
                     @ naive_axis_matrix(order[2], a[2]) for a in ang])
    assert np.allclose(R.quat_to_matrix(q), want, atol=1e-12)  # rounding
    back = R.quat_to_euler(q, order)
    assert np.allclose(back, ang, atol=1e-9)  # away from gimbal lock the triple is unique
    assert np.allclose(R.quat_to_euler(-q, order), ang, atol=1e-9)  # q ~ -q
    assert R.euler_to_quat(ang.reshape(4, 10, 3), order).shape == (4, 10, 4)


def test_euler_at_gimbal_lock_gives_an_equivalent_triple():
    ang = np.array([[30.0, 90.0, 10.0]])
    q = R.euler_to_quat(ang, "ZYX")
    back = R.quat_to_euler(q, "ZYX")
    assert same_rotation(R.euler_to_quat(back, "ZYX"), q, 1e-12)  # any valid triple, same rotation


def test_quat_between_vectors(rng):
    u = rng.normal(size=(N, 3))
    v = rng.normal(size=(N, 3))
    q = R.quat_between_vectors(u, v)
    un, vn = u / np.linalg.norm(u, axis=1, keepdims=True), v / np.linalg.norm(v, axis=1, keepdims=True)
    assert np.allclose(R.quat_rotate(q, un), vn, atol=1e-12)  # rounding
    # shortest arc: angle equals the angle between the vectors
    assert np.allclose(R.quat_angle(q), np.arccos(np.clip(np.sum(un * vn, 1), -1, 1)), atol=1e-7)  # arccos near 0
    # parallel and antipodal
    assert np.allclose(R.quat_between_vectors(un, un), R.quat_identity(N), atol=1e-12)
    anti = R.quat_between_vectors(un, -un)
    assert np.allclose(R.quat_rotate(anti, un), -un, atol=1e-12)
    ex = np.array([1.0, 0, 0])
    assert np.allclose(R.quat_rotate(R.quat_between_vectors(ex, -ex), ex), -ex, atol=1e-12)
