"""Contacts carried through a staggered timing edit and grouped into plants (the contact layer's first step,
:mod:`stagger_nb.staggered.plants`): each source contact's first and last frame mapped through the time warp of
the joint that carries it, and one limb's overlapping contacts (heel, toe) held as one plant.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from .limbs import find_limb


def _timeline(edited):
    """(start time, frame time, frame count) of ``evaluate(edited)`` or of a Motion, and the warp tables."""
    from .representation import StaggeredMotion, default_times
    if isinstance(edited, StaggeredMotion):
        from .timing import _warp_tables
        return float(edited.pose_times[0]), edited.frame_time, default_times(edited).size, _warp_tables(edited)
    if isinstance(edited, Motion):
        return 0.0, edited.frame_time, edited.num_frames, None
    raise ValueError(f"edited must be a StaggeredMotion or a Motion, got {type(edited).__name__}")


def _blend_and_share(blend, lower_root) -> tuple[float, float]:
    """``blend`` (seconds, >= 0) and ``lower_root`` (a bool or a share in [0, 1]) as floats, checked."""
    blend = float(blend)
    if not np.isfinite(blend) or blend < 0:
        raise ValueError(f"blend must be >= 0 seconds, got {blend!r}")
    share = float(lower_root)
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"lower_root must be a bool or a share in [0, 1], got {lower_root!r}")
    return blend, share


def _parse(skeleton, contacts, num_frames: int | None = None) -> list[tuple[int, int, int]]:
    out = []
    for item in contacts:
        try:
            name, a, b = item
            a, b = int(a), int(b)
        except (TypeError, ValueError):
            raise ValueError(f"contacts: each entry must be (joint_name, start_frame, stop_frame), "
                             f"got {item!r}") from None
        if isinstance(name, (int, np.integer)) and not isinstance(name, bool):
            if not 0 <= int(name) < skeleton.num_joints:
                raise ValueError(f"contacts: joint index {name} outside [0, {skeleton.num_joints})")
            j = int(name)
        else:
            try:
                j = skeleton.index(name)
            except KeyError:
                raise ValueError(f"contacts: unknown joint {name!r}") from None
        hi = num_frames if num_frames is not None else b
        if not 0 <= a < b <= hi:
            raise ValueError(f"contacts: frame range [{a}, {b}) of {name!r} is empty or outside [0, {hi})")
        out.append((j, a, b))
    return out


def _carried(edited, parsed, source_frame_time: float, carry_by: str, timeline=None, index=None, cover=None):
    """``[(joint, e0, e1, start, stop, a, b)]``: each contact's first and last source frame ``a``, ``b - 1``
    mapped to edited frames ``e0 <= e1`` (floats) through the warp of the joint that carries it, and the
    edited frames ``[start, stop)`` inside; contacts that keep no frame are left out."""
    from .timing import _warp_column
    t0, ft, F, tables = _timeline(edited) if timeline is None else timeline
    sk = edited.skeleton
    out = []
    ends = np.array([[a, b - 1] for _, a, b in parsed], dtype=float).reshape(-1, 2) * source_frame_time
    if tables is not None:
        clocks = []
        for j, _a, _b in parsed:
            lim = find_limb(sk, j) if carry_by != "joint" else None
            if carry_by == "limb":
                clocks.append([lim.upper if lim is not None else j])
            elif carry_by == "span":
                clocks.append([j, lim.mid if lim is not None else j])
            else:
                clocks.append([j])
        # one warp per clock over every contact it carries (the warp is elementwise: the same numbers)
        warped = [np.empty((len(c), 2)) for c in clocks]
        for c in {c for cs in clocks for c in cs}:
            who = [(i, k) for i, cs in enumerate(clocks) for k, x in enumerate(cs) if x == c]
            w = _warp_column(*tables, c, ends[[i for i, _ in who]]).reshape(-1, 2)
            for (i, k), row in zip(who, w):
                warped[i][k] = row
    for i, (j, a, b) in enumerate(parsed):
        times = ends[i]
        if tables is not None:
            w = warped[i]
            times = np.array([w[:, 0].min(), w[:, 1].max()])
        e0, e1 = (times - t0) / ft
        start = max(int(np.ceil(e0 - 1e-6)), 0)
        stop = min(int(np.floor(e1 + 1e-6)) + 1, F)
        if cover is not None and tables is not None:
            # also the source's own frames less ``cover`` s at each end, where they are near (the edit moved the
            # contact by less than 2 ``cover``): a foot lands no more than that before its own timing says
            c0 = (a * source_frame_time + cover - t0) / ft
            c1 = ((b - 1) * source_frame_time - cover - t0) / ft
            near = 2 * cover / ft
            if c1 >= c0 and 0 < start - c0 <= near:
                start = max(int(np.ceil(c0 - 1e-6)), 0)
            if c1 >= c0 and 0 < c1 - (stop - 1) <= near:
                stop = min(int(np.floor(c1 + 1e-6)) + 1, F)
        if stop > start:
            out.append((j, float(e0), float(e1), start, stop, a, b, i if index is None else index[i]))
    return out


def carry_contacts(edited, contacts, source_frame_time: float, *,
                   carry_by: str = "joint") -> list[tuple[str, int, int]]:
    """Contacts of the source moved in time with the timing edit: ``(joint_name, start, stop)`` half-open
    frames of ``evaluate(edited)``.

    A contact's first and last source frames (times ``frame * source_frame_time``) are mapped through the
    time warp (:func:`~stagger_nb.staggered.editing.warp_times`) of the joint that carries it:
    ``carry_by="joint"`` (default) the contact joint's own, ``"limb"`` its limb's upper joint's (hip /
    shoulder), ``"span"`` from the earlier to the later of the contact joint's and its limb's middle joint's
    (knee / elbow). A Motion (no timing edit) keeps the frames. Contacts that keep no frame are dropped."""
    if carry_by not in ("joint", "limb", "span"):
        raise ValueError(f"carry_by must be 'joint', 'limb' or 'span', got {carry_by!r}")
    ft_s = float(source_frame_time)
    if not np.isfinite(ft_s) or ft_s <= 0:
        raise ValueError(f"source_frame_time must be > 0 seconds, got {source_frame_time!r}")
    timeline = _timeline(edited)
    sk = edited.skeleton
    return [(sk.names[c[0]], c[3], c[4]) for c in _carried(edited, _parse(sk, contacts), ft_s, carry_by, timeline)]


def _plants(carried, limb_of, gap: int = 0) -> list[dict]:
    """The carried contacts grouped into plants: one limb's contacts whose edited frames overlap or touch, or
    whose source frames overlap (a foot's heel and toe contacts of one step), or less than ``gap`` frames apart.
    Each plant: ``eff`` (its limb's
    effector), edited frames ``[start, stop)`` and source frames ``[s_lo, s_hi]`` (first and last held)."""
    by: dict[int, list] = {}
    for c in carried:
        by.setdefault(limb_of[c[0]].eff, []).append(c)
    plants = []
    for eff, items in by.items():
        items.sort(key=lambda c: (c[3], c[5]))
        groups: list[list] = []
        for c in items:
            g = groups[-1] if groups else None
            if g is not None and (c[3] <= max(x[4] for x in g) + gap or c[5] < max(x[6] for x in g)):
                g.append(c)
            else:
                groups.append([c])
        plants += [dict(eff=eff, start=min(x[3] for x in g), stop=max(x[4] for x in g),
                        s_lo=float(min(x[5] for x in g)), s_hi=float(max(x[6] for x in g) - 1)) for g in groups]
    return plants


def _source_frames(tables, t0: float, ft: float, ft_s: float, joint: int, frames: np.ndarray) -> np.ndarray:
    """Source frames (floats) of edited ``frames`` through ``joint``'s inverse time warp (identity without
    warp ``tables``)."""
    te = t0 + np.asarray(frames, dtype=float) * ft
    if tables is not None:
        from .timing import _warp_column
        te = _warp_column(*tables, joint, te, inverse=True)
    return te / ft_s


