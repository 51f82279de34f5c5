"""The naive reference of :func:`stagger_nb.quality.compare`: its figures computed in the most straightforward
manner (one contact, one joint at a time; every figure read from full (F, J, ...) arrays; scipy's two Gaussian
filters; ``core.rotations`` quat_angle / slerp / rotvec on (..., 4) arrays), as the first version of the module
computed them. ``tests/test_quality_fast.py`` checks the vectorised compare against it."""
from __future__ import annotations

import numpy as np

from stagger_nb.core.body import pelvis_joint, up_axis
from stagger_nb.core.kinematics import forward_kinematics
from stagger_nb.core.motion import Motion
from stagger_nb.core.rotations import quat_angle, quat_conj, quat_mul, quat_to_rotvec, slerp
from stagger_nb.quality import (
    BODY_CM,
    DETAIL_FINE,
    DETAIL_RATE,
    DETAIL_SIGMA,
    SOURCE_SHRINK,
    ContactFigures,
    QualityReport,
)
from stagger_nb.quality import body_height as body_height_of
from stagger_nb.quality.bounds import _bounds
from stagger_nb.quality.inputs import _as_motion, _check_contacts
from stagger_nb.staggered.limbs import find_limb
from stagger_nb.staggered.plants_carry import position_joint

__all__ = ["compare_reference"]


def _heights(pos: np.ndarray, up: np.ndarray) -> np.ndarray:
    return pos @ up


def _at_times(pos: np.ndarray, frame_time: float, times: np.ndarray) -> np.ndarray:
    """``pos (F, ...)`` sampled at ``times (N,)`` seconds by linear interpolation (clamped at the ends; exact
    where a time falls on a frame)."""
    f = np.clip(np.asarray(times, float) / frame_time, 0.0, pos.shape[0] - 1)
    i0 = np.floor(f + 1e-9).astype(np.int64)
    np.minimum(i0, pos.shape[0] - 1, out=i0)
    w = f - i0
    w[np.abs(w) < 1e-9] = 0.0
    i1 = np.minimum(i0 + 1, pos.shape[0] - 1)
    w = w.reshape((-1,) + (1,) * (pos.ndim - 1))
    out = pos[i0].copy()
    moving = w.reshape(-1) > 0
    if moving.any():
        out[moving] = pos[i0[moving]] * (1 - w[moving]) + pos[i1[moving]] * w[moving]
    return out


def _frame_steps(q: np.ndarray) -> np.ndarray:
    """Largest frame-to-frame rotation angle (degrees) of each joint, ``q (F, J, 4)`` -> ``(J,)``."""
    if q.shape[0] < 2:
        return np.zeros(q.shape[1])
    return np.degrees(quat_angle(q[:-1], q[1:])).max(axis=0)


