"""Test clips derived from the real ones, for the held-out side of the issue "Edits an animator would keep":
the same motions as a clip we have never seen might present them (bench_edit_quality.py ``--derived``).

Each variant is a pure function of a Motion already scaled to a 170 cm body (``sn.quality.scaled``):

- ``24hz`` / ``60hz`` / ``120hz``: resampled to that rate (slerp / linear, :meth:`Motion.resample`); a clip already
  at that rate is skipped (None);
- ``mid``: the section starting halfway through the source's first detected foot contact (the clip opens with
  a foot mid-stance) to the end; ``swing``: starting halfway between the first foot contact's end and the next
  contact of the same foot (the clip opens mid-swing). None where no such contact (or less than 0.5 s is left);
- ``x100`` / ``x0.01``: every length multiplied by 100 / 0.01 (cm read as m and the other way round);
- ``zup``: the whole world turned -90 degrees about X, so the body's up axis is +Z (some exporters' convention).

The layer and ``sn.quality.compare`` should meet the same goals on each (``compare`` measures in cm of a 170 cm
body and finds the up axis itself).
"""
from __future__ import annotations

import numpy as np

import stagger_nb as sn
from stagger_nb.core.rotations import quat_mul, quat_rotate
from stagger_nb.staggered import detect_contacts

VARIANTS = ("24hz", "60hz", "120hz", "mid", "swing", "x100", "x0.01", "zup")
_MIN_LEFT = 0.5   # seconds a sliced section must keep


def _resample(m, hz: float):
    if abs(m.frame_time * hz - 1.0) < 1e-3:
        return None
    return m.resample(1.0 / hz)


def _foot_contacts(m):
    return [c for c in detect_contacts(m) if any(k in c[0].lower() for k in ("foot", "toe", "ankle", "heel"))]


def _from(m, start: int):
    if start <= 0 or (m.num_frames - start) * m.frame_time < _MIN_LEFT:
        return None
    return m.slice(start, None)


def _mid(m):
    cs = _foot_contacts(m)
    return _from(m, (cs[0][1] + cs[0][2]) // 2) if cs else None


def _swing(m):
    cs = _foot_contacts(m)
    if not cs:
        return None
    j, _, e = cs[0]
    nxt = [c for c in cs if c[0] == j and c[1] > e]
    return _from(m, (e + nxt[0][1]) // 2) if nxt else None


def _units(m, factor: float):
    return sn.quality.scaled(m, factor)


def _zup(m):
    """The world turned -90 degrees about X (+Y -> +Z): the root's rotation and position, and an animated
    translation of a joint whose parent is the root's frame, are all in world axes only at the root."""
    r = np.array([-np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)])          # (x, y, z, w)
    q = np.array(m.local_quats)
    q[:, 0] = quat_mul(np.broadcast_to(r, q[:, 0].shape), q[:, 0])
    rp = quat_rotate(np.broadcast_to(r, m.root_positions.shape[:-1] + (4,)), m.root_positions)
    lt = None if m.local_translations is None else np.array(m.local_translations)
    if lt is not None:
        lt[:, 0] = rp
    return m.replace(local_quats=q, root_positions=rp, local_translations=lt)


def derive(m, variant: str):
    """``m`` (a Motion scaled to a 170 cm body) as ``variant`` (one of :data:`VARIANTS`), or None where the
    variant does not apply to this clip."""
    if variant.endswith("hz"):
        return _resample(m, float(variant[:-2]))
    if variant == "mid":
        return _mid(m)
    if variant == "swing":
        return _swing(m)
    if variant.startswith("x"):
        return _units(m, float(variant[1:]))
    if variant == "zup":
        return _zup(m)
    raise ValueError(f"variant must be one of {', '.join(VARIANTS)}, got {variant!r}")
