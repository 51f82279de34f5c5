"""Runners of the motion ops: frame edits (one at a time and a run of them in one pass), the magic wand's
``propagate`` (Dean et al. 2018), the time warps (guided, Hsu et al. 2007; linear; resampling) and
``guide_poses``, the guided warp read at the staggered pose times. Each is ``(state, op, run) -> state``;
:mod:`.runners` holds the registry.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import _UNIT_TOL, Motion
from ..core.rotations import quat_mul, quat_normalize, rotvec_to_quat
from . import ops as O
from .run import _frame, _joint, _staggered, _timewarp, _wand, apply_pose_deltas

__all__ = ["MAX_WARP_RATIO", "warp_size", "warp_search", "warp_table_key", "warp_k", "even_upsample"]

MAX_WARP_RATIO = 100  # output frames per input frame: far past the papers' 10x slow motion


def _warp_frames(m: Motion, duration: float) -> int:
    """Output frames of a warp to ``duration`` seconds at the input's frame time (at most
    ``MAX_WARP_RATIO`` times the input's frames: an absurd duration must not allocate memory for it)."""
    n = duration / m.frame_time
    if n > MAX_WARP_RATIO * m.num_frames:
        raise ValueError(f"duration: {duration:g} s is more than {MAX_WARP_RATIO} times the input's "
                         f"{m.duration:g} s")
    return max(2, int(round(n)) + 1)


def _edit_frame(m, op: O.EditFrame, run):
    f = _frame(m, op.frame)
    q = np.array(m.local_quats)
    q[f] = apply_pose_deltas(q[f], m.skeleton, op.deltas)
    return m.replace(local_quats=q)


def _edit_frames(m: Motion, ops) -> Motion:
    """A run of ``edit_frame`` ops in one pass, O(F J + n) instead of O(n F J): the deltas of every op are
    turned into quaternions at once, then applied in layers (the t-th rotation of each (frame, joint) in
    layer t, so each joint's rotations compose in op order), each product renormalised as a Motion
    renormalises (only what is off unit); one Motion at the end. A failing op raises ValueError with
    ``offset``, its place in ``ops``."""
    sk, F = m.skeleton, m.num_frames
    rows_f, rows_j, rows_r = [], [], []
    for k, op in enumerate(ops):
        try:
            f = _frame(m, op.frame)
            for name, rv in op.deltas:
                rows_j.append(_joint(sk, name, f"deltas.{name}"))
                rows_f.append(f)
                rows_r.append(rv)
        except ValueError as e:
            e.offset = k
            raise
    q = np.array(m.local_quats)
    if not rows_f:
        return m
    fj = np.asarray(rows_f) * sk.num_joints + np.asarray(rows_j)
    e = rotvec_to_quat(np.radians(np.asarray(rows_r, dtype=float)))
    order = np.argsort(fj, kind="stable")                 # each (frame, joint)'s rows, in op order
    sorted_fj = fj[order]
    start = np.r_[0, np.flatnonzero(np.diff(sorted_fj)) + 1]
    rank = np.empty(len(fj), dtype=int)
    rank[order] = np.arange(len(fj)) - np.repeat(start, np.diff(np.r_[start, len(fj)]))
    flat = q.reshape(F * sk.num_joints, 4)
    for t in range(int(rank.max()) + 1):
        idx = np.flatnonzero(rank == t)
        row = quat_mul(flat[fj[idx]], e[idx])
        off = np.abs(np.sqrt(np.einsum("ji,ji->j", row, row)) - 1.0) > _UNIT_TOL
        if off.any():
            row[off] = quat_normalize(row[off])
        flat[fj[idx]] = row
    return m.replace(local_quats=q)


