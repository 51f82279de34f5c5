"""Motion and Skeleton: frozen data, validation naming the field, slicing, resampling, concatenation."""
import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from stagger_nb.core import Motion, Skeleton, concatenate
from stagger_nb.core.rotations import quat_angle


def chain_skeleton(J=4):
    """A chain 0 <- 1 <- 2 ... plus (for J >= 4) joint 3 branching off joint 1."""
    parents = [-1, 0, 1, 1][:J] + list(range(3, J - 1))
    offsets = np.arange(J * 3, dtype=float).reshape(J, 3) / 10.0
    return Skeleton([f"j{i}" for i in range(J)], parents, offsets)


def random_motion(F=30, J=4, seed=0, frame_time=0.1, translations=False):
    rng = np.random.default_rng(seed)
    q = Rotation.random(F * J, random_state=seed).as_quat().reshape(F, J, 4)
    lt = rng.normal(size=(F, J, 3)) if translations else None
    return Motion(chain_skeleton(J), frame_time, rng.normal(size=(F, 3)), q, lt)


def smooth_motion(F=25, J=4, seed=1, frame_time=0.1):
    """Each joint turns along a geodesic: frames are exactly slerp between the ends."""
    ends = Rotation.random(2 * J, random_state=seed).as_quat().reshape(2, J, 4)
    t = np.linspace(0, 1, F)
    q = np.stack([Slerp([0, 1], Rotation.from_quat(ends[:, j]))(t).as_quat() for j in range(J)], axis=1)
    rp = np.stack([t, 2 * t, -t], axis=1)
    return Motion(chain_skeleton(J), frame_time, rp, q)


# --- Skeleton ------------------------------------------------------------------------------------

def test_skeleton_helpers():
    s = chain_skeleton(6)  # parents [-1, 0, 1, 1, 3, 4]
    assert s.num_joints == 6 and s.index("j3") == 3
    assert s.children(1) == [2, 3] and s.children(5) == []
    assert list(s.depth()) == [0, 1, 2, 2, 3, 4]
    assert list(s.is_leaf()) == [False, False, True, False, False, True]
    with pytest.raises(KeyError, match="nope"):
        s.index("nope")


def test_tree_distance_against_brute_force():
    s = chain_skeleton(6)

    def ancestors(j):
        out = [j]
        while s.parents[out[-1]] >= 0:
            out.append(int(s.parents[out[-1]]))
        return out

    for r in range(6):
        d = s.tree_distance(r)
        for j in range(6):
            a, b = ancestors(r), ancestors(j)
            common = next(x for x in a if x in b)  # lowest common ancestor
            assert d[j] == a.index(common) + b.index(common)
    assert np.array_equal(s.tree_distance("j2"), s.tree_distance(2))


