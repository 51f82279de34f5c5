"""The contact layer's speed work keeps its output bit for bit (issue 20's slider bar): the pop cap that measures
only what a pass changed against the straightforward pass that measures everything, the per-source tables
(cached across a slider's replays) against a cold cache, and the batched time warps against one call per
contact."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, staggered
from stagger_nb.core.body import pelvis_joint
from stagger_nb.core.rotations import quat_angle, quat_conj, quat_mul, rotvec_to_quat
from stagger_nb.staggered import plants
from stagger_nb.staggered.plants_pops import (
    _MIN_STEP,
    _PASSES,
    POP_MARGIN,
    _continuous_log,
    _limit,
    cap_pops,
    source_steps,
)


def _cap_straightforward(held, edit, joints, source_step):
    """The pop cap as the module describes it, every quantity measured again on every pass over every column;
    returns the number of passes that changed something."""
    ch = np.array(sorted(set(int(j) for j in joints)), dtype=np.int64)
    passes = 0
    for _ in range(_PASSES):
        e = quat_angle(edit[:-1, ch], edit[1:, ch])
        allowed = np.maximum(source_step[ch][None, :] + np.radians(POP_MARGIN), e + np.radians(_MIN_STEP))
        excess = quat_angle(held[:-1, ch], held[1:, ch]) - allowed
        fast = excess > 1e-6
        if not fast.any():
            break
        passes += 1
        v = _continuous_log(quat_mul(quat_conj(edit[:, ch]), held[:, ch]))
        c = np.maximum(np.linalg.norm(np.diff(v, axis=0), axis=-1) - excess, np.radians(_MIN_STEP))
        cols = np.flatnonzero(fast.any(axis=0))
        f = fast[:, cols].any(axis=1)
        fwd = _limit(v[:, cols], c[:, cols], f, False)
        bwd = _limit(v[:, cols], c[:, cols], f, True)
        held[:, ch[cols]] = quat_mul(edit[:, ch[cols]], rotvec_to_quat(0.5 * (fwd + bwd)))
    return passes


def _edit(F, J, seed):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, F)[:, None, None]
    axes = rng.normal(size=(1, J, 3))
    return rotvec_to_quat(0.4 * np.sin(t + np.arange(J)[None, :, None]) * axes
                          / np.linalg.norm(axes, axis=-1, keepdims=True))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pop_cap_equals_the_straightforward_passes(seed):
    """Jumps of 100-250 degrees on some columns only (far from the identity: more than one pass), others slow."""
    F, J = 240, 6
    rng = np.random.default_rng(seed)
    edit = _edit(F, J, seed)
    ang = np.zeros((F, J))
    for j in rng.choice(J, size=3, replace=False):
        at = rng.integers(20, F - 20, size=2)
        ang[at[0]:, j] += np.radians(rng.uniform(100, 250))
        ang[at[1]:, j] -= np.radians(rng.uniform(30, 90))
    axis = rng.normal(size=(1, J, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    held = quat_mul(edit, rotvec_to_quat(ang[..., None] * axis))
    joints = [0, 2, 3, 4, 5]
    src = source_steps(edit, 1.0)
    want = held.copy()
    passes = _cap_straightforward(want, edit, joints, src)
    got = cap_pops(held.copy(), edit, joints, src)
    assert passes >= 1
    assert np.array_equal(got, want)
    assert not np.array_equal(got, held)             # the cap did something


@pytest.fixture(scope="module")
def hops():
    m = data.load("cmu_01_01").slice(0, 360)
    sm = staggered.extract(m)
    root = m.skeleton.names[pelvis_joint(m.skeleton)]
    edits = [staggered.random_timing(staggered.succession(sm, root=root, s=0.03, l=ll), tau=0.06, seed=0)
             for ll in (1.2, 1.5)]
    return m, edits


def test_cached_source_tables_change_nothing(hops):
    """A slider's second replay (the source's tables cached) equals a replay with the cache emptied, bit for bit,
    for two different edits of one source in either order."""
    m, edits = hops
    plants._SOURCE_CACHE.clear()
    cold = [staggered.hold_plants(e, m) for e in edits]
    for e, c in zip(edits[::-1], cold[::-1]):          # warm, other order
        w = staggered.hold_plants(e, m)
        assert np.array_equal(w.motion.local_quats, c.motion.local_quats)
        assert np.array_equal(w.motion.root_positions, c.motion.root_positions)
        assert np.array_equal(w.drop, c.drop) and w.notes == c.notes and w.plants == c.plants
    assert cold[0].plants > 0 and not np.array_equal(cold[0].motion.local_quats, cold[1].motion.local_quats)


@pytest.mark.parametrize("carry_by", ["pelvis", "parent", "joint", "span", "limb"])
def test_carried_contacts_equal_one_warp_per_contact(hops, carry_by):
    """carry_contacts (one warp call per clock over all contacts) against warp_times of each contact's ends
    through each of its clocks, one at a time, and the frames rounded as its docstring says."""
    m, edits = hops
    e = edits[1]
    sk = m.skeleton
    contacts = list(e.contacts) or staggered.detect_contacts(m)
    got = staggered.carry_contacts(e, contacts, m.frame_time, carry_by=carry_by)
    t0, ft = float(e.pose_times[0]), e.frame_time
    want = []
    for name, a, b in contacts:
        j = sk.index(name)
        lim = plants.find_limb(sk, j)
        # CMU: every contact is a foot's (a limb below Hips); the joint above each moves it (no helper bones)
        clocks = {"joint": [j], "limb": [lim.upper if lim else j], "span": [j, lim.mid if lim else j],
                  "pelvis": [sk.index("Hips")], "parent": [int(sk.parents[j])]}[carry_by]
        w = np.array([staggered.warp_times(e, np.array([a, b - 1]) * m.frame_time, c) for c in clocks])
        e0, e1 = (np.array([w[:, 0].min(), w[:, 1].max()]) - t0) / ft
        start = max(int(np.ceil(e0 - 1e-6)), 0)
        stop = min(int(np.floor(e1 + 1e-6)) + 1, staggered.evaluate(e).num_frames)
        if stop > start:
            want.append((name, start, stop))
    assert len(want) > 4 and got == want