def _added(edited: np.ndarray, source: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """What the edit adds to a per-joint figure, ``max(edited - source, 0) * scale``, with rounding (< 1e-9)
    counted as nothing (no pop, no jump)."""
    out = np.maximum(edited - source, 0.0) * scale
    out[out < 1e-9] = 0.0
    return out


def _position_steps(p: np.ndarray) -> np.ndarray:
    if p.shape[0] < 2:
        return np.zeros(p.shape[1])
    return np.linalg.norm(np.diff(p, axis=0), axis=-1).max(axis=0)


def _detail_energy(q: np.ndarray, frame_time: float) -> np.ndarray:
    """High-frequency energy (rad²/s²) of each joint's local angular velocity, ``q (F, J, 4)`` -> ``(J,)``."""
    from scipy.ndimage import gaussian_filter1d
    if q.shape[0] < 3:
        return np.zeros(q.shape[1])
    w = quat_to_rotvec(quat_mul(quat_conj(q[:-1]), q[1:])) / frame_time          # (F-1, J, 3)
    hp = (gaussian_filter1d(w, DETAIL_FINE / frame_time, axis=0, mode="nearest")
          - gaussian_filter1d(w, DETAIL_SIGMA / frame_time, axis=0, mode="nearest"))
    return np.mean(np.sum(hp * hp, axis=-1), axis=0)


def _detail_energies(source: Motion, motion: Motion, sm, t0: float) -> tuple[np.ndarray, np.ndarray]:
    """``(edited, source)`` detail energies ``(J,)``, both on the detail grid (every k-th source frame, k the
    largest integer with ``k * frame_time <= 1 / DETAIL_RATE``, at least 1): the edited motion's local
    rotations are read at each joint's warped time (slerp between its frames; exact where a time falls on a
    frame). Grid times whose warped time falls outside the edited motion (any joint) are left out of both."""
    from stagger_nb.staggered import warp_times
    k = max(1, int(1.0 / (DETAIL_RATE * source.frame_time) + 1e-9))
    grid = np.arange(0, source.num_frames, k)
    Fs, J = grid.size, source.num_joints
    ts = grid * source.frame_time
    if sm is None:
        te = np.broadcast_to(ts[:, None], (Fs, J))
    else:
        te = np.stack([warp_times(sm, ts, j) for j in range(J)], axis=1)
    f = (te - t0) / motion.frame_time
    F = motion.num_frames
    keep = np.all((f >= -1e-6) & (f <= F - 1 + 1e-6), axis=1)
    if keep.sum() < 3:
        return np.zeros(J), np.zeros(J)
    f = np.clip(f[keep], 0.0, F - 1)
    i0 = np.minimum(np.floor(f + 1e-9).astype(np.int64), F - 1)
    w = f - i0
    w[np.abs(w) < 1e-9] = 0.0
    cols = np.broadcast_to(np.arange(J), i0.shape)
    q = motion.local_quats[i0, cols]                                                # (n, J, 4)
    frac = w > 0
    if frac.any():
        i1 = np.minimum(i0 + 1, F - 1)
        q[frac] = slerp(q[frac], motion.local_quats[i1[frac], cols[frac]], w[frac])
    h = k * source.frame_time
    return _detail_energy(q, h), _detail_energy(source.local_quats[grid][keep], h)


def _travel(pe: np.ndarray, ps: np.ndarray) -> tuple[float, float, float]:
    """(travel against the source, raw travel, path length) of positions ``pe (n, 3)`` against ``ps (n, 3)``."""
    de, ds = pe - pe[0], ps - ps[0]
    rel = float(np.linalg.norm(de - ds, axis=-1).max())
    raw = float(np.linalg.norm(de, axis=-1).max())
    path = float(np.linalg.norm(np.diff(pe, axis=0), axis=-1).sum()) if pe.shape[0] > 1 else 0.0
    return rel, raw, path


# -- compare ---------------------------------------------------------------------------------------------

def compare_reference(source: Motion, edited, *, staggered=None, contacts=None, baseline=None, bounds=None,
                      body_height: float | None = None, source_positions: np.ndarray | None = None) -> QualityReport:
    """The report of ``stagger_nb.quality.compare`` (same parameters, without ``prepared`` and the positions of the
    edited motion and the baseline), computed the straightforward way."""
    from stagger_nb import staggered as stg  # the arguments are trusted (compare checks them)
    motion, sm = _as_motion(edited, "edited")
    if staggered is None and sm is None and motion.staggered is not None:
        # the Motion's own staggered motion, where it edits a motion on the source's timeline
        from stagger_nb.staggered.source_times import source_pose_times
        own, ft = motion.staggered, source.frame_time
        sp = source_pose_times(own)
        if (abs(own.frame_time - ft) <= 1e-9 * ft and sp.size and abs(sp[0]) <= 0.5 * ft
                and abs(sp[-1] - source.duration) <= 0.5 * ft):
            sm = own
    sm = staggered if staggered is not None else sm
    base = None if baseline is None else _as_motion(baseline, "baseline")[0]
    bnds = _bounds(bounds)
    sk = source.skeleton
    names = sk.names
    src_pos = forward_kinematics(source)[0] if source_positions is None else np.asarray(source_positions, float)
    up = up_axis(source, src_pos)
    h_body = body_height_of(source, src_pos) if body_height is None else float(body_height)
    scale = BODY_CM / h_body
    if contacts is None:
        contacts = stg.detect_contacts(source, positions=src_pos)
    contacts = _check_contacts(source, contacts)

    ft_s, ft_e = source.frame_time, motion.frame_time
    t0 = float(sm.pose_times[0]) if sm is not None else 0.0
    pos, _ = forward_kinematics(motion)
    F = motion.num_frames
    te = t0 + np.arange(F) * ft_e
    inside = te <= source.duration + 0.5 * ft_s + 1e-9          # frames the source covers
    src_at = _at_times(src_pos, ft_s, te[inside])               # (n, J, 3) the source at the same times

    # whole-body figures
    moved_j = np.linalg.norm(pos[inside] - src_at, axis=-1).max(axis=0) if inside.any() else np.zeros(len(names))
    mj = int(np.argmax(moved_j))
    if inside.any():
        fs = np.clip(te[inside] / ft_s, 0, source.num_frames - 1)
        i0 = np.floor(fs + 1e-9).astype(np.int64)
        i1 = np.minimum(i0 + 1, source.num_frames - 1)
        w = np.where(np.abs(fs - i0) < 1e-9, 0.0, fs - i0)
        q_src = source.local_quats[i0]
        frac = w > 0
        if frac.any():
            q_src[frac] = slerp(source.local_quats[i0[frac]], source.local_quats[i1[frac]], w[frac][:, None])
        q_e = motion.local_quats[inside]
        ang = np.where(np.all(q_src == q_e, axis=-1), 0.0, quat_angle(q_src, q_e))   # exact 0 where equal
        rotated = float(np.degrees(ang).max())
    else:
        rotated = 0.0
    pel = pelvis_joint(sk)
    if sm is None:
        hp_e, hp_s = _heights(pos[inside, pel], up), _heights(src_at[:, pel], up)
    else:      # the source pelvis on the root translation's clock (which carries its height)
        ts = stg.warp_times(sm, te, "<root translation>", inverse=True)
        on = (ts >= 0) & (ts <= (source.num_frames - 1) * ft_s)
        hp_e, hp_s = _heights(pos[on, pel], up), _heights(_at_times(src_pos, ft_s, ts[on])[:, pel], up)
    dpel = hp_e - hp_s
    pelvis = float(np.abs(dpel).max()) * scale if dpel.size else 0.0
    pelvis_drop = float(max(-dpel.min(), 0.0)) * scale if dpel.size else 0.0
    pelvis_vs_base = None
    base_pos = None
    if base is not None:
        base_pos, _ = forward_kinematics(base)
        n = min(base_pos.shape[0], F)
        pelvis_vs_base = float(np.abs(_heights(pos[:n, pel] - base_pos[:n, pel], up)).max()) * scale if n else 0.0
    floor = float(_heights(src_pos, up).min())
    below = floor - float(_heights(pos, up).min())
    floor_pen = max(below, 0.0) * scale

    ratio = ft_s / ft_e
    pop_added = _added(_frame_steps(motion.local_quats) * ratio, _frame_steps(source.local_quats))
    pj = int(np.argmax(pop_added))
    jump_added = _added(_position_steps(pos) * ratio, _position_steps(src_pos), scale)
    jj = int(np.argmax(jump_added))
    e_e, e_s = _detail_energies(source, motion, sm, t0)
    total_s = float(e_s.sum())
    detail = float(e_e.sum()) / total_s if total_s > 0 else 1.0
    # per joint, one at a time; a joint still in the source (energy at rounding level: 1e-12 of the mean)
    # reads 1 when it stays still, else its energy over that floor
    tiny = max(1e-12 * total_s / max(e_s.size, 1), 1e-300)
    detail_j = np.ones(e_s.size)
    for j in range(e_s.size):
        if e_s[j] > tiny:
            detail_j[j] = e_e[j] / e_s[j]
        elif e_e[j] > tiny:
            detail_j[j] = e_e[j] / tiny

    knots_bad = None
    if sm is not None:   # a knot column (a joint's, then the root translation's) whose times do not rise
        columns = [sm.knot_times()[:, c] for c in range(len(names))] + [sm.pose_times + sm.root_refinements]
        knots_bad = tuple(label for label, col in zip(list(names) + ["<root translation>"], columns)
                          if any(not col[k + 1] > col[k] for k in range(len(col) - 1)))

    # contacts carried through the pelvis's timing (a joint of a limb below the pelvis; else the timing of the
    # joint whose rotation sets its position), one contact at a time
    figures = []
    pel = pelvis_joint(sk)

    def clock(j):
        lim = find_limb(sk, j)
        if lim is not None and lim.upper != pel:
            k = lim.upper
            while k >= 0 and k != pel:
                k = int(sk.parents[k])
            if k == pel:
                return pel
        return position_joint(sk, j)

    for name, a0, b0 in contacts:
        if sm is not None:
            moved_c = stg.carry_contacts(sm, [(name, a0, b0)], ft_s)
            if not moved_c:
                continue                       # carried onto no frame
            _, a, b = moved_c[0]
        else:
            a, b = a0, b0
        b = min(b, F)
        if b <= a:
            continue
        j = sk.index(name)
        frames = np.arange(a, b)
        tt = te[frames]
        ts = stg.warp_times(sm, tt, clock(j), inverse=True) if sm is not None else tt
        ps = _at_times(src_pos[:, j], ft_s, ts)
        pe = pos[frames, j]
        rel, raw, path = _travel(pe, ps)
        height = float(np.abs(_heights(pe - ps, up)).max())
        bt = None
        if base_pos is not None:
            fb = frames[frames < base_pos.shape[0]]
            bt = _travel(base_pos[fb, j], ps[: fb.size])[0] * scale if fb.size else 0.0
        figures.append(ContactFigures(name, (a0, b0), (int(a), int(b)), rel * scale, raw * scale,
                                      path * scale, height * scale, bt))
    # inside the source's own intervals, shrunk by SOURCE_SHRINK at each end, at the same times
    in_src, in_src_raw = 0.0, 0.0
    for name, a, b in contacts:
        j = sk.index(name)
        lo, hi = a * ft_s + SOURCE_SHRINK, (b - 1) * ft_s - SOURCE_SHRINK
        frames = np.flatnonzero((te >= lo - 1e-9) & (te <= hi + 1e-9))
        if frames.size < 2:
            continue
        rel, raw, _ = _travel(pos[frames, j], _at_times(src_pos[:, j], ft_s, te[frames]))
        in_src, in_src_raw = max(in_src, rel * scale), max(in_src_raw, raw * scale)

    fields = {"scale": scale, "body_height": h_body, "foot_travel_source": in_src,
              "foot_travel_source_raw": in_src_raw, "floor": floor_pen, "pelvis": pelvis, "pelvis_drop": pelvis_drop,
              "pelvis_vs_baseline": pelvis_vs_base, "rotated": rotated, "knots_out_of_order": knots_bad,
              "detail": detail, "contacts": tuple(figures), "joints": tuple(names), "bounds": bnds}
    for key, attr in (("foot_travel", "travel"), ("foot_travel_raw", "travel_raw"), ("foot_path", "path"),
                      ("foot_height", "height")):                       # the worst contact's figure
        fields[key] = max((getattr(c, attr) for c in figures), default=0.0)
    fields["baseline_foot_travel"] = (None if base_pos is None else
                                      max((c.baseline_travel for c in figures), default=0.0))
    for key, values, j, factor in (("added_pop", pop_added, pj, 1.0), ("added_jump", jump_added, jj, 1.0),
                                   ("moved", moved_j, mj, scale)):       # the worst joint's, and its name
        fields[key] = float(values[j]) * factor
        fields[key + "_joint"] = names[j] if values[j] > 0 else None
    for key, values in (("pop_added", pop_added), ("jump_added", jump_added), ("detail_by_joint", detail_j)):
        fields[key] = tuple(float(x) for x in values)
    return QualityReport(**fields)
