"""Constraint layer: a final IK displacement that keeps contacts planted (staggered poses, §3).

"As interpolation does not exactly meet environmental contact constraints, a final displacement map
represents an inverse kinematic solution that modifies the value to meet any such constraints" (§1, §3).
The displacement is non-zero only while a constraint is active, plus a smoothly attenuated copy of the
boundary solution in a short window adjacent in time, so IK is used locally and never spreads
over-correlated motion through the clip (§3, §6).

Contacts are ``(joint_name, start_frame, stop_frame)`` triples with half-open frame ranges
``[start, stop)`` (the format of :func:`stagger_nb.staggered.detect_contacts`). A contact on a toe joint
(name containing ``"toe"``) is enforced through its parent (the ankle): the ankle target is chosen so the
toe lands on its contact position with the foot's world orientation unchanged.

The solver is the vectorised analytic two-bone IK of :mod:`.ik` (upper joint, middle joint, effector:
hip-knee-ankle or shoulder-elbow-wrist, found by :mod:`.limbs`). The effector's world orientation is kept, so
the foot does not tilt.
Up axis: +Y (BVH convention); lengths are in the motion's file units.
"""
from __future__ import annotations

import numpy as np

from ..core.kinematics import forward_kinematics
from ..core.motion import Motion
from ..core.rotations import quat_between_vectors, quat_conj, quat_mul, slerp
from .ik import two_bone_ik
from .limbs import _chain, _chain_length, _fk_joints

__all__ = ["apply_contact_constraints", "contact_positions", "contact_errors", "foot_skate",
           "attenuation_weights", "carry_contacts", "keep_contacts"]


def _parse_contacts(motion: Motion, contacts) -> list[tuple[int, int, int]]:
    out = []
    F = motion.num_frames
    for item in contacts:
        try:
            name, start, stop = item
        except (TypeError, ValueError):
            raise ValueError(f"contacts: each entry must be (joint_name, start_frame, stop_frame), got {item!r}") from None
        try:
            j = motion.skeleton.index(name) if isinstance(name, str) else int(name)
        except KeyError as e:
            raise ValueError(f"contacts: {e.args[0]}") from None
        start, stop = int(start), int(stop)
        if not 0 <= start < stop <= F:
            raise ValueError(f"contacts: frame range [{start}, {stop}) of {name!r} is empty or outside [0, {F})")
        out.append((j, start, stop))
    return out


def contact_positions(reference: Motion, contacts, mode: str = "mean", positions=None) -> list[np.ndarray]:
    """Where each contact should stay: world positions of the contact joint in ``reference``.

    Returns one array per contact, shape ``(stop - start, 3)``: the mean position over the active frames
    repeated (``mode="mean"``, a planted point) or the per-frame positions (``mode="track"``).
    """
    if mode not in ("mean", "track"):
        raise ValueError(f"mode must be 'mean' or 'track', got {mode!r}")
    parsed = _parse_contacts(reference, contacts)
    p = forward_kinematics(reference)[0] if positions is None else positions
    out = []
    for j, s, e in parsed:
        seg = p[s:e, j]
        out.append(np.broadcast_to(seg.mean(axis=0), seg.shape).copy() if mode == "mean" else seg.copy())
    return out


