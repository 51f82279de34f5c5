"""The one evaluator of a staggered-pose motion: ``v_c(t) = s_c(t') ⊕ d_c(t')`` (Coleman et al. 2008, §3).

:func:`channel_at` evaluates any :class:`~.channel.Channel` at (segment, column, normalised time) samples: the
spline of the channel's algebra, the displacement map's linear interpolation on its normalised-time grid, and
``⊕``. For rotations the three are fused in one kernel (``_kernels``, with the C kernel ``_cspline.c`` behind it
where built). The segment coordinates of a time come from :func:`segment_coordinates` (every column at the same
times: a grid of frames) or :func:`pair_coordinates` (one column per sample). Everything else here is that
evaluator at given times: :func:`evaluate` (a :class:`~.representation.StaggeredMotion` sampled as a
:class:`~stagger_nb.core.Motion`), :func:`evaluate_arrays`, :func:`evaluate_samples`, :func:`root_positions_at`.
Notation as in :mod:`.representation`.
"""
from __future__ import annotations

import weakref

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_exp, quat_mul
from . import _kernels as K
from .channel import ROTATION, TRANSLATION, Channel, bezier_cubic
from .representation import StaggeredMotion, default_times, knot_times
from .segments import pair_coordinates, segment_coordinates

__all__ = ["evaluate", "evaluate_arrays", "evaluate_samples", "root_positions_at", "channel_at", "channel_at_times",
           "segment_coordinates", "pair_coordinates", "displacement_at", "rotation_spline", "translation_spline",
           "bezier_cubic", "translation_source_times", "static_rotations"]


def rotation_spline(c0, c1, c2, c3, t) -> np.ndarray:
    """Quaternion Bézier ``s(c0, c1, c2, c3, t)`` by recursive slerp (Appendix A, [Sho85]): the rotation
    algebra's spline. Same curve as :func:`stagger_nb.core.rotations.quat_bezier` (up to sign), computed
    component-first. Control quaternions ``(N, 4)`` (x, y, z, w), ``t (N,)`` in [0, 1]; returns unit ``(N, 4)``.
    """
    return ROTATION.spline(c0, c1, c2, c3, t)


def translation_spline(p0, p1, p2, p3, t) -> np.ndarray:
    """Cubic Bézier of the root translation: the translation algebra's spline (:func:`bezier_cubic`)."""
    return TRANSLATION.spline(p0, p1, p2, p3, t)


def displacement_at(table: np.ndarray, counts: np.ndarray, t: np.ndarray, rows=None) -> np.ndarray:
    """Linear interpolation of displacement maps on their uniform ``t'`` grids.

    Parameters
    ----------
    table : (R, M, D) or (K - 1, C, M, D) samples (rows padded past their counts)
    counts : (N,) valid samples of each sample's row (>= 2)
    t : (N,) normalised times in [0, 1]
    rows : (N,) int, or a tuple of (N,) int arrays (e.g. ``(seg, col)``), optional
        Row of ``table`` of each sample; default ``arange(N)`` (``table`` holds one row per sample). Passing
        the rows gathers only the two table entries each sample reads, instead of a copy ``table[rows]`` of
        whole rows (N x M x D: megabytes on a long segment).

    Returns
    -------
    (N, D) displacement values.
    """
    u = np.clip(t, 0.0, 1.0) * (counts - 1)
    m0 = np.minimum(np.floor(u).astype(np.int64), counts - 2)
    a = (u - m0)[:, None]
    if rows is None:
        rows = np.arange(table.shape[0])
    index = rows if isinstance(rows, tuple) else (rows,)
    return table[index + (m0,)] * (1.0 - a) + table[index + (m0 + 1,)] * a


