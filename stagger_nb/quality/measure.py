"""The edit's figures: :func:`compare` (an edited motion against its source, the carried contacts, an
optional baseline)."""
from __future__ import annotations

import numpy as np

from ..core.kinematics import _to_component_major
from ..core.motion import Motion
from .arrays import (
    _fk_cm,
    _fk_rows,
    _fractional,
    _height_rows,
    _largest_angles,
    _norms2,
    _read_positions,
    _segments,
    _slerp_cm,
    _step_angles,
    _step_lengths,
    _travels,
)
from .bounds import Bounds, _bounds, _positive
from .constants import _ROUNDING, BODY_CM, SOURCE_SHRINK
from .detail import _carried, _detail_energies, _warp, _warp_table
from .inputs import _as_motion, _check_contacts, _finite_motion, _positions_arg, _same_rig
from .report import ContactFigures, QualityReport
from .source import SourceFigures, prepare


def _on_timeline(sm, source: Motion) -> bool:
    """Whether ``sm`` (a Motion's ``staggered``) is an edit of a motion on ``source``'s timeline: the same frame
    time, its poses' source times spanning ``source`` (an extraction's first and last poses are the first and
    last frames). A staggered motion extracted from a retimed copy (a warp before the staggered ops) is not."""
    if sm is None:
        return False
    from ..staggered.source_times import source_pose_times
    ft = source.frame_time
    if abs(sm.frame_time - ft) > 1e-9 * ft:
        return False
    sp = source_pose_times(sm)
    return bool(sp.size) and abs(float(sp[0])) <= 0.5 * ft and abs(float(sp[-1]) - source.duration) <= 0.5 * ft


def compare(source: Motion, edited, *, staggered=None, contacts=None, baseline=None, bounds=None,
            body_height: float | None = None, source_positions: np.ndarray | None = None,
            prepared: SourceFigures | None = None, edited_positions: np.ndarray | None = None,
            baseline_positions: np.ndarray | None = None) -> QualityReport:
    """Measure what an edit did to ``source`` (definitions: :mod:`stagger_nb.quality`).

    Parameters
    ----------
    source : Motion
        The unedited motion.
    edited : Motion or StaggeredMotion
        The edited motion (a StaggeredMotion is evaluated, and is then also ``staggered`` by default).
    staggered : StaggeredMotion, optional
        The edited StaggeredMotion: its time warps carry the contacts, its knots are checked for order.
        Default: ``edited.staggered`` (a Motion from ``staggered.evaluate``, ``keep_contacts`` or a Session whose
        last op is a staggered one knows it) where it edits a motion on ``source``'s timeline. Without one, the
        contacts stay on their frames and ``knots_out_of_order`` is None.
    contacts : list of (joint_name, start_frame, stop_frame), optional
        Source contacts, half-open source frames; default ``prepared.contacts``, else
        ``staggered.detect_contacts(source)``.
    baseline : Motion or StaggeredMotion, optional
        The same edit without the contact layer: ``pelvis_vs_baseline`` and ``baseline_foot_travel`` are
        measured against it.
    bounds : "mild" | "moderate" | "strong" | "unedited" | Bounds | dict, optional
        What :attr:`QualityReport.failures` checks (default ``"mild"``; a dict overrides fields of its
        ``"preset"``, e.g. ``{"preset": "strong", "pop": 8}``).
    body_height : float, optional
        The source's body height in file units (default ``prepared.body_height``, else :func:`body_height`).
    source_positions : ndarray (F, J, 3), optional
        ``forward_kinematics(source)[0]`` when the caller has it (the same figures, one FK fewer; not read
        with ``prepared``).
    prepared : SourceFigures, optional
        :func:`prepare` of ``source``: the source's figures, computed once for any number of edits (the
        same report, bit for bit).
    edited_positions, baseline_positions : ndarray (F_edited, J, 3), optional
        ``forward_kinematics(edited)[0]`` / ``(baseline)[0]`` when the caller has them (the baseline's is
        otherwise computed for the pelvis and the contact joints' chains only).

    Returns
    -------
    QualityReport (frozen): the figures, per-contact and per-joint detail, ``.summary``, ``.items``, ``.ok``,
    ``.failures``, ``.to_dict()``.
    """
    from .. import staggered as stg
    if not isinstance(source, Motion):
        raise ValueError(f"source must be a Motion, got {type(source).__name__}")
    if prepared is None:
        prepared = prepare(source, contacts=contacts, body_height=body_height, source_positions=source_positions)
        contacts = body_height = None
    elif not isinstance(prepared, SourceFigures):
        raise ValueError(f"prepared must be quality.prepare(source), got {type(prepared).__name__}")
    elif prepared.source is not source:
        raise ValueError("prepared: computed for another source motion (use quality.prepare(source) of this one)")
    motion, sm = _as_motion(edited, "edited")
    if staggered is None and sm is None and _on_timeline(motion.staggered, source):
        sm = motion.staggered          # the evaluation (or contact layer) of a staggered motion: its timing
    if staggered is not None:
        if not isinstance(staggered, stg.StaggeredMotion):
            raise ValueError(f"staggered must be a StaggeredMotion, got {type(staggered).__name__}")
        sm = staggered
    _same_rig(source, motion, "edited")
    _finite_motion(motion, "edited")
    if sm is not None:
        _same_rig(source, sm, "staggered")
    base = None
    if baseline is not None:
        base, _ = _as_motion(baseline, "baseline")
        _same_rig(source, base, "baseline")
        _finite_motion(base, "baseline")
    elif baseline_positions is not None:
        raise ValueError("baseline_positions: given without a baseline")
    bnds = _bounds(bounds)
    contacts = prepared.contacts if contacts is None else _check_contacts(source, contacts)
    if body_height is None:
        scale, h_body = prepared.scale, prepared.body_height
    else:
        h_body = _positive(body_height, "body_height")
        scale = BODY_CM / h_body
    if edited_positions is None:
        Pe, Qe = _fk_cm(motion)
    else:
        Pe, Qe = _positions_arg(edited_positions, motion, "edited_positions"), _to_component_major(motion.local_quats)
    return _measure(prepared, motion, sm, Pe, Qe, base, baseline_positions, contacts, scale, h_body, bnds)