def _propagate(m, op: O.Propagate, run):
    edits = op.edits
    frames = [_frame(m, f, "frame" if op.frames is None else f"frames[{i}]") for i, (f, _) in enumerate(edits)]
    edited = np.stack([apply_pose_deltas(m.local_quats[f], m.skeleton, d, "deltas") for f, d in edits])
    fr = None if op.frame_range is None else tuple(op.frame_range)
    return _wand().propagate(m, frames if op.frames is not None else frames[0],
                             edited if op.frames is not None else edited[0], frame_range=fr,
                             repetitions=op.repetitions == "keep", basis=run.heads.wand_basis(m, op.sigma))


def warp_search(m: Motion, op: O.GuidedWarp) -> tuple[int | None, int, int]:
    """``(output frames or None for free length, upsampling factor, output step)`` of the search a guided warp
    of ``m`` runs: what :func:`~stagger_nb.timewarp.guided_warp` chooses for the same request. Free length:
    :func:`~stagger_nb.timewarp.free_length_search` (at 120 Hz the input as it is, output frames searched every
    1/30 s: 2,751 searched frames on CMU 01_01 instead of 11,001). A duration: ``required_upsample`` with the
    keytimes, so a keytime that asks for slower than real time upsamples even inside a compression (the
    paper's expansions, §4.1 V3; issue 26: 22.83 s with 2 s -> 1.5 s on CMU 01_01 needs 3). An op's own
    ``upsample`` is kept (output step 1)."""
    tw = _timewarp()
    n = None if op.free_length else _warp_frames(m, op.duration)
    u, step = op.upsample, 1
    if u is None:
        if n is None:
            u, step = tw.free_length_search(m.frame_time)
        else:
            u = tw.required_upsample(m.num_frames, n, keytimes=_pairs(op.keytimes), frame_time=m.frame_time,
                                     skip=op.skip)
            if n == m.num_frames:
                u = max(u, 2)  # same duration: without upsampling the only warp is the identity (§3.1)
    if n is not None and n > (m.num_frames - 1) * u + 1:
        raise ValueError(f"upsample: {u} gives {(m.num_frames - 1) * u + 1} searched frames, fewer than the "
                         f"{n} output frames of duration {op.duration:g} s")
    return n, u, step


def warp_size(m: Motion, op: O.GuidedWarp) -> tuple[int | None, int]:
    """``(output frames or None for free length, upsampling factor)`` of a guided warp of ``m`` (see
    :func:`warp_search`, which also gives the output step)."""
    return warp_search(m, op)[:2]


def warp_table_key(m: Motion, op) -> tuple:
    """``(reference JSON, upsample, backward, k[, output step])``: what chooses a guided warp's tables besides the
    skip (an editor re-warms its skip slider's tables only when this changes). ``op`` is a guided_warp dict or
    op."""
    op = op if isinstance(op, O.GuidedWarp) else O.Op.from_json(dict(op, op="guided_warp"), "op")
    n, u, step = warp_search(m, op)
    return (repr(op.to_json().get("reference")), u, bool(op.backward), warp_k(n)) + ((step,) if step != 1 else ())


def warp_k(num_frames: int | None) -> int:
    """kNN count of a guided warp's tables: ``timewarp.FREE_K`` for free length (``num_frames`` None), else 3."""
    return _timewarp().FREE_K if num_frames is None else 3


def _guided_warp(m, op: O.GuidedWarp, run):
    tw = _timewarp()
    n, u, step = warp_search(m, op)
    p = run.progress
    k = warp_k(n)
    # the tables, then the search (cached per length: a duration slider's step back, or its next step solved
    # ahead in the background, session/warp_steps.py, runs only the smoothing and resampling, §3.4)
    tables, sol = run.heads.warp_solution(m, op.reference, op.skip, u, op.backward, k, step, n, _pairs(op.keytimes), p)
    out, warp = tw.guided_warp(m, tables.reference, n, skip=op.skip, keytimes=_pairs(op.keytimes),
                               upsample=u, reverse=op.backward, k=k, tables=tables, progress=p, solution=sol)
    run.warp = warp
    return out