def test_skeleton_is_frozen_and_copies_inputs():
    offsets = np.zeros((3, 3))
    s = Skeleton(["a", "b", "c"], [-1, 0, 1], offsets)
    offsets[1, 0] = 5.0
    assert s.offsets[1, 0] == 0.0
    with pytest.raises(ValueError):
        s.offsets[0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.names = ("x",)
    assert s == Skeleton(["a", "b", "c"], [-1, 0, 1], np.zeros((3, 3)))
    assert s != Skeleton(["a", "b", "d"], [-1, 0, 1], np.zeros((3, 3)))


@pytest.mark.parametrize("kwargs, match", [
    (dict(names=["a", "b"], parents=[-1, 0, 0], offsets=np.zeros((2, 3))), "parents"),
    (dict(names=["a", "b"], parents=[0, -1], offsets=np.zeros((2, 3))), "root"),
    (dict(names=["a", "b", "c"], parents=[-1, 2, 0], offsets=np.zeros((3, 3))), "parent"),
    (dict(names=["a", "b"], parents=[-1, 0], offsets=np.zeros((2, 3)), channels=[("Xrotation",)]), "channels"),
])
def test_skeleton_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Skeleton(**kwargs)


# --- Motion: construction --------------------------------------------------------------------------

def test_motion_is_frozen_with_read_only_copies():
    q = Rotation.random(12, random_state=3).as_quat().reshape(3, 4, 4)
    rp = np.zeros((3, 3))
    m = Motion(chain_skeleton(), 0.1, rp, q)
    rp[0, 0] = 9.0
    q[0, 0] = [1.0, 0, 0, 0]
    assert m.root_positions[0, 0] == 0.0 and not np.allclose(m.local_quats[0, 0], [1.0, 0, 0, 0])
    for a in (m.root_positions, m.local_quats):
        assert not a.flags.writeable
        with pytest.raises(ValueError):
            a[0] = 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.frame_time = 1.0
    lt = random_motion(translations=True).local_translations
    assert not lt.flags.writeable


def test_motion_normalises_and_makes_quaternions_continuous(rng):
    m0 = smooth_motion()
    flips = rng.choice([-1.0, 1.0], size=(m0.num_frames, m0.num_joints, 1))
    scaled = np.asarray(m0.local_quats) * flips * 3.0
    m = m0.replace(local_quats=scaled)
    assert np.all(np.sum(m.local_quats[1:] * m.local_quats[:-1], axis=-1) >= 0)
    assert np.allclose(np.linalg.norm(m.local_quats, axis=-1), 1.0, atol=1e-15)
    assert np.allclose(quat_angle(m.local_quats, m0.local_quats), 0.0, atol=1e-7)  # arccos-free angle, rounding


@pytest.mark.parametrize("field, value, match", [
    ("frame_time", 0.0, "frame_time"),
    ("frame_time", -0.1, "frame_time"),
    ("frame_time", float("nan"), "frame_time"),
    ("local_quats", np.zeros((5, 3, 4)), "local_quats"),
    ("local_quats", np.zeros((5, 4, 3)), "local_quats"),
    ("root_positions", np.zeros((4, 3)), "root_positions"),
    ("root_positions", np.zeros((5, 2)), "root_positions"),
    ("local_translations", np.zeros((5, 4, 2)), "local_translations"),
    ("root_positions", np.full((5, 3), np.inf), "root_positions"),
    ("local_quats", np.full((5, 4, 4), np.nan), "local_quats"),
    ("local_translations", np.full((5, 4, 3), np.nan), "local_translations"),
    ("skeleton", "not a skeleton", "skeleton"),
])
def test_motion_validation_names_the_field(field, value, match):
    fields = dict(skeleton=chain_skeleton(), frame_time=0.1, root_positions=np.zeros((5, 3)),
                  local_quats=np.tile([0, 0, 0, 1.0], (5, 4, 1)))
    fields[field] = value
    with pytest.raises(ValueError, match=match):
        Motion(**fields)


def test_motion_properties():
    m = random_motion(F=30, frame_time=0.1)
    assert m.num_frames == len(m) == 30 and m.num_joints == 4
    assert m.duration == pytest.approx(2.9) and m.fps == pytest.approx(10.0)
    assert np.allclose(m.times, np.arange(30) * 0.1)
    t = m.translations()
    assert np.array_equal(t[:, 0], m.root_positions) and np.array_equal(t[:, 1:], np.broadcast_to(
        m.skeleton.offsets[1:], (30, 3, 3)))
    mt = random_motion(F=30, translations=True)
    assert np.array_equal(mt.translations()[:, 1:], mt.local_translations[:, 1:])
    assert np.array_equal(mt.translations()[:, 0], mt.root_positions)


# --- Motion: new motions ---------------------------------------------------------------------------

def test_slice_is_half_open_and_copies_values():
    m = random_motion(F=30, translations=True)
    s = m.slice(2, 5)
    assert s.num_frames == 3
    assert np.array_equal(s.local_quats, m.local_quats[2:5])
    assert np.array_equal(s.root_positions, m.root_positions[2:5])
    assert np.array_equal(s.local_translations, m.local_translations[2:5])
    assert m.slice(None, 4).num_frames == 4 and m.slice(-3).num_frames == 3
    st = m.slice(0, 10, 3)
    assert st.num_frames == 4 and st.frame_time == pytest.approx(0.3)
    assert np.array_equal(st.root_positions, m.root_positions[0:10:3])
    with pytest.raises(ValueError, match="empty"):
        m.slice(5, 5)
    assert m.num_frames == 30  # the source is untouched


def test_resample_duration_and_values():
    m = smooth_motion(F=25, frame_time=0.1)  # 2.4 s
    up = m.resample(0.05)
    assert up.num_frames == 49 and up.duration == pytest.approx(m.duration)
    assert up.frame_time == 0.05
    # even frames are the originals, odd frames the slerp midpoints (checked with scipy's Slerp)
    assert np.allclose(quat_angle(up.local_quats[::2], m.local_quats), 0, atol=1e-7)  # rounding in angle
    for j in range(m.num_joints):
        want = Slerp(m.times, Rotation.from_quat(m.local_quats[:, j]))(up.times).as_quat()
        assert np.allclose(np.abs(np.sum(up.local_quats[:, j] * want, axis=-1)), 1, atol=1e-12)  # up to sign
    assert np.allclose(up.root_positions[1::2], 0.5 * (m.root_positions[1:] + m.root_positions[:-1]), atol=1e-15)
    down = m.resample(0.3)  # 2.4 s / 0.3 s = 8 intervals
    assert down.num_frames == 9 and down.duration == pytest.approx(2.4)
    assert np.allclose(down.root_positions, m.root_positions[::3], atol=1e-12)
    odd = m.resample(0.07)  # 2.4 / 0.07 = 34.3 -> covers [0, 2.38]
    assert odd.num_frames == 35 and odd.duration <= m.duration + 1e-12
    with pytest.raises(ValueError, match="frame_time"):
        m.resample(0)


def test_sample_and_sample_times_clamp():
    m = smooth_motion()
    s = m.sample([-5.0, 0.0, 3.5, 1e9])
    assert np.array_equal(s.root_positions[0], m.root_positions[0])
    assert np.array_equal(s.root_positions[-1], m.root_positions[-1])
    assert np.allclose(s.root_positions[2], 0.5 * (m.root_positions[3] + m.root_positions[4]))
    st = m.sample_times([0.35])
    assert np.allclose(st.root_positions, s.root_positions[2:3])


def test_concatenate():
    a = random_motion(F=10, seed=1)
    b = random_motion(F=7, seed=2)
    c = concatenate([a, b])
    assert c.num_frames == 17
    assert np.array_equal(c.root_positions, np.concatenate([a.root_positions, b.root_positions]))
    assert np.allclose(quat_angle(c.local_quats[10:], b.local_quats), 0, atol=1e-7)  # sign may flip
    assert c.local_translations is None
    mixed = concatenate([a, random_motion(F=5, seed=3, translations=True)])
    assert mixed.local_translations is not None and np.array_equal(
        mixed.local_translations[:10, 1:], np.broadcast_to(a.skeleton.offsets[1:], (10, 3, 3)))
    with pytest.raises(ValueError, match="frame_time"):
        concatenate([a, random_motion(F=5, frame_time=0.2)])
    with pytest.raises(ValueError, match="skeleton"):
        concatenate([a, random_motion(F=5, J=5)])
    with pytest.raises(ValueError, match="no motions"):
        concatenate([])


def test_replace_returns_a_new_validated_motion():
    m = random_motion()
    m2 = m.replace(root_positions=np.zeros((30, 3)))
    assert m2 is not m and np.all(m2.root_positions == 0) and not np.all(m.root_positions == 0)
    with pytest.raises(ValueError, match="root_positions"):
        m.replace(root_positions=np.zeros((3, 3)))
