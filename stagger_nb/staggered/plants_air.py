"""The legs in the air (:mod:`.plants_hold`): feet kept where the edit puts them while the root is lowered, above
the source's floor (the toe turned up where a foot joint would go below it), and effectors with no joint below them
kept as edited."""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from ..core.rotations import (
    quat_between_vectors,
    quat_conj,
    quat_mul,
    quat_rotate,
)
from .limbs import Limb, _fk_joints
from .plants_ik import _solve_rows
from .plants_root import _TOL, _envelope
from .plants_sample import _scaled_along

_ID = np.array([0.0, 0.0, 0.0, 1.0])


def _toe_up(p: np.ndarray, lim: Limb, floor: np.ndarray, free: np.ndarray):
    """``(turn (F, 4), where (F,) bool)``: per frame the least rotation of the foot about its ankle (``p (F, J,
    3)``: positions of the pose, the ankle ``lim.eff``) that brings its lowest joint below the ankle up to
    ``floor (F,)`` (heights relative to that pose, the ankle kept where it is), on ``free`` frames where that
    joint is below it; the identity elsewhere."""
    F = p.shape[0]
    feet = np.array(lim.foot)
    k = feet[np.argmin(p[:, feet, 1], axis=1)]
    v = p[np.arange(F), k] - p[:, lim.eff]                    # (F, 3) ankle to the lowest foot joint
    n = np.linalg.norm(v, axis=-1)
    want = floor - p[:, lim.eff, 1]                          # the height that joint must have over the ankle
    side = np.hypot(v[:, 0], v[:, 2])
    where = free & (want > v[:, 1] + _TOL * np.maximum(n, 1e-300)) & (want < n) & (side > 1e-9 * n)
    turn = np.broadcast_to(_ID, (F, 4)).copy()
    if where.any():
        w = v[where]
        y = want[where]
        h = np.sqrt(np.maximum(n[where] ** 2 - y ** 2, 0.0)) / side[where]
        target = np.stack([w[:, 0] * h, y, w[:, 2] * h], axis=-1)
        turn[where] = quat_between_vectors(w, target)
    return turn, where