def channel_at(ch: Channel, seg: np.ndarray, col: np.ndarray, tn: np.ndarray) -> np.ndarray:
    """``s(t') ⊕ d(t')`` of channel ``ch`` at samples of segment ``seg (N,)``, column ``col (N,)`` and
    normalised time ``tn (N,)``: ``(N, D)`` values (quaternions x, y, z, w, or translations)."""
    seg = np.asarray(seg, dtype=np.int64)
    col = np.asarray(col, dtype=np.int64)
    if ch.algebra is ROTATION:          # spline, displacement and product fused in the rotation kernel
        return np.array(_rotations_at(ch, seg * ch.num_columns + col, tn).T)
    tg = ch.tangents[seg, col]
    s = ch.algebra.spline(ch.values[seg, col], tg[:, 0], tg[:, 1], ch.values[seg + 1, col], tn)
    return ch.algebra.compose(s, displacement_at(ch.displacements, ch.counts[seg, col], tn, (seg, col)))


def channel_at_times(ch: Channel, pose_times: np.ndarray, times, cols) -> np.ndarray:
    """:func:`channel_at` of column ``cols[n]`` at ``times[n]`` seconds (scattered samples, N of each)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    cols = np.broadcast_to(np.asarray(cols, dtype=np.int64).reshape(-1), times.shape)
    seg, tn = pair_coordinates(ch.knots(pose_times), times, cols)
    return channel_at(ch, seg, cols, tn)


_GATHER_MAX = 4096   # samples up to which the rotation kernel gathers per sample (no per-pair set-up of the table)


#: a pair whose displacement samples turn more than this (radians) is "wide": between its samples the
#: displacement is interpolated on the quaternions (nlerp), not on the rotation vectors (see _wide_pairs)
_WIDE_ANGLE = np.pi
_WIDE = weakref.WeakKeyDictionary()


def _wide_pairs(ch: Channel) -> np.ndarray | None:
    """Indices (segment-major ``k * C + c``) of the pairs of rotation channel ``ch`` whose displacement samples
    turn more than :data:`_WIDE_ANGLE` (once per channel; None when there is none, the usual case).

    Displacements are unwrapped along each pair (``displacement_rotvecs``: angles in [0, 2 pi)), so linear
    interpolation never jumps across pi; but near a full turn the exponential map folds (every rotation
    vector of length 2 pi is the identity): two neighbouring samples that are close as rotations can be far
    apart as vectors, and the vector half-way between them is a large rotation. Seen in a browser review: cull
    95 %, s 0.05, tau 0.05, w_r 0.5 on CMU 01_01 gave a one-frame 149 degree pop of LeftForeArm."""
    if ch in _WIDE:
        return _WIDE[ch]
    d = ch.displacements
    wide = None
    if d.size:
        big = np.flatnonzero((np.einsum("pcmx,pcmx->pcm", d, d) > _WIDE_ANGLE ** 2).any(axis=2).reshape(-1))
        wide = big if big.size else None
    _WIDE[ch] = wide
    return wide


def _wide_fix(ch: Channel, idx: np.ndarray, t: np.ndarray, out: np.ndarray) -> None:
    """Re-evaluate, in place in ``out (4, n)``, the samples of wide pairs (:func:`_wide_pairs`) with their
    displacement interpolated on the quaternions: ``s(t') ⊕ nlerp(exp d_m, exp d_m+1; a)``, the same value at
    every displacement sample (a = 0) and a short arc between them."""
    wide = _wide_pairs(ch)
    if wide is None:
        return
    sel = np.flatnonzero(np.isin(idx, wide))
    if not sel.size:
        return
    C = ch.num_columns
    seg, col = np.divmod(idx[sel], C)
    ts = t[sel]
    s = ROTATION.spline(ch.values[seg, col], ch.tangents[seg, col, 0], ch.tangents[seg, col, 1],
                        ch.values[seg + 1, col], ts)
    cnt = ch.counts[seg, col]
    u = ts * (cnt - 1)
    m0 = np.minimum(u.astype(np.int64), cnt - 2)
    a = (u - m0)[:, None]
    e0 = quat_exp(0.5 * ch.displacements[seg, col, m0])
    e1 = quat_exp(0.5 * ch.displacements[seg, col, m0 + 1])
    e1 = np.where(np.sum(e0 * e1, axis=1, keepdims=True) < 0, -e1, e1)
    e = e0 + a * (e1 - e0)
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    out[:, sel] = quat_mul(s, e).T


def _rotations_at(ch: Channel, idx: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = _rotations_at_linear(ch, idx, t)
    _wide_fix(ch, np.ascontiguousarray(idx, dtype=np.int64), np.ascontiguousarray(t, dtype=float), out)
    return out


def _rotations_at_linear(ch: Channel, idx: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Rotations ``s(t') ⊕ d(t')`` of (segment, column) pairs ``idx (n,)`` (segment-major ``k * C + c``) of a
    rotation channel at normalised times ``t (n,)``, as a (4, n) view of workspace memory (valid until the
    next call). Up to ``_GATHER_MAX`` samples each one's controls and displacement samples are gathered
    directly (the K x J editing knots of an edit); more go through the per-pair tables (control polygons and
    their first-level arcs once per pair; the C kernel where built, the same operations as the numpy path)."""
    W = K.WORK
    n = t.size
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    t = np.ascontiguousarray(t, dtype=float)
    out = W.get("ev_q", (4, n))
    C = ch.num_columns
    if n <= _GATHER_MAX:
        seg, col = np.divmod(idx, C)
        c = W.get("ev_c", (16, n))
        c[0:4] = ch.values[seg, col].T
        tg = ch.tangents[seg, col]
        c[4:8] = tg[:, 0].T
        c[8:12] = tg[:, 1].T
        c[12:16] = ch.values[seg + 1, col].T
        arc = W.get("ev_arc", (9, n))
        _arcs_into(c, arc, n)
        d = ch.displacements

        def take(m0, shift, buf):
            buf[...] = d[seg, col, m0 + shift].T
            return buf
        return _rotations_block(c, arc, ch.counts[seg, col], t, take, out)
    P = ch.tangents.shape[0] * C
    # per-pair control polygons (4 controls x 4 components, P) and their three fixed first-level arcs
    ctrl = W.get("ev_ctrl", (16, P))
    ctrl[0:4] = ch.values[:-1].reshape(P, 4).T
    ctrl[4:8] = ch.tangents[:, :, 0].reshape(P, 4).T
    ctrl[8:12] = ch.tangents[:, :, 1].reshape(P, 4).T
    ctrl[12:16] = ch.values[1:].reshape(P, 4).T
    arcp = W.get("ev_arcp", (9, P))
    _arcs_into(ctrl, arcp, P, "ev_p")
    M = ch.displacements.shape[2]
    table = W.get("ev_table", (3, P * M))
    table[...] = ch.displacements.reshape(P * M, 3).T
    counts = np.ascontiguousarray(ch.counts.reshape(-1), dtype=np.int64)
    block = 4 * K.CHUNK                          # blocks bound the scratch; larger ones make fewer numpy calls
    for s0 in range(0, n, block):
        s1 = min(n, s0 + block)
        # the C kernel where built (same bits), else (or for a wide-angle displacement) numpy
        if not K.rotations_block_c(ctrl, arcp, table, counts, M, idx[s0:s1], t[s0:s1], out, s0, W):
            ib = idx[s0:s1]

            def take(m0, shift, buf, ib=ib):
                return K.take_cols_into(table, m0 + ib * M + shift, buf)
            bn = s1 - s0
            _rotations_block(K.take_cols_into(ctrl, ib, W.get("ev_c", (16, bn))),
                             K.take_cols_into(arcp, ib, W.get("ev_arc", (9, bn))), counts[ib], t[s0:s1], take,
                             out[:, s0:s1])
    return out


def _arcs_into(ctrl, arc, n, tag="ev_"):
    """The three first-level arcs ``arc (9, n)`` of the control polygons ``ctrl (16, n)``."""
    W = K.WORK
    for j in range(3):
        K.arc_into(ctrl[4 * j:4 * j + 4], ctrl[4 * j + 4:4 * j + 8], arc[3 * j:3 * j + 3],
                   W.get(tag + "tmp", n), W.get(tag + "tmp2", n))


def _rotations_block(c, arc, cnt, t, take, out):
    """``s(t') ⊕ d(t')`` into ``out (4, n)`` from the samples' controls ``c (16, n)``, first-level arcs
    ``arc (9, n)``, displacement counts ``cnt (n,)`` and normalised times ``t (n,)``; ``take(m0, shift, buf)``
    writes the displacement samples ``m0 + shift`` of each sample's map into ``buf (3, n)``."""
    W = K.WORK
    n = t.size
    s = K.bezier_into(c[0:4], c[4:8], c[8:12], c[12:16], t, (arc[0:3], arc[3:6], arc[6:9]), tag="ev_",
                      normalize=False)   # unit to ~1e-15; Motion() renormalises what is not unit
    # displacement: linear interpolation of rotation vectors on each pair's uniform t' grid
    u = np.multiply(t, cnt - 1, out=W.get("ev_u", n))
    m0 = np.minimum(u.astype(np.int64), cnt - 2)
    a = u
    a -= m0                                                         # fractional position
    d0 = take(m0, 0, W.get("ev_d0", (3, n)))
    d1 = take(m0, 1, W.get("ev_d1", (3, n)))
    d1 -= d0
    d1 *= a
    d0 += d1
    d0 *= 0.5                                                       # half rotation vectors for exp
    e = K.qexp_into(d0, W.get("ev_e", (4, n)), W.get("ev_h", n), W.get("ev_tmp", n))
    return K.qmul_into(s, e, out, W.get("ev_tmp", n))


def root_positions_at(sm: StaggeredMotion, times) -> np.ndarray:
    """Root translation ``s(t') + d(t')`` at ``times (N,)`` seconds, shape (N, 3) (segment coordinates as
    :func:`evaluate`'s, so a frame reads the same bits here and there)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    seg, tn = segment_coordinates(sm.translation.knots(sm.pose_times), times)
    return channel_at(sm.translation, seg[:, 0], np.zeros(times.size, np.int64), tn[:, 0])


def evaluate_samples(sm: StaggeredMotion, times, joints) -> np.ndarray:
    """Local rotation of joint ``joints[n]`` at ``times[n]`` seconds for every n: ``(N, 4)`` (x, y, z, w).

    The same formula as :func:`evaluate`, for scattered (time, joint) samples (the editing knots of an edit,
    refits after edits)."""
    return channel_at_times(sm.rotations, sm.pose_times, times, joints)


def static_rotations(sm: StaggeredMotion):
    """``(J,) bool, (J, 4)``: joints whose rotation is one quaternion throughout (every knot and control
    equal to the first knot, the displacement map zero: the spline of equal controls is that quaternion),
    and each joint's first knot ``values[0]``."""
    return sm.rotations.static_columns()


def evaluate_arrays(sm: StaggeredMotion, times: np.ndarray):
    """Local rotations ``(N, J, 4)`` and root positions ``(N, 3)`` of ``sm`` at ``times (N,)`` seconds.

    Vectorised over all (time, joint) samples; scratch memory is reused between calls (see ``_kernels``).
    """
    q, p = _evaluate_arrays(sm, times)
    return np.array(q), p


def _evaluate_arrays(sm: StaggeredMotion, times: np.ndarray):
    """:func:`evaluate_arrays` returning, for ``q``, a view of workspace memory (valid until the next call)
    or a new array. Static joints (:func:`static_rotations`, e.g. 6 of CMU's 31) are their quaternion
    exactly, without evaluating the spline (which returns it to ~1e-16)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    J, N = sm.num_joints, times.size
    static, c = static_rotations(sm)
    if not static.any():
        seg, tn = segment_coordinates(knot_times(sm), times)          # (N, J)
        idx = seg.reshape(-1) * J + np.tile(np.arange(J), N)         # pair index (segment-major)
        return _rotations_at(sm.rotations, idx, tn.reshape(-1)).T.reshape(N, J, 4), root_positions_at(sm, times)
    mov = np.flatnonzero(~static)
    q = np.empty((N, J, 4))
    q[:, static] = c[static]
    if mov.size:
        seg, tn = segment_coordinates(knot_times(sm)[:, mov], times)  # (N, moving joints)
        idx = seg.reshape(-1) * J + np.tile(mov, N)
        q[:, mov] = _rotations_at(sm.rotations, idx, tn.reshape(-1)).T.reshape(N, mov.size, 4)
    return q, root_positions_at(sm, times)


def _sample_translations(lt: np.ndarray, frame_time: float, times: np.ndarray) -> np.ndarray:
    f = np.clip(times / frame_time, 0.0, lt.shape[0] - 1)
    r = np.rint(f)
    f = np.where(np.abs(f - r) < 1e-9, r, f)          # frame times read their frame bit-for-bit
    i0 = np.minimum(np.floor(f).astype(np.int64), lt.shape[0] - 1)
    i1 = np.minimum(i0 + 1, lt.shape[0] - 1)
    a = (f - i0)[:, None, None]
    return lt[i0] * (1.0 - a) + lt[i1] * a


def translation_source_times(sm: StaggeredMotion, times) -> np.ndarray:
    """Source times ``(N,)`` at which ``sm.local_translations`` are read for evaluation ``times (N,)``
    seconds: piecewise linear from the root-translation knots ``pose_times + root_refinements`` to
    ``sm.translation_times`` (identity when that is None)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    if sm.translation_times is None:
        return times
    seg, tn = segment_coordinates(sm.translation.knots(sm.pose_times), times)
    tt = sm.translation_times
    a, b = tt[seg[:, 0]], tt[seg[:, 0] + 1]
    return a + tn[:, 0] * (b - a)


_MAX_SAMPLES = 20_000_000    # (time, joint) samples evaluate() accepts (~155 B each while evaluating: ~3 GB)


def _check_size(n: int, sm: StaggeredMotion):
    if n * sm.num_joints > _MAX_SAMPLES:
        raise ValueError(f"evaluate: {n} times x {sm.num_joints} joints exceed {_MAX_SAMPLES} samples (~3 GB "
                         f"while evaluating; frame_time {sm.frame_time!r} s): evaluate slices of the time range "
                         f"(times=...) one at a time")


def evaluate(sm: StaggeredMotion, times=None) -> Motion:
    """Evaluate a staggered-pose motion: ``v_i(t) = s_i(t') ⊕ d_i(t')`` for every joint (§3).

    Parameters
    ----------
    sm : StaggeredMotion
    times : array_like, shape (N,), seconds, optional
        Absolute times to sample. Default :func:`default_times` (``t_0, t_0 + frame_time, ... <= t_{K-1}``),
        which for an unedited extraction are exactly the source frames.

    Returns
    -------
    Motion with N frames, ``frame_time = sm.frame_time`` (or the spacing of uniform ``times``), its
    ``staggered`` = ``sm`` on the default times (what :func:`stagger_nb.quality.compare` carries contacts by);
    the source's ``local_translations`` (if any) are sampled at :func:`translation_source_times` (retimed with
    the root translation; the same absolute times for an unedited extraction).
    """
    if not isinstance(sm, StaggeredMotion):
        raise ValueError(f"evaluate: sm must be a StaggeredMotion, got {type(sm).__name__}")
    own = times is None
    if own:
        _check_size(int(np.floor(sm.duration / sm.frame_time + 1e-6)) + 1, sm)
        times = default_times(sm)
        ft = sm.frame_time
    else:
        times = np.asarray(times, dtype=float).reshape(-1)
        _check_size(times.size, sm)
        if times.size == 0 or not np.all(np.isfinite(times)):
            raise ValueError("evaluate: times must be a non-empty array of finite seconds")
        dt = np.diff(times)
        ft = float(dt[0]) if dt.size and dt[0] > 0 and np.allclose(dt, dt[0]) else sm.frame_time
    q, p = _evaluate_arrays(sm, times)
    lt = None
    if sm.local_translations is not None:
        lt = _sample_translations(sm.local_translations, sm.frame_time, translation_source_times(sm, times))
    # arrays computed here from a valid representation: the trusted constructor (no re-validation); q may
    # be workspace memory, so the Motion gets its own copy
    return Motion._trusted(sm.skeleton, ft, p, np.array(q), lt, staggered=sm if own else None)
