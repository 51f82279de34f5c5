"""Geometric editing of staggered poses (Coleman et al. 2008, §5.1): pose edits, relative exaggeration, and the
offset basis that lets a slider re-measure faster.

The editing tools' conventions and notation: :mod:`stagger_nb.staggered`.

Geometric edits change the knots by a per-joint offset ``δ``: ``v̂ = v ⊕ δ`` and ``v̂⁰ = v⁰ ⊕ δ`` (the mutual
constraint of the two knots, both directions of Figure 6a/b). The displacement maps of the two segments around
the pose are then re-measured so that the evaluated motion is the old one post-multiplied by a smooth weight
``w(t) δ``: ``w = 1`` on the plateau between ``t_k`` and ``T[k, i]`` (so both knots get exactly ``δ``), a
raised-cosine ramp to 0 at the neighbouring poses' plateaus, 0 elsewhere. Because the old displacement is kept
inside the new one, high-frequency detail is carried through (§3, §5.1), and frames outside the two segments
around an edited pose do not change at all.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.rotations import quat_conj, quat_exp, quat_hemisphere, quat_log, quat_mul
from . import _kernels as kern
from ._checks import _IDENTITY, _check, _finite, _joint_mask, _pose_index, _pose_weights, _rotation_table
from .channel import ROTATION, Channel
from .displacement import _grid, measure
from .evaluation import _rotations_at, channel_at, static_rotations
from .representation import StaggeredMotion, knot_times
from .source_times import _refresh

__all__ = ["edit_pose", "exaggerate", "mean_pose", "OffsetBasis", "pose_offset_basis", "spread_offsets"]




def _pair_plateau_weights(knots: np.ndarray, tk: np.ndarray, k: np.ndarray, col: np.ndarray, side: int,
                          t: np.ndarray, pair: np.ndarray) -> np.ndarray:
    """Weight ``(N,)`` of pose ``k[pair]`` at times ``t (N,)`` for control variable ``col[pair]`` of ``knots (K, C)``
    on ``side`` (-1: t is before pose k's knot, in segment k-1; +1: after, in segment k): 1 on the plateau
    between ``t_k`` and ``T[k, col]``, a raised cosine down to 0 at the neighbouring pose's plateau edge. The
    plateau and ramp ends are found once per pair (P << N) and gathered, and the raised cosine
    ``(1 - cos(pi u)) / 2`` is taken as ``(1 - sin(pi/2 - pi u)) / 2`` by the kernels' polynomial sine (numpy's
    cos is scalar libm here; tests/references.py has the per-sample form, the same values to ~1e-16)."""
    T = np.maximum.accumulate(knots, axis=0)
    lo = np.minimum(tk[:, None], T)
    hi = np.maximum(tk[:, None], T)
    kn = np.clip(k + side, 0, T.shape[0] - 1)
    inner = (hi[kn, col] if side < 0 else lo[kn, col])[pair]     # where the ramp reaches 0
    outer = (lo[k, col] if side < 0 else hi[k, col])[pair]       # where the ramp reaches 1
    L = outer - inner
    nz = np.abs(L) > 0
    u = np.where(nz, (t - inner) / np.where(nz, L, 1.0), 1.0)
    np.clip(u, 0.0, 1.0, out=u)
    x = np.pi / 2 - np.pi * u                                     # in [-pi/2, pi/2]
    w = kern.sin_poly(x, np.empty_like(x), np.empty_like(x))
    w = 0.5 * (1.0 - w)
    on_plateau = (t >= lo[k, col][pair]) & (t <= hi[k, col][pair])
    return np.where(on_plateau, 1.0, w)


@dataclass(frozen=True, eq=False)
class OffsetBasis:
    """What re-measuring every displacement map of one StaggeredMotion after knot offsets (§5.1) needs that
    does not depend on the offsets: the re-measuring grid of every (segment, joint) pair, the motion's
    rotations on it and the plateau weights of both ends. Built by :func:`pose_offset_basis`; pass it to
    :func:`exaggerate` (``basis=``) to skip that half of the work when the same motion is exaggerated again
    with another ``w_r`` (a slider). Arrays: ``seg, joint, counts (P,)``, the P pairs it covers: every
    (segment, joint) pair of the joints that move (P <= (K - 1) J; a static joint's rotation, one quaternion
    throughout, e.g. 6 of CMU's 31, is not exaggerated by a relative offset and keeps its map); ``pair,
    m, tn, t (N,)`` the grid (pair index, index in the pair, normalised and absolute time, seconds);
    ``old (4, N)`` the rotations (x, y, z, w rows); ``wl, wr (N,)`` the weights of the segment's first and
    second pose; ``knots (K, J)`` and ``pose_times (K,)`` of the motion it was built for (checked on use)."""

    knots: np.ndarray
    pose_times: np.ndarray
    seg: np.ndarray
    joint: np.ndarray
    counts: np.ndarray
    grid: tuple
    old: np.ndarray
    wl: np.ndarray
    wr: np.ndarray

    def fits(self, sm: StaggeredMotion) -> bool:
        """True when this basis was built for a motion with ``sm``'s knots and displacement grids."""
        return (self.knots.shape == (sm.num_poses, sm.num_joints) and np.array_equal(self.knots, knot_times(sm))
                and np.array_equal(self.pose_times, sm.pose_times)
                and np.array_equal(self.counts, sm.displacement_counts[self.seg, self.joint]))

    def restrict(self, pairs: np.ndarray) -> OffsetBasis:
        """This basis on the subset ``pairs (P,) bool`` of its pairs (the grid gathered, pairs renumbered)."""
        if pairs.all():
            return self
        pair, m, tn, t = self.grid
        keep = pairs[pair]
        new_id = np.cumsum(pairs) - 1
        return OffsetBasis(self.knots, self.pose_times, self.seg[pairs], self.joint[pairs], self.counts[pairs],
                           (new_id[pair[keep]], m[keep], tn[keep], t[keep]), self.old[:, keep], self.wl[keep],
                           self.wr[keep])


_READ_TOL = 1e-9   # rad: a motion read at the grid's frames stands for sm's own rotations there within this


def _old_from_frames(sm: StaggeredMotion, reproduced, seg, joint, pair, tn, t) -> np.ndarray | None:
    """``sm``'s rotations ``(4, N)`` at the grid samples ``(pair, t)`` read from ``reproduced`` (a Motion that
    ``sm`` reproduces at its frames, frame f at ``f * frame_time`` seconds; ``tn`` the samples' normalised
    times in their pairs), or None when a sample is off its
    frames (after timing edits) or a check finds ``sm`` away from it: the middle sample of every pair and
    every 16th sample are evaluated and must agree within ``_READ_TOL`` (a geometric edit since, …)."""
    ft = reproduced.frame_time
    if abs(ft - sm.frame_time) > 1e-12 * ft or reproduced.num_joints != sm.num_joints:
        return None
    f = t / ft
    r = np.rint(f)
    if not (np.all(np.abs(f - r) < 1e-9) and r.min() >= 0 and r.max() <= reproduced.num_frames - 1):
        return None
    jp = joint[pair]
    old = np.ascontiguousarray(reproduced.local_quats[r.astype(np.int64), jp].T)
    starts = np.flatnonzero(np.r_[True, pair[1:] != pair[:-1]])
    mid = (starts + np.r_[starts[1:], pair.size]) // 2
    check = np.union1d(mid, np.arange(0, pair.size, 16))
    true = np.array(_rotations_at(sm.rotations, seg[pair[check]] * sm.num_joints + jp[check], tn[check]))
    r = quat_mul(quat_conj(true.T), old[:, check].T)          # angle by atan2 (a dot product's arccos cannot
    angle = 2.0 * np.arctan2(np.linalg.norm(r[:, :3], axis=1), np.abs(r[:, 3]))   # resolve 1e-9 rad)
    return old if angle.max() <= _READ_TOL else None


def pose_offset_basis(sm: StaggeredMotion, reproduced=None) -> OffsetBasis:
    """The offset-independent half of re-measuring every displacement map of ``sm`` (see
    :class:`OffsetBasis`): ``exaggerate(sm, ..., basis=pose_offset_basis(sm))`` equals ``exaggerate(sm, ...)``
    to rounding (~1e-16 rad). Cost: about one :func:`evaluate`; memory ~100 bytes
    per grid sample (``(F + K) J`` samples at extraction). Static joints (:func:`~.evaluation.
    static_rotations`) are left out: an edit that moves one re-measures without the basis.

    ``reproduced``: a Motion ``sm`` reproduces at its frames (frame f at ``f * frame_time`` seconds), e.g. the
    source of an extraction or of its cull (both exact at the frames by construction, §4.1.1: ~1e-14 rad);
    while ``sm``'s knots sit on frames (no timing edit yet) the rotations on the grid are read from it instead
    of evaluated (most of the cost), after a check that evaluates every pair's middle sample and every 16th
    sample (they must agree within 1e-9 rad, else ``sm`` is evaluated as without it). The result then equals
    the basis without it to ~1e-14 rad."""
    _check(sm)
    K, J = sm.num_poses, sm.num_joints
    moving = np.flatnonzero(~static_rotations(sm)[0])
    seg, joint = np.divmod(np.arange((K - 1) * moving.size), moving.size)
    joint = moving[joint]
    counts = sm.displacement_counts[seg, joint]
    knots = knot_times(sm)
    T = np.maximum.accumulate(knots, axis=0)
    grid = _grid(T[seg, joint], T[seg + 1, joint], counts)
    pair, _, tn, t = grid
    old = None if reproduced is None else _old_from_frames(sm, reproduced, seg, joint, pair, tn, t)
    if old is None:
        old = np.array(_rotations_at(sm.rotations, seg[pair] * J + joint[pair], tn))
    wl = _pair_plateau_weights(knots, sm.pose_times, seg, joint, 1, t, pair)
    wr = _pair_plateau_weights(knots, sm.pose_times, seg + 1, joint, -1, t, pair)
    for a in (knots, old, wl, wr) + tuple(grid):
        a.setflags(write=False)
    return OffsetBasis(knots, np.array(sm.pose_times), seg, joint, counts, grid, old, wl, wr)


def _apply_pose_offsets(sm: StaggeredMotion, deltas: np.ndarray, root_deltas: np.ndarray | None = None,
                        basis: OffsetBasis | None = None):
    """Apply knot offsets ``deltas (K, J, 4)`` (and root translation offsets ``(K, 3)``): ``v̂ = v ⊕ δ``,
    ``v̂⁰ = v⁰ ⊕ δ``, the adjacent Bézier handles move with their knot, and the displacement maps of the
    touched segments are re-measured so that ``v̂(t) = v(t) ⊕ w_k(t) δ_k ⊕ w_{k+1}(t) δ_{k+1}`` (the
    rotation channel with ``basis`` when given)."""
    fields = {}
    rd = None if root_deltas is None else root_deltas[:, None]                # (K, 1, 3): one column
    for name, ch, d, b in (("rotations", sm.rotations, deltas, basis), ("translation", sm.translation, rd, None)):
        if d is not None:
            gen = ch.algebra.generator(d)                          # (K, C, 3)
            moved = ch.algebra.moves(gen)                          # (K, C)
            if moved.any():
                fields[name] = _offset_channel(sm, ch, d, gen, moved, b)
    return _refresh(sm, **fields) if fields else sm


def _offset_channel(sm: StaggeredMotion, ch: Channel, d, gen, moved, basis):
    """``ch`` with knot offsets ``d (K, C, D)`` (generators ``gen (K, C, 3)``, ``moved (K, C)``) applied and the
    maps of the touched segments re-measured (:func:`_apply_pose_offsets`)."""
    alg = ch.algebra
    values = alg.offset(ch.values, d)
    tangents = np.array(ch.tangents)
    tangents[:, :, 0] = alg.offset(tangents[:, :, 0], d[:-1])      # handle next to v_k (segment k)
    tangents[:, :, 1] = alg.offset(tangents[:, :, 1], d[1:])       # handle next to v_{k+1}
    touched = moved[:-1] | moved[1:]                                # (K-1, C) segments to re-measure
    if basis is not None:
        covered = np.zeros_like(touched)
        covered[basis.seg, basis.joint] = True
        inside = touched[basis.seg, basis.joint]
        if (touched & ~covered).any() or inside.sum() < 0.5 * inside.size:
            basis = None              # a static joint moved, or few pairs: re-measure those without it
        else:
            basis = basis.restrict(inside)   # the touched pairs (the others keep their maps exactly)
    if basis is not None:
        seg, col, counts, grid = basis.seg, basis.joint, basis.counts, basis.grid
    else:
        seg, col = np.nonzero(touched)
        counts, grid = ch.counts[seg, col], None
    knots = ch.knots(sm.pose_times)
    C = ch.num_columns

    def target(t, cp, pair, tn):
        # component-first (D, N) arithmetic; the plateau ramps' ends are per (segment, column) pair
        if basis is not None:
            old, wl, wr = basis.old, basis.wl, basis.wr
        else:                                                       # same knots and grid: no search
            old = (_rotations_at(ch, seg[pair] * C + cp, tn) if alg is ROTATION
                   else channel_at(ch, seg[pair], cp, tn).T)
            wl = _pair_plateau_weights(knots, sm.pose_times, seg, col, 1, t, pair)
            wr = _pair_plateau_weights(knots, sm.pose_times, seg + 1, col, -1, t, pair)
        W, N = kern.WORK, t.size            # scratch reused move to move (no fresh page-faulted arrays)
        g = W.get("ex_g", (3, N))
        x = old
        for end, w, tag in ((seg, wl, "ex_a"), (seg + 1, wr, "ex_v")):   # ⊕ w_k δ_k, then ⊕ w_{k+1} δ_{k+1}
            kern.take_cols_into(np.ascontiguousarray(gen[end, col].T), pair, g)
            g *= w
            x = alg.step_rows(x, g, W.get(tag, (alg.dim, N)))
        return x.T

    table = measure(alg, values, tangents, knots, seg, col, counts, target, grid, into=ch.displacements)
    return ch.with_arrays(values=values, tangents=tangents, displacements=table)


def spread_offsets(offsets: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Knot offsets of every pose from the offsets of E edited poses spread by per-pose weights.

    ``offsets (E, J, 4)`` quaternions ``δ_e``, ``weights (E, K)``; pose ``j`` gets ``exp(Σ_e w[e, j] log δ_e)``
    (log maps in each joint's local frame, hemisphere-canonical: Eq. 5 of Dean et al. 2018, §3.3, on the
    staggered knots instead of the frames). A pose whose column is one edit's weight exactly 1 and the others' 0
    gets that ``δ_e`` itself (bit-identical to the edit without spreading); a column of zeros, the identity.
    Returns ``(K, J, 4)``."""
    offsets = np.asarray(offsets, dtype=float)
    w = np.asarray(weights, dtype=float)
    logs = quat_log(quat_hemisphere(offsets))                         # (E, J, 3)
    table = quat_exp(np.einsum("ek,ejc->kjc", w, logs))
    nz = w != 0
    one = (nz.sum(axis=0) == 1) & np.any(w == 1.0, axis=0)            # poses that get one δ_e exactly
    if one.any():
        e = np.argmax(w == 1.0, axis=0)
        table[one] = offsets[e[one]]
    table[~nz.any(axis=0)] = _IDENTITY
    return table


def edit_pose(sm: StaggeredMotion, k: int, deltas=None, *, target=None, mode: str = "staggered",
              joints=None, root_offset=None, weights=None) -> StaggeredMotion:
    """Geometric pose edit of pose ``k`` (§5.1, Figure 6a/b).

    Parameters
    ----------
    sm : StaggeredMotion
    k : int
        Pose index in ``[0, K)``.
    deltas : dict joint name -> rotation, or ndarray (J, 3) / (J, 4), optional
        Per-joint change ``δ``: a rotation vector ``[x, y, z]`` (axis * angle, radians, in the joint's
        local frame) or a quaternion ``[x, y, z, w]``. Applied as ``v̂ = v ⊕ δ`` and ``v̂⁰ = v⁰ ⊕ δ``.
    target : dict joint name -> quaternion (x, y, z, w), or ndarray (J, 4), optional
        New value of the edited knot instead of ``deltas``: the true pose at ``t_k`` (``mode="staggered"``,
        ``δ = target ⊖ v⁰ = v⁰⁻¹ target``) or the non-staggered pose (``mode="unstaggered"``,
        ``δ = target ⊖ v = v⁻¹ target``).
    mode : {"staggered", "unstaggered"}
        Which knot the user edits: the editing knot at the staggered pose time (§5.1, first approach) or
        the extreme value of the non-staggered pose (second approach). The other follows by the same change.
    joints : list of joint names, optional
        Partial pose: only these joints are edited (default: every joint named in ``deltas``/``target``).
    root_offset : [dx, dy, dz], optional
        Change of the root translation knot (file units), with the same plateau treatment.
    weights : array_like (K,), optional
        Propagate the same change to every pose ``j`` with weight ``weights[j]``: ``v̂_j = v_j ⊕ exp(w_j log δ)``
        (and ``v̂⁰_j`` alike; the root offset scaled by ``w_j``), each in that pose's own knots, so every pose keeps
        its staggering and detail. E.g. the magic-wand falloff of pose ``k`` read at the pose times (Dean et al.
        2018, §3.3: one nudge of one step of a walk changes every step); ``weights[k] = 1`` gives pose ``k`` the
        edit itself (bit-identical to the edit without ``weights`` when every other weight is 0). ``δ`` is found
        at pose ``k`` (``target`` is pose ``k``'s new value).

    Returns
    -------
    StaggeredMotion; without ``weights``, motion outside ``(T[k-1, i], T[k+1, i])`` is unchanged for every
    joint ``i``.
    """
    _check(sm)
    k = _pose_index(sm, k)
    if mode not in ("staggered", "unstaggered"):
        raise ValueError(f"mode must be 'staggered' or 'unstaggered', got {mode!r}")
    if (deltas is None) == (target is None) and root_offset is None:
        raise ValueError("give exactly one of deltas= or target= (or only root_offset=)")
    if deltas is not None and target is not None:
        raise ValueError("give exactly one of deltas= or target=")
    J = sm.num_joints
    d = np.tile(_IDENTITY, (J, 1))
    if deltas is not None:
        d, given = _rotation_table(sm, deltas, "deltas")
    elif target is not None:
        tq, given = _rotation_table(sm, target, "target")
        base = sm.editing_knots[k] if mode == "staggered" else sm.values[k]
        d = np.where(given[:, None], quat_mul(quat_conj(base), tq), _IDENTITY)
    mask = _joint_mask(sm, joints)
    d = np.where(mask[:, None], d, _IDENTITY)
    w = _pose_weights(sm, weights)
    if w is None:
        w = np.zeros(sm.num_poses)
        w[k] = 1.0
    full = spread_offsets(d[None], w[None])
    rd = None
    if root_offset is not None:
        ro = np.asarray(root_offset, dtype=float).reshape(-1)
        if ro.shape != (3,) or not np.all(np.isfinite(ro)):
            raise ValueError(f"root_offset must be 3 finite numbers, got {root_offset!r}")
        rd = w[:, None] * ro[None]
    return _apply_pose_offsets(sm, full, rd)


def mean_pose(quats: np.ndarray) -> np.ndarray:
    """Per-joint mean rotation of ``quats (K, J, 4)`` -> ``(J, 4)``: the principal eigenvector of
    ``Σ q qᵀ`` (sign-invariant, Markley et al. 2007)."""
    q = np.asarray(quats, dtype=float)
    M = np.einsum("kja,kjb->jab", q, q)
    _, vecs = np.linalg.eigh(M)
    return quat_hemisphere(vecs[..., -1])


def exaggerate(sm: StaggeredMotion, k, w_r: float, *, reference="previous", mode: str = "staggered",
               joints=None, basis: OffsetBasis | None = None, weights=None) -> StaggeredMotion:
    """Relative exaggeration ``v̂ = v ⊕ w_r (v ⊖ vʳ)`` of pose(s) ``k`` (§5.1).

    Parameters
    ----------
    k : int or list of int
        Pose(s) to exaggerate; several poses are offset together (each against its own reference).
    w_r : float
        Weight of the offset: 0 is the identity, 1 doubles the rotation from the reference, -1 collapses
        onto it. The rotation is scaled (``exp(w_r log(vʳ⁻¹ v))``), not multiplied component-wise.
    reference : "previous" | "next" | "mean" | int | dict joint -> quaternion
        The relative pose ``vʳ``: a neighbouring pose (local exaggeration; the first/last pose uses its
        only neighbour), the mean of all poses (global exaggeration), a pose index, or explicit values.
    mode : {"staggered", "unstaggered"}
        Values that are scaled: editing knots (the true pose at ``t_k``) or extreme values (the
        non-staggered pose); the other knot follows by the same change.
    joints : list of joint names, optional
        Partial pose (default all joints).
    basis : OffsetBasis, optional
        :func:`pose_offset_basis` of ``sm`` (cache it per ``sm``: it does not depend on ``k``, ``w_r``,
        ``reference``, ``mode`` or ``joints``); used when the edit moves at least half of the (segment, joint)
        pairs (e.g. every pose), where it saves a quarter to a third of the work; the same result to rounding.
        A basis of another motion is a ValueError.
    weights : array_like (E, K) (or (K,) for one pose), optional
        Propagate the offsets ``δ_e`` of the E poses ``k`` to every pose: pose ``j`` gets
        ``exp(Σ_e weights[e, j] log δ_e)`` (:func:`spread_offsets`), e.g. each pose's magic-wand falloff read at
        the pose times (Dean et al. 2018, §3.3). Without it each pose in ``k`` gets its own offset, the others none.
    """
    _check(sm)
    w_r = _finite(w_r, "w_r")
    if basis is not None and (not isinstance(basis, OffsetBasis) or not basis.fits(sm)):
        raise ValueError("basis: not a pose_offset_basis of this StaggeredMotion (build it with "
                         "pose_offset_basis(sm) for the sm you exaggerate)")
    if mode not in ("staggered", "unstaggered"):
        raise ValueError(f"mode must be 'staggered' or 'unstaggered', got {mode!r}")
    ks = [k] if isinstance(k, (int, np.integer)) else list(k)
    ks = [_pose_index(sm, kk) for kk in ks]
    spread = _pose_weights(sm, weights, rows=len(ks))
    vals = sm.editing_knots if mode == "staggered" else sm.values
    K, J = sm.num_poses, sm.num_joints
    mask = _joint_mask(sm, joints)
    full = np.tile(_IDENTITY, (K, J, 1))
    at = np.asarray(ks, dtype=np.int64)
    if isinstance(reference, str):
        if reference == "previous":
            refs = vals[np.where(at > 0, at - 1, at + 1)]
        elif reference == "next":
            refs = vals[np.where(at < K - 1, at + 1, at - 1)]
        elif reference == "mean":
            refs = mean_pose(vals)[None]
        else:
            raise ValueError(f"reference must be 'previous', 'next', 'mean', a pose index or a pose, "
                             f"got {reference!r}")
    elif isinstance(reference, (int, np.integer)):
        refs = vals[_pose_index(sm, reference, "reference")][None]
    else:
        rq, given = _rotation_table(sm, reference, "reference")
        refs = np.where(given[None, :, None], rq[None], vals[at])    # joints without a reference value: no change
    # every pose at once (the same element-wise arithmetic as one pose at a time, bit for bit)
    off = quat_hemisphere(quat_mul(quat_conj(refs), vals[at]))              # v ⊖ vʳ
    delta = quat_exp(w_r * quat_log(off))                                    # rotation scale
    full[at] = np.where(mask[None, :, None], delta, _IDENTITY)
    if spread is not None:
        full = spread_offsets(full[ks], spread)
    return _apply_pose_offsets(sm, full, basis=basis)
