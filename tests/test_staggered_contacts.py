"""Contact detection (Coleman et al. 2008, Appendix B) and pose times on real walking."""
from __future__ import annotations

import re

import numpy as np
import pytest

from stagger_nb import staggered
from stagger_nb.core.motion import Motion
from stagger_nb.core.rotations import quat_identity
from stagger_nb.core.skeleton import Skeleton
from stagger_nb.staggered.contacts import contact_events, end_effectors


def foot_motion(path, fps=100.0):
    """Root -> LeftFoot (offset 1 down) and a Hand; the root follows ``path (F, 3)``, no rotation."""
    sk = Skeleton(["Hips", "LeftFoot", "RightHand"], [-1, 0, 0],
                  [[0, 0, 0], [0, -1.0, 0], [0.5, 0, 0]])
    F = path.shape[0]
    return Motion(sk, 1.0 / fps, path, quat_identity((F, 3)))


def brute_contacts(p, tol, L):
    """Appendix B in the most straightforward manner: scan forward, test every window, grow it."""
    out, s, F = [], 0, len(p)
    ext = lambda a, b: np.linalg.norm(p[a:b].max(0) - p[a:b].min(0))  # noqa: E731
    while s + L <= F:
        if ext(s, s + L) <= tol:
            e = s + L
            while e < F and ext(s, e + 1) <= tol:
                e += 1
            out.append((s, e))
            s = e
        else:
            s += 1
    return out


def test_still_then_moving_foot_gives_one_half_open_contact():
    F = 200
    path = np.zeros((F, 3))
    path[80:, 0] = np.arange(F - 80) * 0.05            # still for frames [0, 80), then walks off
    m = foot_motion(path)
    got = staggered.detect_contacts(m, tolerance=0.01, joints=["LeftFoot"])
    assert got == [("LeftFoot", 0, 81)]                 # frame 80 is still at x = 0: the box grows to it


def test_short_stillness_is_not_a_contact():
    F = 100
    path = np.zeros((F, 3))
    path[:, 0] = np.arange(F) * 0.05
    path[40:60, 0] = path[40, 0]                          # 20 frames = 0.2 s still < 0.25 s
    got = staggered.detect_contacts(foot_motion(path), tolerance=0.01, joints=["LeftFoot"])
    assert got == []
    got = staggered.detect_contacts(foot_motion(path), tolerance=0.01, joints=["LeftFoot"], min_duration=0.15)
    assert got == [("LeftFoot", 40, 60)]


def test_detect_contacts_matches_brute_force_on_noisy_steps(rng):
    F = 400
    steps = np.repeat(np.arange(8), 50)[:, None] * np.array([0.3, 0.0, 0.0])
    path = steps + rng.normal(scale=0.004, size=(F, 3))
    m = foot_motion(path)
    got = staggered.detect_contacts(m, tolerance=0.03, joints=["LeftFoot"])
    L = int(np.ceil(0.25 * 100)) + 1
    want = [("LeftFoot", a, b) for a, b in brute_contacts(path + [0, -1.0, 0], 0.03, L)]
    assert got == want and len(got) >= 6


def test_still_hands_count_only_near_the_feet():
    F = 100
    path = np.zeros((F, 3))                                   # everything still for 1 s
    m = foot_motion(path)                                     # hand 1.0 above the foot (height 1.0)
    assert staggered.detect_contacts(m, tolerance=0.01) == [("LeftFoot", 0, F)]
    # the paper's plain stillness test also takes the hand
    assert staggered.detect_contacts(m, tolerance=0.01, hand_support=None) == [("LeftFoot", 0, F),
                                                                               ("RightHand", 0, F)]
    # a hand on the floor next to the foot (0.05 above it, within 0.1 x height) supports the body
    sk = Skeleton(["Hips", "LeftFoot", "RightHand"], [-1, 0, 0], [[0, 0, 0], [0, -1.0, 0], [0.5, -0.95, 0]])
    low = Motion(sk, 0.01, path, quat_identity((F, 3)))
    assert staggered.detect_contacts(low, tolerance=0.01) == [("LeftFoot", 0, F), ("RightHand", 0, F)]
    with pytest.raises(ValueError, match="hand_support"):
        staggered.detect_contacts(m, hand_support=-0.1)