def even_upsample(n: int, num_frames: int, u: int, most: int = 16) -> int:
    """The upsampling factor of a guided warp of ``n`` input frames to ``num_frames`` near the default ``u``
    (``u - 1 .. u + 1``, at least what the length needs) whose mean step ``(n - 1) u' / (num_frames - 1)``
    upsampled frames per output frame is nearest a whole number: the search's speeds are multiples of ``1 / u'``,
    so a reference timed uniformly (a take played 1.5x slower) is followed at one speed instead of alternating
    two (measured on CMU 131_01, 994 frames to 1491: ``u = 4`` plays 0.75x for 18 s, then 0.25x; ``u = 3``
    plays 0.667x throughout, pose spacings 1.49-1.56x). Ties go to the default."""
    need = max(1, -(-(num_frames - 1) // (n - 1)))

    def off(c):  # distance of the mean step from a whole number of upsampled frames
        step = (n - 1) * c / (num_frames - 1)
        return abs(step - round(step))
    best = min(range(max(need, u - 1), min(most, u + 1) + 1), key=lambda c: (round(off(c), 9), c != u, c))
    if num_frames == n:
        best = max(best, 2)        # same duration: without upsampling the only warp is the identity (§3.1)
    return best


def _guide_poses(sm, op: O.GuidePoses, run):
    """The pose times ``t_k`` of ``sm`` mapped through the guided warp of ``run.origin`` (the motion the poses
    were extracted from) to the reference: ``t̂_k = W⁻¹(t_k)`` with ``W`` the warp (output time -> input time,
    Hsu et al. 2007), then ``staggered.retime`` (§5.2): refinements, splines and displacement maps follow."""
    tw = _timewarp()
    origin = run.origin
    reference = run.heads.reference(op.reference)
    wop = op.warp_op(reference.duration)
    n, u, step = warp_search(origin, wop)
    if n is not None and op.upsample is None:
        u = even_upsample(origin.num_frames, n, u)
    k = warp_k(n)
    p = run.progress
    tables = run.heads.warp_tables(origin, wop.reference, wop.skip, u, False, k,
                                   None if p is None else (lambda f: p(0.9 * f)), out_step=step)
    _, warp = tw.guided_warp(origin, tables.reference, n, skip=wop.skip, keytimes=_pairs(wop.keytimes),
                             upsample=u, k=k, tables=tables, progress=p)
    run.warp = warp
    t = np.asarray(sm.pose_times, dtype=float)
    end = origin.duration
    if t[-1] > end + 1e-9 or t[0] < -1e-9:
        raise ValueError(f"the pose times run over [{t[0]:g}, {t[-1]:g}] s, outside the {end:g} s the warp maps "
                         "(an op before this one stretched them; guide the poses before retiming them)")
    xs, inverse = np.unique(np.maximum.accumulate(warp), return_inverse=True)
    out_times = np.arange(warp.size) * origin.frame_time
    ys = np.bincount(inverse, out_times) / np.bincount(inverse)   # a pause in the warp: its middle
    new = np.interp(t, xs, ys)
    if not np.all(np.diff(new) > 0):
        bad = int(np.argmin(np.diff(new)))
        raise ValueError(f"the warp plays poses {bad} and {bad + 1} at the same time ({new[bad]:.4f} s); "
                         "a smaller skip or more keytimes keep them apart")
    return _staggered().retime(sm, new)


def _pairs(keytimes):
    return None if keytimes is None else [list(p) for p in keytimes]


def _linear_warp(m, op: O.LinearWarp, run):
    out, warp = _timewarp().linear_warp(m, _warp_frames(m, op.duration), keytimes=_pairs(op.keytimes))
    run.warp = warp
    return out


def _resample(m, op: O.Resample, run):
    if m.duration / op.frame_time > MAX_WARP_RATIO * m.num_frames:
        raise ValueError(f"frame_time: {op.frame_time:g} s gives more than {MAX_WARP_RATIO} times the "
                         f"input's {m.num_frames} frames")
    return m.resample(op.frame_time)
