"""The contact layer's pop cap (:mod:`stagger_nb.staggered.plants`): no corrected joint turns from one frame to
the next faster than the source ever turns it plus a margin (or than the edit itself turns it there).

A held joint may turn by ``max(S + margin, e(n) + _MIN_STEP)`` from frame ``n`` to ``n + 1`` (``S``: its
largest frame-to-frame turn in the source, per edited frame; ``e(n)``: the edit's own turn there). Where it
turns faster (a fade or a plant boundary), the step of its IK displacement ``D(n) = q_edit(n)^-1 q_held(n)`` is
cut by the excess and the displacement ramped instead: the mean of a forward and a backward rate limiter on its
rotation vector (the exponential map is 1-Lipschitz, so a ramp of the rotation vector is one of the rotation).
The plants' own frames (``pinned``) are kept: each limiter restarts from them, and each is used on the side of a
plant where it starts from it (the forward one after a plant, the backward one before, blended linearly between
two plants), so a ramp lies outside the plant (Kovar et al. 2002, §4: the plant met exactly, the adjustment
blended in and out around it); only a step inside a plant too fast by more than ``INNER_MARGIN`` is ramped there.
Where the displacement already changes slowly enough both limiters are the displacement itself: an unedited
motion, and the plants' own frames away from a too-fast step, are left exactly as they are."""
from __future__ import annotations

import numpy as np

from ..core.rotations import quat_angle, quat_conj, quat_mul, rotvec_to_quat

POP_MARGIN = 2.5     # degrees a frame a held joint may turn beyond the source's fastest turn of it
_PASSES = 4
INNER_MARGIN = 2.5   # degrees a frame beyond the allowance a step inside a plant may take before it is ramped too
_MIN_STEP = 1.0      # degrees a frame the displacement may always change


def _limit(v: np.ndarray, c: np.ndarray, fast: np.ndarray, reverse: bool, pinned=None) -> np.ndarray:
    """Rate limiter along axis 0 of ``v (F, C, 3)``: step ``n - 1 -> n`` moved by at most ``c[n - 1] (C,)``.
    ``fast (F - 1,)``: the steps ``v`` itself takes too fast; the limiter only works from one of them until it
    has caught up with ``v`` again, and jumps to the next one (elsewhere the result is ``v``). ``pinned (F, C)``
    bool: frames kept at ``v`` (the limiter goes on from there)."""
    out = v.copy()
    F = v.shape[0]
    bad = np.flatnonzero(fast)
    if pinned is None:
        pinned = np.zeros(v.shape[:2], bool)
    if reverse:
        out, v, c, bad, pinned = out[::-1], v[::-1], c[::-1], (F - 2 - bad)[::-1], pinned[::-1]
    k, n = 0, None
    while k < bad.size:
        n = int(bad[k]) + 1 if n is None or n <= bad[k] else n
        while n < F:
            d = v[n] - out[n - 1]
            size = np.sqrt(np.einsum("ci,ci->c", d, d))
            lim = c[n - 1]
            over = size > lim
            if not over.any():
                out[n] = v[n]
                if n - 1 > bad[k] and np.array_equal(out[n - 1], v[n - 1]):
                    break
            else:
                out[n] = out[n - 1] + d * np.where(over, lim / np.maximum(size, 1e-300), 1.0)[:, None]
                out[n] = np.where(pinned[n][:, None], v[n], out[n])
            n += 1
        while k < bad.size and bad[k] < n:
            k += 1
    return out[::-1].copy() if reverse else out