def attenuation_weights(active: np.ndarray, blend_frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smooth window around active frames.

    Parameters
    ----------
    active : ndarray, shape (F,), bool
    blend_frames : int
        Width of the attenuation window on each side, frames.

    Returns
    -------
    weight : (F,) in [0, 1]; 1 on active frames, ``(1 + cos(pi d / (n + 1))) / 2`` at ``d`` frames from
        the nearest active frame (``n = blend_frames``), 0 beyond.
    left, right : (F,) int
        Index of the nearest active frame at or before / at or after each frame (-1 where none).
    """
    F = active.shape[0]
    idx = np.arange(F)
    left = np.maximum.accumulate(np.where(active, idx, -1))
    right = np.minimum.accumulate(np.where(active, idx, F)[::-1])[::-1]
    right = np.where(right >= F, -1, right)

    def w(d):
        d = d.astype(float)
        return np.where(d <= blend_frames, 0.5 * (1.0 + np.cos(np.pi * d / (blend_frames + 1))), 0.0)

    wl = np.where(left >= 0, w(idx - left), 0.0)
    wr = np.where(right >= 0, w(right - idx), 0.0)
    weight = np.clip(wl + wr - wl * wr, 0.0, 1.0)
    weight[active] = 1.0
    return weight, left, right


def _window_targets(tgt, traj, act, weight, left, right) -> None:
    """Fill ``tgt (F, 3)`` on the window frames (weight > 0, not active) in place: the trajectory ``traj
    (F, 3)`` plus the offset ``tgt - traj`` of the nearest active frame (interpolated across a gap), so the
    IK solution continues smoothly out of the active range and the raised-cosine weight (zero slope at both
    ends) fades it without a velocity kink."""
    win = np.flatnonzero((weight > 0) & ~act)
    if not win.size:
        return
    off = tgt - traj
    l, r = left[win], right[win]
    gl = np.where(l >= 0, win - l, np.inf)
    gr = np.where(r >= 0, r - win, np.inf)
    with np.errstate(invalid="ignore"):
        alpha = np.where(np.isinf(gr), 0.0, np.where(np.isinf(gl), 1.0, gl / (gl + gr)))[:, None]
    tgt[win] = traj[win] + (1 - alpha) * off[np.maximum(l, 0)] + alpha * off[np.maximum(r, 0)]


_REACH = 0.999  # fraction of a chain's full length the root drop makes available (a just-bent knee)


def _pivot(off: np.ndarray, to_upper: np.ndarray, reach) -> np.ndarray:
    """Toe -> ankle vectors ``off (n, 3)`` turned (length kept) toward ``to_upper (n, 3)`` (toe target ->
    upper joint) by the least angle that brings the ankle within ``reach`` (a length, or one per row
    ``(n,)``) of the upper joint (row by row: several contacts' rows go in one call): the heel
    lifts further when the leg cannot reach otherwise (fully toward it if even that is not enough)."""
    f = np.linalg.norm(off, axis=-1)
    D = np.linalg.norm(to_upper, axis=-1)
    u = to_upper / np.maximum(D, 1e-12)[:, None]
    cos0 = np.sum(off * u, axis=-1) / np.maximum(f, 1e-12)
    need = np.clip((D ** 2 + f ** 2 - reach ** 2) / np.maximum(2.0 * D * f, 1e-12), -1.0, 1.0)
    turn = cos0 < need                                                  # too far with the given heel lift
    if not turn.any():
        return off
    w = off - (cos0 * f)[:, None] * u                                    # part of off orthogonal to u
    wn = np.linalg.norm(w, axis=-1)
    w = np.where(wn[:, None] > 1e-12, w / np.maximum(wn, 1e-12)[:, None], 0.0)
    sin = np.sqrt(1.0 - need ** 2)
    return np.where(turn[:, None], f[:, None] * (need[:, None] * u + sin[:, None] * w), off)


def _reach_need(sk, pos, eff: int, act: np.ndarray, tgt: np.ndarray):
    """``(frames, dy)``: the active frames of the chain held at ``eff`` and how far (file units, vertical) each
    target lies below what the chain reaches at ``_REACH`` of its length from its upper joint (<= 0: it
    reaches; a target horizontally beyond reach gets the upper joint's height above it)."""
    up, mid, _ = _chain(sk, eff)
    fr = np.flatnonzero(act)                  # reach is needed while held; the windows fade out
    length = _REACH * _chain_length(pos[0], up, mid, eff)
    h, t = pos[fr, up], tgt[fr]
    horiz = np.hypot(h[:, 0] - t[:, 0], h[:, 2] - t[:, 2])
    return fr, (h[:, 1] - t[:, 1]) - np.sqrt(np.maximum(length ** 2 - horiz ** 2, 0.0))


def _raise_to_reach(sk, pos, groups) -> dict:
    """Raise each held target (in place) that its chain cannot reach with the upper joint where it is, to the
    height it reaches (x and z stay); returns ``{effector: rise (F,)}`` (file units, >= 0)."""
    rises = {}
    for eff, (act, tgt) in groups.items():
        fr, dy = _reach_need(sk, pos, eff, act, tgt)
        rise = np.zeros(act.shape[0])
        rise[fr] = np.maximum(dy, 0.0)
        tgt[:, 1] += rise
        rises[eff] = rise
    return rises


def _root_drop(sk, pos, groups, nb: int) -> np.ndarray:
    """Smallest smooth downward root offset ``(F,)`` (file units, >= 0) with which every held chain reaches
    ``_REACH`` of its length at its target on its active frames (vertical move only; a target horizontally
    beyond reach gets the drop that brings the upper joint to the target's height)."""
    from scipy.ndimage import maximum_filter1d
    F = pos.shape[0]
    need = np.zeros(F)
    for eff, (act, tgt) in groups.items():
        fr, dy = _reach_need(sk, pos, eff, act, tgt)
        need[fr] = np.maximum(need[fr], np.maximum(dy, 0.0))
    if not np.any(need > 0):
        return need
    w = max(nb, 1)
    peak = maximum_filter1d(need, 2 * w + 1, mode="nearest")      # >= need[x] over [x - w, x + w]
    kernel = 0.5 * (1.0 + np.cos(np.pi * np.arange(-w, w + 1) / (w + 1)))
    kernel /= kernel.sum()
    # an average of values that are all >= need[x] stays >= need[x]: the smooth profile still reaches
    return np.convolve(np.pad(peak, w, mode="edge"), kernel, mode="valid")


def _constrained_joints(sk, parsed) -> set:
    """Joints :func:`apply_contact_constraints` reads for contacts ``parsed`` ``[(joint, start, stop)]``: the
    contact joints, their chains and the middle joints' parents (FK adds the ancestors)."""
    chains = [_chain(sk, j) for j, _, _ in parsed]
    need = {j for j, _, _ in parsed} | {x for ch in chains for x in ch if x >= 0}
    return need | {int(sk.parents[ch[1]]) for ch in chains if ch[1] > 0}


def _share(lower_root) -> float:
    share = float(lower_root)
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"lower_root must be a bool or a share in [0, 1], got {lower_root!r}")
    return share


def apply_contact_constraints(motion: Motion, contacts, reference: Motion | None = None, blend: float = 0.15,
                              mode: str | None = None, *, targets=None, lower_root: bool | float = False,
                              toe_offsets=None, raise_unreachable: bool = False, _fk=None) -> Motion:
    """Constraint displacement layer (§3): two-bone IK on legs/arms holding contacts in place.

    Parameters
    ----------
    motion : Motion
        The evaluated (possibly edited) motion, F frames.
    contacts : list of (joint_name, start_frame, stop_frame)
        Active frame ranges ``[start, stop)``; JSON-serialisable.
    reference : Motion, optional
        Motion whose contact-joint positions are the targets (the unedited source); default ``motion``
        itself (removes its own foot skate). Must have the same skeleton and frame count.
    blend : float
        Seconds of smooth attenuation on each side of an active range (>= 0). The displacement of the
        nearest active frame is faded with a raised cosine, so it starts and ends with zero slope.
    mode : {"mean", "track"}, optional
        Target = the reference position averaged over the contact (a planted point) or followed per frame
        (keeps the reference's heel-toe roll exactly). Default: ``"track"`` when a ``reference`` is
        given (an edit must not move the feet), ``"mean"`` otherwise (clean-up of the motion's own skate).
    targets : list of ndarray, optional
        World positions the contact joints must hold instead of the reference's: one per contact, shape
        ``(3,)`` (a planted point) or ``(stop - start, 3)``, file units (``reference``/``mode`` are then
        ignored; see :func:`keep_contacts`, whose contacts moved in time with a timing edit).
    toe_offsets : list of (ndarray or None), optional
        For toe contacts (held through the ankle), the world vector toe -> ankle to place the ankle with,
        one per contact, shape ``(stop - start, 3)`` (None: the motion's own, i.e. the foot keeps its world
        orientation). :func:`keep_contacts` passes the source's, so the heel lifts as it did in the source.
    lower_root : bool
        Where a held chain cannot reach its target (the target is farther from the upper joint than the
        two bones are long: e.g. a contact carried later than the pelvis' own timing), lower the root
        translation just enough (along -Y, the BVH up axis) that every held leg/arm reaches, with the
        smallest smooth profile above the need (a max filter and a raised-cosine average, both the
        ``blend`` window wide), as footskate clean-up does (Kovar et al. 2002). Off by default. A number in
        [0, 1] lowers that share of the need (the rest is left to ``raise_unreachable``).
    raise_unreachable : bool
        Where a held chain cannot reach its target, raise the target (only its height) to where the chain
        reaches instead: the root keeps its height and the foot is held in x/z, a little above its plant
        (before ``lower_root``, which then finds nothing left to lower). Off by default.

    Returns
    -------
    Motion
        ``motion`` with local rotations of (upper, middle, effector) joints of each constrained chain
        post-multiplied by the attenuated IK displacement; unchanged outside the windows (up to
        the round-off of re-normalisation, < 1e-15).
    """
    if mode is None:
        mode = "mean" if reference is None else "track"
    if reference is None or targets is not None:
        reference = motion
    if reference.num_frames != motion.num_frames or reference.num_joints != motion.num_joints:
        raise ValueError("reference must have the same number of frames and joints as motion")
    blend = float(blend)
    if not np.isfinite(blend) or blend < 0:
        raise ValueError(f"blend must be >= 0 seconds, got {blend!r}")
    share = _share(lower_root)
    parsed = _parse_contacts(motion, contacts)
    if not parsed:
        return motion
    sk = motion.skeleton
    F = motion.num_frames
    nb = int(round(blend / motion.frame_time))
    chains = [_chain(sk, j) for j, _, _ in parsed]
    need = _constrained_joints(sk, parsed)
    # _fk: keep_contacts' own _fk_joints(motion, joints ⊇ need), whose positions this call may lower in place
    pos, wq = _fk_joints(motion, need) if _fk is None else _fk
    if targets is None:
        ref_pos = pos if reference is motion else _fk_joints(reference, need)[0]
        targets = contact_positions(reference, contacts, mode=mode, positions=ref_pos)
    else:
        ref_pos = pos
        if len(targets) != len(parsed):
            raise ValueError(f"targets: one per contact ({len(parsed)}), got {len(targets)}")
        given = []
        for (j, s_, e_), t in zip(parsed, targets):
            t = np.asarray(t, dtype=float)
            if t.shape not in ((3,), (e_ - s_, 3)) or not np.all(np.isfinite(t)):
                raise ValueError(f"targets: each must be 3 finite numbers or ({e_ - s_}, 3), got shape {t.shape}")
            given.append(np.broadcast_to(t, (e_ - s_, 3)))
        targets = given
    lq = motion.local_quats                                  # read only; ``out`` below is the copy

    # group contacts by effector; direct (ankle) contacts take precedence over toe contacts
    groups: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    order = sorted(range(len(parsed)), key=lambda i: chains[i][2] == parsed[i][0])
    # toe contacts placed by a given toe -> ankle vector: every contact's pivot in one (row-wise) call
    pivoted = [i for i in range(len(parsed)) if toe_offsets is not None and toe_offsets[i] is not None
               and chains[i][2] != parsed[i][0] and chains[i][0] > 0]
    pivots = {}
    if pivoted:
        rows = [parsed[i][2] - parsed[i][1] for i in pivoted]
        lengths = {ch: _REACH * _chain_length(pos[0], *ch) for ch in {chains[i] for i in pivoted}}
        reach = [lengths[chains[i]] for i in pivoted]
        turned = _pivot(np.concatenate([np.asarray(toe_offsets[i], dtype=float) for i in pivoted]),
                        np.concatenate([pos[parsed[i][1]:parsed[i][2], chains[i][0]] - targets[i] for i in pivoted]),
                        np.repeat(reach, rows))
        pivots = dict(zip(pivoted, np.split(turned, np.cumsum(rows)[:-1])))
    for i in order:
        j, s, e = parsed[i]
        up, mid, eff = chains[i]
        if up <= 0:
            raise ValueError(f"contacts: joint {sk.names[j]!r} has no two-bone chain below the root")
        act, tgt = groups.setdefault(eff, (np.zeros(F, bool), np.zeros((F, 3))))
        t = targets[i]
        if eff != j:  # toe contact: ankle target keeps the foot's world orientation (or the given one)
            if i in pivots:
                t = t + pivots[i]
            else:
                t = t - (pos[s:e, j] - pos[s:e, eff])
        act[s:e] = True
        tgt[s:e] = t

    traj = {eff: ref_pos[:, eff].copy() for eff in groups}   # the windows follow the unlowered trajectory
    rp = motion.root_positions           # lowered below: one new Motion at the end, not one per change
    if share > 0:
        drop = _root_drop(sk, pos, groups, nb)
        if np.any(drop > 0):
            if share < 1:
                drop *= share
            rp = np.array(rp)
            rp[:, 1] -= drop
            pos[..., 1] -= drop[:, None]  # pos is this call's own array (or keep_contacts', passed to it)
    rises = _raise_to_reach(sk, pos, groups) if raise_unreachable else {}   # what the lowering left
    windows = {}
    for eff, (act, tgt) in groups.items():
        weight, left, right = attenuation_weights(act, nb)
        _window_targets(tgt, traj[eff], act, weight, left, right)
        windows[eff] = weight
    out = np.array(lq)
    # every held chain's window frames in one batch (rows: frame, chain): one IK solve per kind of chain
    # (the middle joint's parent is the upper joint, or a zero-length bone between them), not one per chain
    rows = {}
    for eff, (act, tgt) in groups.items():
        up, mid, _ = _chain(sk, eff)
        fr = np.flatnonzero(windows[eff] > 0)
        rows.setdefault(int(sk.parents[mid]) == up, []).append((fr, np.array([up, mid, eff]), tgt[fr], windows[eff][fr],
                                                                int(sk.parents[mid])))
    for direct, batch in rows.items():
        fr = np.concatenate([b[0] for b in batch])
        chain = np.concatenate([np.broadcast_to(b[1], (b[0].size, 3)) for b in batch])      # (n, 3)
        tgt = np.concatenate([b[2] for b in batch])
        weight = np.concatenate([b[3] for b in batch])
        up, mid, eff = chain.T
        a_new, b_new, bw_new = two_bone_ik(pos[fr, up], pos[fr, mid], pos[fr, eff], tgt, wq[fr, up], wq[fr, mid],
                                           lq[fr, up], b_parent_world=None if direct else
                                           wq[fr, np.concatenate([np.full(b[0].size, b[4]) for b in batch])])
        c_new = quat_mul(quat_conj(bw_new), wq[fr, eff])
        cur = lq[fr[:, None], chain]
        disp = quat_mul(quat_conj(cur), np.stack([a_new, b_new, c_new], axis=1))
        ident = np.broadcast_to(np.array([0.0, 0.0, 0.0, 1.0]), disp.shape)
        disp = slerp(ident, disp, np.broadcast_to(weight[:, None], (fr.size, 3)))
        out[fr[:, None], chain] = quat_mul(cur, disp)

    # Toe contacts that overlap an ankle contact (foot flat): the ankle is held above; turn the foot about
    # the ankle so the toe also lands on its target (shortest-arc aim of ankle -> toe, attenuated likewise).
    toes: dict[int, tuple[np.ndarray, np.ndarray, int]] = {}
    for i, (j, s, e) in enumerate(parsed):
        eff = chains[i][2]
        if eff != j and sk.parents[j] == eff:
            act, tgt, _ = toes.setdefault(j, (np.zeros(F, bool), np.zeros((F, 3)), eff))
            act[s:e] = True
            tgt[s:e] = targets[i]
            if eff in rises:                       # the foot rises as a whole where its ankle was raised
                tgt[s:e, 1] += rises[eff][s:e]
    if toes:
        pos2, wq2 = _fk_joints(motion, set(toes) | {eff for _, _, eff in toes.values()}, local_quats=out,
                               root_positions=rp)
        for j, (act, tgt, eff) in toes.items():
            weight, left, right = attenuation_weights(act, nb)
            fr = np.flatnonzero(weight > 0)
            _window_targets(tgt, pos2[:, j], act, weight, left, right)
            turn = quat_between_vectors(pos2[fr, j] - pos2[fr, eff], tgt[fr] - pos2[fr, eff])   # world frame
            disp = quat_mul(quat_conj(wq2[fr, eff]), quat_mul(turn, wq2[fr, eff]))              # ankle's local
            disp = slerp(np.broadcast_to(np.array([0.0, 0.0, 0.0, 1.0]), disp.shape), disp, weight[fr])
            out[fr, eff] = quat_mul(out[fr, eff], disp)
    # out: this call's own copy of a valid motion's rotations, displaced by unit quaternions; rp: the root
    # positions, lowered (finite): the trusted constructor, the same values as motion.replace(...)
    return Motion._trusted(motion.skeleton, motion.frame_time, rp, out, motion.local_translations)


def contact_errors(motion: Motion, contacts, reference: Motion | None = None, mode: str = "mean") -> np.ndarray:
    """Largest distance ``(N,)`` (file units) of each contact joint from its contact position over its
    active frames (targets from ``reference``, default ``motion``; see :func:`contact_positions`)."""
    reference = motion if reference is None else reference
    parsed = _parse_contacts(motion, contacts)
    targets = contact_positions(reference, contacts, mode=mode)
    p = forward_kinematics(motion)[0]
    return np.array([np.linalg.norm(p[s:e, j] - t, axis=-1).max() for (j, s, e), t in zip(parsed, targets)])


def foot_skate(motion: Motion, contacts, up_axis: int = 1) -> np.ndarray:
    """Foot skate ``(N,)``: horizontal path length (file units) travelled by each contact joint during its
    active frames (0 for a perfectly planted contact)."""
    parsed = _parse_contacts(motion, contacts)
    p = forward_kinematics(motion)[0]
    horiz = [k for k in range(3) if k != up_axis]
    return np.array([np.linalg.norm(np.diff(p[s:e, j][:, horiz], axis=0), axis=-1).sum() for j, s, e in parsed])


# -- contacts carried through staggered timing edits ------------------------------------------------------

def _timeline(edited):
    """(start time, frame time, frame count, joint names) of ``evaluate(edited)`` or of a Motion."""
    from .representation import StaggeredMotion, default_times
    if isinstance(edited, StaggeredMotion):
        return float(edited.pose_times[0]), edited.frame_time, default_times(edited).size, edited.skeleton.names
    if isinstance(edited, Motion):
        return 0.0, edited.frame_time, edited.num_frames, edited.skeleton.names
    raise ValueError(f"edited must be a StaggeredMotion or a Motion, got {type(edited).__name__}")


def _carry(edited, contacts, source_frame_time: float, carry_by: str = "joint", tables=None):
    """``[(name, joint, start, stop, source_start, source_stop, clock)]`` of the contacts that keep a frame
    (``clock``: the index of the joint whose time warp moved it); ``tables``: ``timing._warp_tables(edited)``
    when the caller has them."""
    from .timing import _warp_column, _warp_tables
    from .representation import StaggeredMotion
    ft_s = float(source_frame_time)
    if not np.isfinite(ft_s) or ft_s <= 0:
        raise ValueError(f"source_frame_time must be > 0 seconds, got {source_frame_time!r}")
    if carry_by not in ("joint", "limb", "span"):
        raise ValueError(f"carry_by must be 'joint', 'limb' or 'span', got {carry_by!r}")
    t0, ft, F, names = _timeline(edited)
    names = list(names)
    is_sm = isinstance(edited, StaggeredMotion)
    if is_sm and tables is None:
        tables = _warp_tables(edited)        # every contact's warp from one table (not one per contact)
    out = []
    for item in contacts:
        try:
            name, a, b = item
            a, b = int(a), int(b)
        except (TypeError, ValueError):
            raise ValueError(f"contacts: each entry must be (joint_name, start_frame, stop_frame), got {item!r}") from None
        if isinstance(name, (int, np.integer)) and 0 <= int(name) < len(names):
            name = names[int(name)]
        if name not in names:
            raise ValueError(f"contacts: unknown joint {name!r}")
        if not 0 <= a < b:
            raise ValueError(f"contacts: frame range [{a}, {b}) of {name!r} is empty or negative")
        times = np.array([a, b - 1], dtype=float) * ft_s
        j = names.index(name)
        clock = j
        if carry_by == "limb":
            up = _chain(edited.skeleton, j)[0]
            clock = up if up >= 0 else j
        if is_sm:
            own = _warp_column(*tables, clock, times)
            if carry_by == "span":   # also the limb's middle joint (knee / elbow): the union of both intervals
                mid = _chain(edited.skeleton, j)[1]
                other = _warp_column(*tables, mid if mid >= 0 else j, times)
                own = np.array([min(own[0], other[0]), max(own[1], other[1])])
            times = own
        start = max(int(np.ceil((times[0] - t0) / ft - 1e-6)), 0)
        stop = min(int(np.floor((times[1] - t0) / ft + 1e-6)) + 1, F)
        if stop > start:
            out.append((str(name), j, start, stop, a, b, clock))
    if carry_by == "span":   # a joint's next contact takes the frames the union gave both (one plant at a time)
        last = {}
        for i in sorted(range(len(out)), key=lambda i: (out[i][1], out[i][4])):
            k = last.get(out[i][1])
            if k is not None and out[k][3] > out[i][2]:
                out[k] = out[k][:3] + (out[i][2],) + out[k][4:]
            last[out[i][1]] = i
        out = [c for c in out if c[3] > c[2]]
    return out


def carry_contacts(edited, contacts, source_frame_time: float, *, carry_by: str = "joint") -> list[tuple[str, int, int]]:
    """Contacts of the source moved in time with each contact joint's own timing edit.

    A contact ``(joint, start, stop)`` holds on source frames ``[start, stop)`` (times ``frame *
    source_frame_time``). Its first and last active times are mapped through the time warp of that joint's
    rotation (:func:`~stagger_nb.staggered.timing.warp_times`: piecewise linear from the source knot times
    to the edited knot times, §3/§5.2), and become the frames of ``evaluate(edited)`` (times
    ``pose_times[0] + n * frame_time``) inside the mapped interval.

    Parameters
    ----------
    edited : StaggeredMotion (timing-edited) or Motion (no timing edit: times map to themselves)
    contacts : list of (joint_name, start_frame, stop_frame), half-open source frames
    source_frame_time : float, seconds
    carry_by : {"joint", "limb", "span"}
        Whose time warp moves a contact: the contact joint's own (default: "a foot's contact moves with that
        foot's timing"), or the upper joint of its limb (hip / shoulder: the limb's timing relative to the
        pelvis; a foot whose ankle lags the hip then ends its contact earlier, nearer to where the leg can
        still reach, so :func:`keep_contacts` lowers the root less), or ``"span"``: the union of the intervals
        carried by the contact joint's own warp and by its limb's middle joint's (knee / elbow, which with
        the hip places the foot), from the earlier start to the later stop; where this makes two contacts
        of one joint overlap, the earlier one stops where the next starts.

    Returns
    -------
    list of (joint_name, start_frame, stop_frame), half-open frames of the edited motion; contacts that
    shrink to no frame are dropped.
    """
    return [c[:1] + c[2:4] for c in _carry(edited, contacts, source_frame_time, carry_by)]


# plant shifts tried, in leg lengths (1/80 apart); within a quarter leg of the hip-following point, so a plant
# stays near where the edited foot lands (wider searches lower the pelvis less on walks but move hop landings
# far from their feet: the transitions then slide, e.g. notebook 01's hops)
_SHIFT_STEPS = np.linspace(-0.25, 0.25, 41)


def _reachable_shifts(hips, points, plant, lengths, shifts) -> np.ndarray:
    """Horizontal plant shifts ``(P, 3)`` (y = 0) near ``shifts (P, 3)`` with which a straight-legged stance
    reaches its plant without lowering the hip, for every plant at once.

    Plant ``p`` is tried at ``shifts[p] + a u_p`` (``u_p`` its hip's horizontal travel direction, ``a`` in
    ``_SHIFT_STEPS * lengths[p]``, at most a quarter leg); the chosen ``a`` minimises the largest root drop its held points need
    (``points + shift (n, 3)`` from the hip positions ``hips (n, 3)`` with reach ``lengths[p]``, the samples
    of plant ``plant (n,)``, ascending); among the shifts needing no drop, the one nearest ``shifts[p]``.
    Plants without samples keep ``shifts[p]`` (y set to 0)."""
    out = np.array(shifts, dtype=float)
    out[:, 1] = 0.0
    if not plant.size:
        return out
    ids, starts = np.unique(plant, return_index=True)
    last = np.r_[starts[1:], plant.size] - 1
    u = (hips[last] - hips[starts])[:, [0, 2]]                                     # (p, 2)
    un = np.sqrt(np.einsum("pk,pk->p", u, u))
    moving = un >= 1e-9 * lengths[ids]
    u = u / np.where(moving, un, 1.0)[:, None]
    L = lengths[plant]                                                             # (n,)
    rel = (hips - points)[:, [0, 2]] - out[plant][:, [0, 2]]                       # (n, 2)
    ru = np.einsum("nk,nk->n", rel, u[np.searchsorted(ids, plant)])
    a = _SHIFT_STEPS[:, None] * L                                                  # (A, n)
    # |rel - a u|^2 = |rel|^2 - 2 a (rel . u) + a^2, for every (a, sample)
    h2 = np.einsum("nk,nk->n", rel, rel) + a * (a - 2.0 * ru)
    np.subtract(L * L, h2, out=h2)
    np.maximum(h2, 0.0, out=h2)
    need = (hips[:, 1] - points[:, 1]) - np.sqrt(h2, out=h2)
    worst = np.maximum.reduceat(need, starts, axis=1)                              # (A, p)
    ok = worst <= 0
    k = np.where(ok.any(axis=0), np.argmin(np.where(ok, np.abs(_SHIFT_STEPS)[:, None], np.inf), axis=0),
                 np.argmin(worst, axis=0))
    step = np.where(moving, _SHIFT_STEPS[k] * lengths[ids], 0.0)
    out[ids, 0] += step * u[:, 0]
    out[ids, 2] += step * u[:, 1]
    return out


def _plants(carried, effs) -> list[list[int]]:
    """Indices of ``carried`` grouped into plants: contacts held through the same effector whose edited frame
    ranges overlap or touch (e.g. a foot's ankle and toe contacts of one step)."""
    groups: dict[int, list[list[int]]] = {}
    for i in sorted(range(len(carried)), key=lambda i: carried[i][2]):
        eff = effs[carried[i][1]]
        runs = groups.setdefault(eff, [])
        if runs and carried[i][2] <= max(carried[k][3] for k in runs[-1]):
            runs[-1].append(i)
        else:
            runs.append([i])
    return [np.array(r) for runs in groups.values() for r in runs]


# a toe plant held with its ankle's is consistent when their distance is the foot's length within this share
_FOOT_TOL = 0.05


def _release_heels(carried, effs, targets, rest) -> list[tuple[str, int, int]]:
    """The carried contacts as ``(name, start, stop)``, an ankle contact stopped where a toe contact of the same
    foot starts inside it (heel-off) when the two plants do not fit one foot: the toe plant's distance from the
    ankle plant (at the toe's first frame) differs from the foot's length (rest pose ``rest (J, 3)``) by more
    than ``_FOOT_TOL`` of it. Held together the toe, turned about the held ankle, would stop short of (or
    beyond) its plant and step onto it when the ankle is released; the later contact (the toe's) holds the
    foot from its start instead. ``targets`` (one per contact, ``(3,)`` or ``(stop - start, 3)``) are cut to
    match, in place."""
    held = [c[:1] + c[2:4] for c in carried]
    for i, (_, j, s, e, *_r) in enumerate(carried):          # i: a toe contact (held through its ankle)
        eff = effs[j]
        if eff == j:
            continue
        foot = float(np.linalg.norm(rest[j] - rest[eff]))
        for k, (_, jk, sk_, _e, *_r2) in enumerate(carried):
            ek = held[k][2]
            if jk != eff or not sk_ < s < ek <= e:
                continue
            tk, ti = np.asarray(targets[k]), np.asarray(targets[i])
            gap = np.linalg.norm((ti if ti.ndim == 1 else ti[0]) - (tk if tk.ndim == 1 else tk[s - sk_]))
            if abs(gap - foot) > _FOOT_TOL * foot:
                held[k] = (held[k][0], sk_, s)
                if tk.ndim == 2:
                    targets[k] = tk[:s - sk_]
    return held


def keep_contacts(edited, source: Motion, *, contacts=None, blend: float = 0.15, mode: str = "mean",
                  lower_root: bool | float = 0.5, carry_by: str = "span", plant: str = "hip",
                  source_positions: np.ndarray | None = None) -> Motion:
    """The constraint layer after staggered timing edits (§3, §5.2): contacts of ``source`` carried with each
    foot's own timing (:func:`carry_contacts`), then held by the IK displacement of
    :func:`apply_contact_constraints` at the source's contact positions moved with the hip (``plant``), the
    pelvis and the foot sharing what a straight stance leg cannot reach (``lower_root``).

    Measured (tests/test_staggered_keep_contacts.py, real walks after ``succession(Hips, 0.02, 1)`` +
    ``random_timing(0.05, seed=0)``): feet travel <= 0.43 cm inside the contacts carried by each joint's own
    timing shrunk by 0.1 s (19-23 cm without), the pelvis height changes by <= 1.4 cm and a held foot sits
    <= 1.2 cm above its plant (the source plant with the root lowered alone: 5-12 cm of pelvis drop). Inside
    the SOURCE's contact intervals shrunk by 0.1 s (tests/test_acceptance_editors.py): xia 0.19 cm, bandai
    0.00, cmu_131_01 0.38 (24-29 cm without; 1.69, 0.76, 2.81 with ``carry_by="joint"``, whose contacts
    start up to 0.15 s after the source's: the foot still swings on the first frames of those intervals).
    Where a toe contact starts inside its ankle's and the two plants do not fit one foot, the ankle contact
    stops there (:func:`_release_heels`; cmu_131_01 RightToe 821-942: 1.15 -> 0.38 cm).

    Parameters
    ----------
    edited : StaggeredMotion or Motion
        The current (timing- and/or pose-edited) staggered motion, or an already evaluated Motion
        (then the contacts keep their times).
    source : Motion
        The motion the extraction came from (its frames at ``frame * frame_time`` seconds).
    contacts : list of (joint_name, start_frame, stop_frame), optional
        Source contacts, half-open source frames; default ``edited.contacts`` (found at extraction) or
        :func:`~stagger_nb.staggered.detect_contacts` of ``source`` (feet; hands only where they support).
    blend : float, seconds
        Attenuation window on each side of a contact (see :func:`apply_contact_constraints`).
    mode : {"mean", "track"}
        Where a carried contact holds: the source contact's mean position (a planted point, default), or the
        source's position at the source time of each edited frame (through the inverse warp: keeps the
        heel-toe roll).
    lower_root : bool or float in [0, 1]
        Where a straight stance leg cannot reach its carried plant (mostly just after heel strike of a foot
        whose timing lags the pelvis'), the share of the missing height taken by lowering the root (a smooth
        profile, see :func:`apply_contact_constraints`); the rest raises the held foot (x/z still held, a
        little above its plant: it lands a little later). True = 1: the foot stays on its plant and the
        pelvis drops; False = 0: the pelvis keeps its height. Default 0.5: both changes are halved (on the
        real walks of issue 11, <= 1.4 cm each).
    carry_by : {"span", "joint", "limb"}
        Whose timing moves each contact (see :func:`carry_contacts`). Default ``"span"``: held from the earlier
        of the contact joint's and its knee's (elbow's) carried starts to the later stop, so a foot is held
        from when either timing lands it (with ``"joint"`` the first frames of a source contact can come
        before an ankle that lags the knee lands it, and the foot still swings there).
    plant : {"hip", "source"}
        Where a carried contact holds horizontally. ``"hip"`` (default): the source's contact point moved by
        the limb's upper joint (hip / shoulder) the way the edit moved it, i.e. by the mean over the carried
        frames of ``upper_edited(t) - upper_source(w^-1(t))`` (x and z only; the height stays the source's
        ground). A foot whose timing lags the pelvis' by ``δ`` is then planted ``≈ v δ`` further along the
        walk, where its own delayed swing puts it, so the leg reaches it without lowering the pelvis.
        ``"source"``: the source's contact point itself (the leg must then reach back by ``v δ``: on real
        walks the root drops 5-12 cm).
    source_positions : ndarray, shape (F_source, J, 3), optional
        ``forward_kinematics(source)[0]`` (world joint positions, file units) when the caller has it (an edit
        session keeps it per source: it does not change with the edit); the same numbers as computing it
        here, one forward kinematics fewer per call.

    Returns
    -------
    Motion: ``evaluate(edited)`` (or ``edited``) with the contact chains' rotations displaced.
    """
    from .contacts import detect_contacts
    from .timing import _warp_column, _warp_tables
    from .evaluation import evaluate
    from .representation import StaggeredMotion
    if not isinstance(source, Motion):
        raise ValueError(f"source must be a Motion, got {type(source).__name__}")
    if mode not in ("mean", "track"):
        raise ValueError(f"mode must be 'mean' or 'track', got {mode!r}")
    if plant not in ("hip", "source"):
        raise ValueError(f"plant must be 'hip' or 'source', got {plant!r}")
    share = _share(lower_root)
    t0, _, _, _ = _timeline(edited)
    is_sm = isinstance(edited, StaggeredMotion)
    if edited.skeleton.num_joints != source.num_joints:
        raise ValueError("edited and source must have the same skeleton")
    if contacts is None:
        contacts = list(edited.contacts) if is_sm and edited.contacts else detect_contacts(source)
    _parse_contacts(source, contacts)                        # validates frames against the source
    motion = evaluate(edited) if is_sm else edited
    tables = _warp_tables(edited) if is_sm else None
    carried = _carry(edited, contacts, source.frame_time, carry_by, tables)
    if not carried:
        return motion
    sk = source.skeleton
    chains = {j: _chain(sk, j) for j in {c[1] for c in carried}}
    effs = {j: ch[2] for j, ch in chains.items()}
    ups = {j: max(ch[0], 0) for j, ch in chains.items()}
    if source_positions is None:
        src_pos = _fk_joints(source, set(effs) | set(effs.values()) | set(ups.values()))[0]   # the contact chains
    else:
        src_pos = np.asarray(source_positions)
        if src_pos.shape != (source.num_frames, source.num_joints, 3):
            raise ValueError(f"source_positions: expected shape ({source.num_frames}, {source.num_joints}, 3) "
                             f"(forward_kinematics(source)[0]), got {src_pos.shape}")
    # source positions at the source time of every carried frame (inverse of each contact's joint warp),
    # all contacts at once: one interpolation per clock joint, one gather for every frame
    n = np.array([c[3] - c[2] for c in carried])
    frames = np.concatenate([np.arange(c[2], c[3]) for c in carried])
    te = t0 + frames * motion.frame_time
    ts = te
    if is_sm:
        ts = np.empty_like(te)
        clock = np.repeat([c[6] for c in carried], n)
        for c in np.unique(clock):
            sel = clock == c
            ts[sel] = _warp_column(*tables, int(c), te[sel], inverse=True)
    f = np.clip(ts / source.frame_time, 0, source.num_frames - 1)
    i0 = np.floor(f).astype(int)
    i1 = np.minimum(i0 + 1, source.num_frames - 1)
    w = (f - i0)[:, None, None]
    cols = np.repeat([[c[1], effs[c[1]], ups[c[1]]] for c in carried], n, axis=0)   # the joints read below
    at = src_pos[i0[:, None], cols] * (1 - w) + src_pos[i1[:, None], cols] * w   # (sum n, 3, 3)
    span = np.array([c[5] - c[4] for c in carried])                                 # source frames held
    fr_src = np.concatenate([np.arange(c[4], c[5]) for c in carried])
    means = np.add.reduceat(src_pos[fr_src, np.repeat([c[1] for c in carried], span)],
                            np.r_[0, np.cumsum(span)[:-1]], axis=0) / span[:, None]    # (contacts, 3)
    starts = np.r_[0, np.cumsum(n)[:-1]]
    shift = np.zeros((len(carried), 3))
    fk = None
    if plant == "hip":   # how far the edit moved each limb's upper joint, horizontally, over the contact
        parsed = [(j, s_, e_) for _, j, s_, e_, _, _, _ in carried]
        fk = _fk_joints(motion, _constrained_joints(sk, parsed) | set(ups.values()))   # shared with the IK below
        up_e = fk[0][frames, cols[:, 2]]                                                 # (sum n, 3)
        sums = np.add.reduceat(up_e - at[:, 2], starts, axis=0)                         # (contacts, 3)
        plants = _plants(carried, effs)   # one shift per plant: a foot's toe and ankle contacts agree
        of = np.empty(len(carried), np.int64)
        for p, members in enumerate(plants):
            of[members] = p
        P = len(plants)
        mean_shift = np.zeros((P, 3))
        np.add.at(mean_shift, of, sums)
        mean_shift /= np.bincount(of, weights=n, minlength=P)[:, None]
        lengths = np.array([_REACH * _chain_length(src_pos[0], *chains[carried[mb[0]][1]]) for mb in plants])
        # the point each direct (ankle) contact frame holds before the shift; toe contacts are left out: where
        # the leg cannot reach their ankle point, apply_contact_constraints lifts the heel (see _pivot)
        direct = np.repeat([effs[c[1]] == c[1] for c in carried], n)
        base = np.repeat(means, n, axis=0) if mode == "mean" else at[:, 0]
        pid = np.repeat(of, n)[direct]
        order = np.argsort(pid, kind="stable")
        shift = _reachable_shifts(up_e[direct][order], base[direct][order], pid[order], lengths, mean_shift)[of]
    targets, toe_offsets = [], []
    for (name, j, s_, e_, a, b, clock), piece, d, mu in zip(carried, np.split(at, starts[1:]), shift, means):
        targets.append((mu if mode == "mean" else piece[:, 0]) + d)
        toe_offsets.append(piece[:, 1] - piece[:, 0] if effs[j] != j else None)
    held = _release_heels(carried, effs, targets, src_pos[0])
    return apply_contact_constraints(motion, held, blend=blend, targets=targets,
                                     lower_root=share, raise_unreachable=share < 1,
                                     toe_offsets=toe_offsets, _fk=fk)