def _measure(prep: SourceFigures, motion: Motion, sm, Pe: np.ndarray, Qe: np.ndarray, base, base_positions,
             contacts: tuple, scale: float, h_body: float, bnds: Bounds) -> QualityReport:
    """The figures of :func:`compare` from the source's (``prep``) and the edit's FK ``Pe (3, J, F)`` and
    rotations ``Qe (4, J, F)``."""
    src, sk, up = prep.source, prep.source.skeleton, prep.up
    names = sk.names
    Fs, J, F = src.num_frames, src.num_joints, motion.num_frames
    Ps = prep._P
    ft_s, ft_e = src.frame_time, motion.frame_time
    t0 = float(sm.pose_times[0]) if sm is not None else 0.0
    tables, table = _warp_table(sm)
    te = t0 + np.arange(F) * ft_e
    n_in = int(np.searchsorted(te, src.duration + 0.5 * ft_s + 1e-9, side="right"))   # frames the source covers
    # the source at the same times (te increasing: the covered frames are the first n_in)
    i0, i1, w = _fractional(te[:n_in] / ft_s, Fs)
    same_frames = not w.any() and np.array_equal(i0, np.arange(n_in))
    if same_frames:
        src_at, q_src = Ps[:, :, :n_in], prep._Q[:, :, :n_in]
    else:
        src_at, q_src = Ps[:, :, i0], prep._Q[:, :, i0]
        frac = w > 0
        if frac.any():
            wf = w[frac]
            src_at[:, :, frac] = Ps[:, :, i0[frac]] * (1 - wf) + Ps[:, :, i1[frac]] * wf
            q_src[:, :, frac] = _slerp_cm(prep._Q[:, :, i0[frac]], prep._Q[:, :, i1[frac]],
                                          np.broadcast_to(wf, (J, wf.size)))

    # whole-body figures
    if n_in:
        moved_j = np.sqrt(_norms2(Pe[:, :, :n_in] - src_at).max(axis=1))
        rotated = float(_largest_angles(q_src, Qe[:, :, :n_in]).max())
    else:
        moved_j, rotated = np.zeros(J), 0.0
    mj = int(np.argmax(moved_j))
    pel = prep.pelvis
    He = _height_rows(Pe, up)                                                     # (J, F)
    if table is None:
        dpel = He[pel, :n_in] - _height_rows(src_at[:, pel], up)
    else:
        # a retimed pelvis is judged against the source pelvis on its own clock (the root translation's, which
        # carries its height): a timing edit alone changes no height, what is left is the edit's (the layer's)
        ts = _warp(table, J, te, inverse=True) / ft_s
        inside = (ts >= 0) & (ts <= Fs - 1)
        rows = _read_positions(Ps, np.full(int(inside.sum()), pel), ts[inside])
        dpel = He[pel, inside] - _height_rows(rows, up)
    pelvis = float(np.abs(dpel).max()) * scale if dpel.size else 0.0
    pelvis_drop = float(max(-dpel.min(), 0.0)) * scale if dpel.size else 0.0
    pelvis_vs_base = pelvis_base_drop = None
    Pb = None
    if base is not None:
        if base_positions is not None:
            Pb = _positions_arg(base_positions, base, "baseline_positions")
        else:
            Pb = _fk_rows(base, sorted({pel} | {sk.index(c[0]) for c in contacts}))   # (NaN elsewhere)
        n = min(base.num_frames, F)
        db = He[pel, :n] - _height_rows(Pb[:, pel, :n], up)
        pelvis_vs_base = float(np.abs(db).max()) * scale if n else 0.0
        pelvis_base_drop = float(max(-db.min(), 0.0)) * scale if n else 0.0
    floor_pen = max(prep.floor - float(He.min()), 0.0) * scale

    ratio = ft_s / ft_e
    pop_added = np.maximum(_step_angles(Qe) * ratio - prep.step_angles, 0.0)
    pop_added[pop_added < _ROUNDING] = 0.0            # a frame-rate ratio's rounding is no pop (nor a joint)
    pj = int(np.argmax(pop_added))
    jump_added = np.maximum(_step_lengths(Pe) * ratio - prep.step_lengths, 0.0) * scale
    jump_added[jump_added < _ROUNDING] = 0.0
    jj = int(np.argmax(jump_added))
    e_e, e_s = _detail_energies(prep, Qe, ft_e, table, t0)
    total_s = float(e_s.sum())
    detail = float(e_e.sum()) / total_s if total_s > 0 else 1.0
    # per joint; a joint still in the source (energy at rounding level: 1e-12 of the mean) reads 1 when it
    # stays still, else its energy over that floor
    tiny = max(1e-12 * total_s / max(e_s.size, 1), 1e-300)
    detail_j = np.where(e_s > tiny, e_e / np.maximum(e_s, tiny), np.where(e_e > tiny, e_e / tiny, 1.0))

    knots_bad = None
    if sm is not None:
        T = np.concatenate([sm.knot_times(), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)
        bad = ~np.all(np.diff(T, axis=0) > 0, axis=0)
        knots_bad = tuple((list(names) + ["<root translation>"])[c] for c in np.flatnonzero(bad))

    figures = _contact_figures(prep, contacts, sm, tables, table, Pe, He, Pb, te, F, base, scale)
    in_src, in_src_raw = _source_interval_travel(prep, contacts, Pe, te, scale)

    def worst(attr):
        return max((getattr(c, attr) for c in figures), default=0.0)

    base_travel = None if base is None else max((c.baseline_travel for c in figures), default=0.0)
    return QualityReport(
        scale=scale, body_height=h_body,
        foot_travel=worst("travel"), foot_travel_raw=worst("travel_raw"), foot_path=worst("path"),
        foot_height=worst("height"), foot_travel_source=in_src, foot_travel_source_raw=in_src_raw,
        floor=floor_pen, pelvis=pelvis, pelvis_drop=pelvis_drop, pelvis_vs_baseline=pelvis_vs_base,
        added_pop=float(pop_added[pj]), added_pop_joint=names[pj] if pop_added[pj] > 0 else None,
        added_jump=float(jump_added[jj]), added_jump_joint=names[jj] if jump_added[jj] > 0 else None,
        moved=float(moved_j[mj]) * scale, moved_joint=names[mj] if moved_j[mj] > 0 else None,
        rotated=rotated, knots_out_of_order=knots_bad, detail=detail, baseline_foot_travel=base_travel,
        contacts=tuple(figures), joints=tuple(names), pop_added=tuple(pop_added.tolist()),
        jump_added=tuple(jump_added.tolist()), detail_by_joint=tuple(detail_j.tolist()),
        bounds=bnds, pelvis_vs_baseline_drop=pelvis_base_drop)


def _contact_figures(prep, contacts, sm, tables, table, Pe, He, Pb, te, F, base, scale) -> list:
    """One :class:`ContactFigures` per contact carried onto at least one frame, all contacts at once."""
    sk = prep.source.skeleton
    if sm is not None:
        carried, clocks = _carried(sm, contacts, prep.source.frame_time, tables)
    else:
        carried, clocks = [(a, b) for _, a, b in contacts], [sk.index(c[0]) for c in contacts]
    kept = [(c, a, min(b, F), k) for c, ab, k in zip(contacts, carried, clocks) if ab is not None
            for a, b in [ab] if min(b, F) > a]
    if not kept:
        return []
    first = np.array([a for _, a, _, _ in kept], dtype=np.int64)
    lengths = np.array([b for _, _, b, _ in kept], dtype=np.int64) - first
    starts, owner = _segments(lengths)
    frames = np.arange(owner.size) + np.repeat(first - starts, lengths)
    joints = np.repeat([sk.index(c[0]) for c, _, _, _ in kept], lengths)
    by = np.repeat([k for _, _, _, k in kept], lengths)
    tt = te[frames]
    ts = np.empty_like(tt)
    for k in np.unique(by):                       # the source time of each frame: its carrying clock's inverse
        at = by == k
        ts[at] = _warp(table, int(k), tt[at], inverse=True)
    ps = _read_positions(prep._P, joints, ts / prep.source.frame_time)
    pe = Pe[:, joints, frames]
    rel, raw = _travels(pe, ps, starts, owner)
    steps = np.sqrt(_norms2(np.diff(pe, axis=1))) if pe.shape[1] > 1 else np.zeros(0)
    steps = np.append(steps, 0.0)
    steps[starts[1:] - 1] = 0.0                                  # no step from one contact into the next
    steps[-1] = 0.0
    path = np.add.reduceat(steps, starts)
    height = np.maximum.reduceat(np.abs(He[joints, frames] - _height_rows(ps, prep.up)), starts)
    bt = [None] * len(kept)
    if Pb is not None:
        inb = frames < base.num_frames                            # a prefix of each contact
        fb = np.minimum(frames, base.num_frames - 1)
        pb = Pb[:, joints, fb]
        d = _norms2((pb - pb[:, owner]) - (ps - ps[:, owner]))
        d[~inb | ~inb[owner]] = 0.0
        bt = (np.sqrt(np.maximum.reduceat(d, starts)) * scale).tolist()
    return [ContactFigures(c[0], (c[1], c[2]), (int(a), int(b)), float(r * scale), float(w * scale),
                           float(p * scale), float(h * scale), t)
            for (c, a, b, _), r, w, p, h, t in zip(kept, rel, raw, path, height, bt)]


def _source_interval_travel(prep, contacts, Pe, te, scale) -> tuple[float, float]:
    """``(foot_travel_source, foot_travel_source_raw)``: inside the source's own contact intervals shrunk by
    SOURCE_SHRINK at each end, at the same times (no carrying)."""
    ft_s = prep.source.frame_time
    spans, sk = [], prep.source.skeleton
    for name, a, b in contacts:
        s = int(np.searchsorted(te, a * ft_s + SOURCE_SHRINK - 1e-9, side="left"))
        e = int(np.searchsorted(te, (b - 1) * ft_s - SOURCE_SHRINK + 1e-9, side="right"))
        if e - s >= 2:
            spans.append((sk.index(name), s, e))
    if not spans:
        return 0.0, 0.0
    first = np.array([s for _, s, _ in spans], dtype=np.int64)
    lengths = np.array([e for _, _, e in spans], dtype=np.int64) - first
    starts, owner = _segments(lengths)
    frames = np.arange(owner.size) + np.repeat(first - starts, lengths)
    joints = np.repeat([j for j, _, _ in spans], lengths)
    ps = _read_positions(prep._P, joints, te[frames] / ft_s)
    rel, raw = _travels(Pe[:, joints, frames], ps, starts, owner)
    return float(rel.max()) * scale, float(raw.max()) * scale
