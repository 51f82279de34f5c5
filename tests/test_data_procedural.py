"""Procedural clips: planted feet, ballistic flight, determinism, the CMU joint layout, BVH round trip."""
import numpy as np
import pytest
from conftest import shared_clip_path

from stagger_nb import forward_kinematics, read_bvh, write_bvh
from stagger_nb.data import procedural as P


@pytest.fixture(scope="module")
def clips():
    out = {}
    for name in P.CLIPS:
        m, contacts = P.generate(name, return_contacts=True)
        pos, wq = forward_kinematics(m)
        out[name] = (m, contacts, pos, wq)
    return out


def runs(mask):
    """Half-open [start, stop) runs of True in a boolean (F,) array."""
    d = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


@pytest.mark.parametrize("name", list(P.CLIPS))
def test_shape_rate_and_length(clips, name):
    m = clips[name][0]
    assert m.frame_time == pytest.approx(1 / 60) and 300 <= m.num_frames <= 600
    assert m.num_joints == 31 and m.skeleton == P.cmu_skeleton()
    assert np.all(np.isfinite(m.local_quats)) and np.all(np.isfinite(m.root_positions))


@pytest.mark.parametrize("name", list(P.CLIPS))
def test_feet_are_planted_during_stance(clips, name):
    m, contacts, pos, wq = clips[name]
    sk = m.skeleton
    for foot, mask in contacts.items():
        assert 0.2 < mask.mean() < 0.8  # a real gait, not all-stance or all-swing
        for a, b in runs(mask):
            for joint in (foot, foot.replace("Foot", "ToeBase")):
                p = pos[a:b, sk.index(joint)]
                # speed over the stance: exact IK leaves rounding only (threshold 1e-6 cm/frame)
                assert np.abs(np.diff(p, axis=0)).max(initial=0.0) < 1e-6, (foot, joint, a, b)
            # the ankle sits at its height above the ground and the foot is flat (identity world rotation)
            assert np.allclose(pos[a:b, sk.index(foot), 1], P.ANKLE_HEIGHT, atol=1e-9)
            assert np.allclose(np.abs(wq[a:b, sk.index(foot), 3]), 1.0, atol=1e-12)
        # swing: the foot moves and rises above its stance height
        swing = ~mask
        assert pos[swing, sk.index(foot), 1].max() > P.ANKLE_HEIGHT + 5.0
    # nothing goes through the floor (toes 1.5 cm above the ankle's ground when flat)
    toes = pos[:, [sk.index("LeftToeBase"), sk.index("RightToeBase")], 1]
    assert toes.min() > 0.0


@pytest.mark.parametrize("name", list(P.CLIPS))
def test_knees_bend_forward_and_bones_keep_length(clips, name):
    m, _, pos, _ = clips[name]
    sk = m.skeleton
    for side in ("Left", "Right"):
        hip, knee, ankle = (pos[:, sk.index(side + j)] for j in ("UpLeg", "Leg", "Foot"))
        assert np.allclose(np.linalg.norm(knee - hip, axis=-1), P.THIGH, atol=1e-9)
        assert np.allclose(np.linalg.norm(ankle - knee, axis=-1), P.SHIN, atol=1e-9)
        # knee in front of the hip-ankle line (the character faces +Z): flexion is never backwards
        mid = hip + (ankle - hip) * (np.sum((knee - hip) * (ankle - hip), -1) /
                                     np.sum((ankle - hip) ** 2, -1))[:, None]
        assert np.all((knee - mid)[:, 2] > -1e-6)


def flight_runs(contacts):
    return runs(~(contacts["LeftFoot"] | contacts["RightFoot"]))


def test_run_has_ballistic_flight_phases(clips):
    m, contacts, pos, _ = clips["run"]
    flights = [(a, b) for a, b in flight_runs(contacts) if b - a >= 4]
    assert len(flights) >= 8  # two per cycle over 5 s of 0.72 s cycles
    for a, b in flights:
        t = m.times[a:b]
        coef = np.polyfit(t - t[0], m.root_positions[a:b, 1], 2)
        assert coef[0] == pytest.approx(-P.GRAVITY / 2, rel=1e-6)  # exact parabola up to fitting rounding
        assert np.allclose(np.diff(m.root_positions[a:b, 2]), 300 / 60, atol=1e-9)  # constant forward speed