def test_walks_have_no_hand_contacts(shared_motion):
    # CMU 131_01 starts and ends standing: the hanging wrists are still for over a second there
    m = shared_motion("cmu_131_01_walk_startstop.bvh")
    hands = re.compile("hand|wrist", re.I)
    plain = staggered.detect_contacts(m, hand_support=None)
    assert any(hands.search(n) for n, _, _ in plain)
    got = staggered.detect_contacts(m)
    assert not any(hands.search(n) for n, _, _ in got)
    assert [c for c in plain if not hands.search(c[0])] == got   # feet are untouched


def test_end_effectors_from_names_and_leaves(shared_motion):
    m = shared_motion("xia_neutral_walk.bvh")
    names = {m.skeleton.names[j] for j in end_effectors(m.skeleton)}
    assert names == {"LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase", "LeftHand", "RightHand"}
    m = shared_motion("cmu_131_01_walk_startstop.bvh")          # other naming: ankles, toes, wrists
    names = {m.skeleton.names[j] for j in end_effectors(m.skeleton)}
    assert {"LeftAnkle", "RightAnkle", "LeftToe", "RightToe", "LeftWrist", "RightWrist"} <= names
    assert not any("Thumb" in n or "Finger" in n for n in names)
    sk = Skeleton(["a", "b", "c", "d"], [-1, 0, 1, 1], np.ones((4, 3)))
    assert end_effectors(sk) == [2, 3]                   # no foot/hand names: the leaves


def test_contact_events_and_validation():
    ev = contact_events([("x", 3, 7), ("y", 0, 12)], 10)
    assert np.flatnonzero(ev).tolist() == [0, 3, 7, 9]
    m = foot_motion(np.zeros((50, 3)))
    with pytest.raises(ValueError, match="tolerance"):
        staggered.detect_contacts(m, tolerance=-1.0)
    with pytest.raises(ValueError, match="min_duration"):
        staggered.detect_contacts(m, min_duration=0.0)


def _foot_events(contacts, F):
    """Contact and release frames of feet/toes/ankles (release = the half-open stop frame)."""
    feet = [(a, b) for n, a, b in contacts if re.search("foot|toe|ankle|heel", n, re.I)]
    return np.array(sorted({a for a, _ in feet} | {b for _, b in feet if b < F}))


@pytest.mark.parametrize("name", ["cmu_131_01_walk_startstop.bvh", "xia_neutral_walk.bvh"])
def test_walking_pose_times_fall_near_foot_events(shared_motion, name):
    m = shared_motion(name)
    sm = staggered.extract(m)
    F = m.num_frames
    ev = _foot_events(sm.contacts, F)
    assert ev.size >= 3
    frames = np.rint(sm.pose_times / m.frame_time).astype(int)[1:-1]   # forced ends excluded
    d = np.abs(frames[:, None] - ev[None]).min(axis=1)
    # a loose bound (0.2 s): the note reports the measured median; a pose at random times would sit
    # ~a quarter of the inter-event gap away
    assert np.median(d) * m.frame_time <= 0.2
    assert np.abs(sm.refinements).max() <= 0.25 + 1e-12


@pytest.mark.parametrize("name", ["xia_neutral_walk.bvh", "bandai_walk.bvh", "cmu_131_01_walk_startstop.bvh",
                                  "pymo_walk_turnaround.bvh"])
def test_contacts_from_effector_chains_equal_full_fk_on_real_clips(shared_motion, name):
    """detect_contacts' default FK covers only the effectors' and feet's chains; the contacts (and, hands'
    support test included, every position it reads) equal those from full forward kinematics."""
    from stagger_nb.core.kinematics import forward_kinematics
    m = shared_motion(name)
    full = staggered.detect_contacts(m, positions=forward_kinematics(m)[0])
    assert full, f"{name}: a walk or run has foot contacts, or the comparison proves nothing"
    assert staggered.detect_contacts(m) == full
    # the plain Appendix B test (hands included without the support test) agrees too
    assert (staggered.detect_contacts(m, hand_support=None)
            == staggered.detect_contacts(m, positions=forward_kinematics(m)[0], hand_support=None))