def _legs_in_air(sk, motion: Motion, legs: list, rows: list, fade_w: dict, shift: np.ndarray, out: np.ndarray,
                 floor: float, nb: int, med: dict, length: dict, hinges: dict, above_floor: bool,
                 backs: dict) -> None:
    """The legs on the frames no plant holds them (in place on ``out (F, J, 4)``), see the comment below; ``rows``:
    the plants' frames per limb, ``fade_w``: the fades around them, ``shift (F, 3)``: the root's shift."""
    F = motion.num_frames
    # legs in the air: where the root is lowered they keep their feet where the edit (in a fade: the faded pose
    # on the lowered root, plus the part of the drop the fade has let go of) puts them; and no foot joint goes
    # below the source's floor (the lowest any source joint goes), lifted by a smooth profile, let go of
    # towards the plants (whose own frames sit on the ground)
    if legs:
        held = {r["lim"].eff: r["fr"] for r in rows}
        leg_joints = {x for lim in legs for x in (lim.upper, lim.mid, lim.eff, int(sk.parents[lim.mid]),
                                                   int(sk.parents[lim.eff])) + lim.foot}
        p_u, w_u = _fk_joints(motion, leg_joints, local_quats=out)       # the root not lowered
        for lim in legs:
            free = np.ones(F, bool)
            if lim.eff in held:
                free[held[lim.eff]] = False
            wf = np.zeros(F)
            infade = np.zeros(F, bool)
            reach_of = length[lim.eff] * (1 - 1e-9)        # (F,): full extension, a fade's reach inside it
            if lim.eff in fade_w:
                wf[fade_w[lim.eff][0]] = fade_w[lim.eff][1]
            down = wf[:, None] * shift                        # how far the foot goes with the root
            if lim.eff in fade_w and len(fade_w[lim.eff]) > 2:
                # the fade's world-space foot: the pose's foot moved there (down: the offset that puts it there)
                win, _w, g_f, q_f, r_f = fade_w[lim.eff]
                reach_of[win] = r_f
                infade[win] = True
                # the foot's orientation: from the joint-space fade's (continuous; near the edit's far from the
                # plant) the share w of the way to the plant's, so it meets the plant's at its boundary
                rel = quat_mul(quat_conj(w_u[win, lim.eff]), q_f)[:, None]
                q_f = quat_mul(w_u[win, lim.eff], _scaled_along(rel, _w, win)[:, 0])
                turn_f = quat_mul(q_f, quat_conj(w_u[win, lim.eff]))
                down[win] = g_f - p_u[win, lim.eff]
                for k in lim.foot:                            # the foot joints as the fade's orientation puts them
                    p_u[win, k] = p_u[win, lim.eff] + quat_rotate(turn_f, p_u[win, k] - p_u[win, lim.eff])
                w_u[win, lim.eff] = q_f
            low = np.min(p_u[:, [lim.eff] + list(lim.foot), 1], axis=1) + down[:, 1]
            deficit = np.where(free, np.maximum(floor - low, 0.0), 0.0)
            lift = np.zeros(F)
            pitch = None
            if above_floor and np.any(deficit > _TOL * med[lim.eff]):
                # smooth away from the plants (let go of towards them: their own frames sit on the ground); what
                # is still below the floor (in a fade into a plant): the ankle lifted exactly to the floor if it
                # is below it, and a foot joint below it by turning the foot about the ankle (toe up) by the
                # least angle that puts that joint on the floor (lifting the ankle instead would bend the knee
                # against the plant's straight leg: a pop at the plant's first frame)
                lift = _envelope(deficit, nb) * (1.0 - wf)
                lift[~free] = 0.0
                ankle = p_u[:, lim.eff, 1] + down[:, 1] + lift
                lift += np.where(free, np.maximum(floor - ankle, 0.0), 0.0)
                if lim.foot:
                    pitch = _toe_up(p_u, lim, floor - down[:, 1] - lift, free)
            tiny = _TOL * length[lim.eff]                    # (F,): below this, neither moves the foot
            moved = np.linalg.norm(shift, axis=-1)
            turn = np.zeros(F, bool) if pitch is None else pitch[1]
            fr = np.flatnonzero(free & ((moved > tiny) | (lift > tiny) | turn | infade))
            if not fr.size:
                continue
            p3 = p_u[fr][:, [lim.upper, lim.mid, lim.eff]]
            p3 += shift[fr, None, :]
            tgt = p_u[fr, lim.eff] + down[fr]
            tgt[:, 1] += lift[fr]
            q_foot = w_u[fr, lim.eff] if pitch is None else quat_mul(pitch[0][fr], w_u[fr, lim.eff])
            a_new, m_new, e_new = _solve_rows(sk, lim, fr, p3, w_u, out, tgt, q_foot,
                                              reach_of[fr], hinges[lim.eff], max_back=backs[lim.eff])
            out[fr, lim.upper], out[fr, lim.mid], out[fr, lim.eff] = a_new, m_new, e_new


def _leaf_effectors_as_edited(limbs: dict, out: np.ndarray, lq: np.ndarray) -> None:
    """An effector with no joint below it (a 19-joint rig's ankle or wrist) places nothing by its rotation: it
    keeps the edit's local rotation (in place on ``out``; the plant is a position, Kovar et al. 2002, §4). Held
    to the source's world orientation instead, it turned up to 122 degrees against the edited shin on
    mocapbank_get_down at s = +0.1 (a kneel on the shin's other timing), and that and its fades were most of
    the 4.7x detail the layer added there."""
    for lim in limbs.values():
        if not lim.foot:
            out[:, lim.eff] = lq[:, lim.eff]