def test_jump_flight_is_a_parabola_with_feet_off_the_ground(clips):
    m, contacts, pos, _ = clips["jump"]
    t0, t1 = P.JUMP_TIMES["takeoff"], P.JUMP_TIMES["landing"]
    inside = (m.times > t0 + 1e-9) & (m.times < t1 - 1e-9)
    assert not np.any(contacts["LeftFoot"][inside] | contacts["RightFoot"][inside])
    # both feet planted together just before take-off and just after landing
    for t in (t0 - 0.1, t1 + 0.1):
        f = int(round(t * 60))
        assert contacts["LeftFoot"][f] and contacts["RightFoot"][f]
    t = m.times[inside] - t0
    y = m.root_positions[inside, 1]
    tf = t1 - t0
    v0 = P.GRAVITY * tf / 2  # symmetric flight: lands at the take-off height
    y0 = y[0] - (v0 * t[0] - P.GRAVITY * t[0] ** 2 / 2)
    assert np.allclose(y, y0 + v0 * t - P.GRAVITY * t ** 2 / 2, atol=1e-9)  # exact parabola, rounding only
    z = m.root_positions[inside, 2]
    assert np.allclose(np.diff(z, 2), 0.0, atol=1e-9)  # straight line forward
    assert y.max() - y0 == pytest.approx(P.GRAVITY * tf ** 2 / 8, abs=0.2)  # frames straddle the apex: 0.2 cm
    # continuous at take-off and landing: the frames there sit on the same parabola within 0.1 cm
    for tt in (t0, t1):
        f = int(round(tt * 60))
        tau = m.times[f] - t0
        assert m.root_positions[f, 1] == pytest.approx(y0 + v0 * tau - P.GRAVITY * tau ** 2 / 2, abs=0.1)
    # the root travels forward overall and crouches before take-off
    assert m.root_positions[-1, 2] - m.root_positions[0, 2] > 300
    crouch = m.root_positions[int(P.JUMP_TIMES["crouch"] * 60), 1]
    assert crouch < m.root_positions[0, 1] - 15


def test_deterministic_and_seeded():
    a = P.walk()
    b = P.walk()
    assert np.array_equal(a.local_quats, b.local_quats) and np.array_equal(a.root_positions, b.root_positions)
    c = P.walk(seed=5)
    sk = a.skeleton
    legs = [sk.index(n) for n in ("LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot")]
    assert np.array_equal(a.local_quats[:, legs], c.local_quats[:, legs])  # the noise is upper-body only
    assert not np.allclose(a.local_quats[:, sk.index("Spine")], c.local_quats[:, sk.index("Spine")])
    assert np.array_equal(P.generate("jump").local_quats, P.jump().local_quats)


def test_parameters_are_validated():
    with pytest.raises(ValueError, match="speed"):
        P.walk(speed=0)
    with pytest.raises(ValueError, match="duration"):
        P.run(duration=-1)
    with pytest.raises(ValueError, match="duration"):
        P.jump(duration=2.0)
    with pytest.raises(ValueError, match="name"):
        P.generate("swim")


def test_walk_parameters_change_the_gait():
    fast = P.walk(duration=3.0, speed=140.0)
    assert fast.num_frames == 181
    assert fast.root_positions[-1, 2] == pytest.approx(140.0 * 3.0)


def test_layout_matches_the_cmu_bvh_files():
    ref = read_bvh(shared_clip_path("xia_neutral_walk.bvh"))  # the CMU MotionBuilder-friendly layout
    sk = P.cmu_skeleton()
    assert sk.names == ref.skeleton.names
    assert np.array_equal(sk.parents, ref.skeleton.parents)
    assert sorted(sk.end_sites) == sorted(ref.skeleton.end_sites)


def test_bvh_round_trip(tmp_path, clips):
    m, _, pos, _ = clips["jump"]
    write_bvh(m, tmp_path / "jump.bvh")
    back = read_bvh(tmp_path / "jump.bvh")
    p2, _ = forward_kinematics(back)
    assert back.skeleton.names == m.skeleton.names and back.num_frames == m.num_frames
    assert np.abs(p2 - pos).max() < 1e-4  # 9 significant digits of degrees and cm in the file