def _continuous_log(D: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(F, C, 3)`` of ``D (F, C, 4)`` that change continuously along axis 0: the quaternions
    made sign-continuous first (so a displacement through half a turn goes on beyond pi instead of jumping to
    the other side; a mean of two such vectors then stays near both)."""
    D = np.array(D)
    D[0] = np.where(D[0, :, 3:] < 0, -D[0], D[0])
    if D.shape[0] > 1:
        flip = np.einsum("fci,fci->fc", D[1:], D[:-1]) < 0
        sign = np.where(np.cumsum(flip, axis=0) % 2 == 1, -1.0, 1.0)
        D[1:] *= sign[..., None]
    xyz = D[..., :3]
    s = np.linalg.norm(xyz, axis=-1)
    angle = 2.0 * np.arctan2(s, D[..., 3])
    return xyz * np.where(s > 1e-12, angle / np.maximum(s, 1e-300), 2.0)[..., None]


def source_steps(source_quats: np.ndarray, scale: float) -> np.ndarray:
    """Each joint's largest frame-to-frame turn ``(J,)`` (radians) in the source's local rotations
    ``(F_s, J, 4)``, times ``scale`` (edited frame time over the source's)."""
    if source_quats.shape[0] < 2:
        return np.zeros(source_quats.shape[1])
    return quat_angle(source_quats[:-1], source_quats[1:]).max(axis=0) * scale


def _sides(pinned: np.ndarray) -> np.ndarray:
    """``(F, C)`` share of the forward limiter per frame: 1 just after a run of ``pinned (F, C)`` frames, 0 just
    before one, linear between (0 before the first, 1 after the last, 0.5 in a column with none): each limiter
    is used on the side where it starts from the pinned frames, so their ramps end there."""
    F = pinned.shape[0]
    idx = np.arange(F)[:, None]
    last = np.maximum.accumulate(np.where(pinned, idx, -1), axis=0)
    nxt = np.minimum.accumulate(np.where(pinned, idx, F)[::-1], axis=0)[::-1]
    dp = np.where(last >= 0, idx - last, np.inf)
    dn = np.where(nxt < F, nxt - idx, np.inf)
    both = np.isfinite(dp) & np.isfinite(dn) & (dp + dn > 0)
    mid = np.where(both, dn, 0.5) / np.where(both, dp + dn, 1.0)
    return np.where(np.isinf(dp), np.where(np.isinf(dn), 0.5, 0.0), np.where(np.isinf(dn), 1.0, mid))


def _unpin_inner(pinned: np.ndarray, excess: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """``pinned (F, C)`` less the frames around a step between two pinned frames (inside a plant) that is too
    fast by more than ``INNER_MARGIN`` (a plant's own exact frames keep the smaller excess):
    ``k`` frames each side, ``k`` the number of allowed steps the excess needs (``excess``, ``allowed`` ``(F - 1,
    C)``), so the ramp can spread it there."""
    inner = (excess > np.radians(INNER_MARGIN)) & pinned[:-1] & pinned[1:]
    if not inner.any():
        return pinned
    out = pinned.copy()
    F = pinned.shape[0]
    for n, c in zip(*np.nonzero(inner)):
        k = int(np.ceil(excess[n, c] / max(allowed[n, c], 1e-9)))
        out[max(n - k, 0):min(n + 2 + k, F), c] = False
    return out


def cap_pops(held: np.ndarray, edit: np.ndarray, joints, source_step: np.ndarray, pinned=None) -> np.ndarray:
    """``held (F, J, 4)`` local rotations with the displacement from ``edit (F, J, 4)`` of ``joints`` rate
    limited as the module says (in place; returned). ``source_step (J,)``: :func:`source_steps`. ``pinned
    (F, J)`` bool, optional: frames kept exactly (the plants' own frames): the ramps are made on their outside
    (inside only where a step is too fast by more than ``INNER_MARGIN``). A pass cuts each too-fast step of the
    rotation vector by the excess; where the rotation vector changes more than the rotation (far from the
    identity) one pass is not enough, so up to ``_PASSES`` are made."""
    ch = np.array(sorted(set(int(j) for j in joints)), dtype=np.int64)
    if ch.size == 0 or held.shape[0] < 2:
        return held
    # the edit's own turn (and so each step's allowance) is the same on every pass; a pass changes only the
    # columns it ramps, so only theirs are measured again
    e = quat_angle(edit[:-1, ch], edit[1:, ch])                                   # (F - 1, C)
    allowed = np.maximum(source_step[ch][None, :] + np.radians(POP_MARGIN), e + np.radians(_MIN_STEP))
    excess = quat_angle(held[:-1, ch], held[1:, ch]) - allowed
    if pinned is not None:
        pinned = _unpin_inner(pinned[:, ch], excess, allowed)
    for k in range(_PASSES):
        cols = _cap_pass(held, edit, ch, excess, pinned)
        if cols is None or k == _PASSES - 1:
            break
        sel = ch[cols]
        excess[:, cols] = quat_angle(held[:-1, sel], held[1:, sel]) - allowed[:, cols]
    return held


def _cap_pass(held, edit, ch, excess, pinned=None):
    """One pass of :func:`cap_pops` (in place) given each step's ``excess (F - 1, C)`` over its allowance;
    returns the columns of ``ch`` it ramped, None when nothing was too fast."""
    fast = excess > 1e-6
    if not fast.any():
        return None
    cols = np.flatnonzero(fast.any(axis=0))
    sel = ch[cols]
    vv = _continuous_log(quat_mul(quat_conj(edit[:, sel]), held[:, sel]))      # only the too-fast columns
    jump = np.linalg.norm(np.diff(vv, axis=0), axis=-1)
    # the displacement's step is cut by the excess where the held joint turns too fast, and may grow by the room
    # left elsewhere (so a ramp catches up no faster than the joint may turn)
    cc = np.maximum(jump - excess[:, cols], np.radians(_MIN_STEP))
    f = fast[:, cols].any(axis=1)
    if pinned is None or not pinned[:, cols].any():
        fwd = _limit(vv, cc, f, False)
        bwd = _limit(vv, cc, f, True)
        held[:, sel] = quat_mul(edit[:, sel], rotvec_to_quat(0.5 * (fwd + bwd)))
        return cols
    pin = pinned[:, cols]
    fwd = _limit(vv, cc, f, False, pin)
    bwd = _limit(vv, cc, f, True, pin)
    a = _sides(pin)[..., None]
    ramped = quat_mul(edit[:, sel], rotvec_to_quat(a * fwd + (1 - a) * bwd))
    held[:, sel] = np.where(pin[..., None], held[:, sel], ramped)          # pinned frames bit for bit
    return cols
