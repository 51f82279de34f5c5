"""The root (pelvis) adjustment of the contact layer (:mod:`stagger_nb.staggered.plants`): how far each held leg
may reach, the horizontal shift of each plant, and the smallest smooth root displacement that lets every held
leg reach its plant (the root lowered and moved aside only as much as the plants need, within caps).
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d

REACH = 0.98          # share of a leg's length a held leg may use (unless the edited pose already uses more)
_MAX_DROP = 0.05      # the root is lowered by at most this share of a leg (~4.4 cm of a 170 cm body)
_MAX_SIDE = 0.15      # the root moves aside by at most this share of a leg (~13 cm of a 170 cm body)
_SHIFT_STEPS = np.linspace(-0.25, 0.25, 21)
_SEGMENT = np.linspace(0.0, 1.0, 21)     # from where the edit puts the foot to the centre of the hip's path
_DYKSTRA_STEPS = 30   # alternating projections for the root's shift
_TOL = 1e-6          # lengths below this share of a leg are rounding (no need to lower the root, no shift)

def _envelope(need: np.ndarray, n: int) -> np.ndarray:
    """Smallest-ish smooth profile ``>= need (F,)``: a max filter ``2n + 1`` frames wide, then a normalised
    raised-cosine average of the same width (an average of values >= need[x] stays >= need[x])."""
    if not np.any(need > 0):
        return np.zeros_like(need)
    w = max(int(n), 1)
    peak = maximum_filter1d(np.maximum(need, 0.0), 2 * w + 1, mode="nearest")
    kernel = 0.5 * (1.0 + np.cos(np.pi * np.arange(-w, w + 1) / (w + 1)))
    kernel /= kernel.sum()
    return np.convolve(np.pad(peak, w, mode="edge"), kernel, mode="valid")


def _below(sk, j: int, ancestor: int) -> bool:
    """Whether joint ``j`` is ``ancestor`` or below it."""
    while j >= 0:
        if j == ancestor:
            return True
        j = int(sk.parents[j])
    return False


def _vertical_need(hip: np.ndarray, target: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """How far ``(n,)`` the hip ``(n, 3)`` must come down (file units; <= 0: no need) for ``target (n, 3)``
    to lie within ``reach (n,)`` of it; a target horizontally beyond reach gets the drop to its height plus
    the horizontal excess (a penalty that keeps growing)."""
    dx = hip[:, 0] - target[:, 0]
    dz = hip[:, 2] - target[:, 2]
    h2 = dx * dx + dz * dz
    dy = hip[:, 1] - target[:, 1]
    room = reach * reach - h2
    return np.where(room >= 0, dy - np.sqrt(np.maximum(room, 0.0)), dy + np.sqrt(h2) - reach)


def _choose_shifts(hip, base, reach, pid, d0, lengths) -> np.ndarray:
    """One horizontal shift ``(P, 3)`` per plant, for held targets ``base + shift`` (samples ``(n, 3)``
    sorted by plant ``pid (n,)``) that the hip ``hip (n, 3)`` reaches within ``reach (n,)``.

    Candidates: the segment from ``d0`` (where the edit puts the foot at the plant's first frame) to the shift
    that centres the hip's path over the plant (the middle of its horizontal extent), then around that centre along the
    hip's travel (within a quarter leg, ``lengths (P,)``). The first that needs no lowering, in that order
    (the nearest to ``d0``), else the one needing the least."""
    out = np.array(d0, dtype=float)
    out[:, 1] = 0.0
    if not pid.size:
        return out
    ids, starts = np.unique(pid, return_index=True)
    ends = np.r_[starts[1:], pid.size] - 1
    rel = (hip - base)[:, [0, 2]]                                                   # (n, 2)
    lo, hi = np.minimum.reduceat(rel, starts, axis=0), np.maximum.reduceat(rel, starts, axis=0)
    centre = 0.5 * (lo + hi)                                                        # (p, 2)
    u = rel[ends] - rel[starts]
    un = np.hypot(u[:, 0], u[:, 1])
    u = np.where((un > 1e-9 * lengths[ids])[:, None], u / np.maximum(un, 1e-300)[:, None], 0.0)
    d = out[ids][:, [0, 2]]
    cand = np.concatenate([d[None] + _SEGMENT[:, None, None] * (centre - d)[None],
                           centre[None] + (_SHIFT_STEPS[:, None] * lengths[ids])[:, :, None] * u[None]])   # (C, p, 2)
    of = np.searchsorted(ids, pid)
    diff = rel[None] - cand[:, of]                                                  # (C, n, 2)
    h2 = np.einsum("cnk,cnk->cn", diff, diff)
    room = reach * reach - h2
    dy = (hip - base)[:, 1]
    need = np.where(room >= 0, dy - np.sqrt(np.maximum(room, 0.0)), dy + np.sqrt(h2) - reach)
    worst = np.maximum.reduceat(need, starts, axis=1)                               # (C, p)
    ok = worst <= _TOL * lengths[ids]                                               # rounding is no need
    k = np.where(ok.any(axis=0), np.argmax(ok, axis=0), np.argmin(worst, axis=0))
    best = cand[k, np.arange(ids.size)]
    out[ids, 0], out[ids, 2] = best[:, 0], best[:, 1]
    return out


def _root_shift(F: int, rows: list, pos: np.ndarray, cap_down: float, cap_side: float, nb: int) -> np.ndarray:
    """The smallest root displacement ``(F, 3)`` that brings every held effector's target within its reach:
    per frame the point nearest the origin in the intersection of the balls ``|hip + x - target| <= R`` (one
    per held limb), the root lowered by at most ``cap_down`` and moved aside by at most ``cap_side`` (Dykstra's
    alternating projections, vectorised over frames; the caps are projected last, so they always hold), then
    made smooth: each component's positive and negative parts through :func:`_envelope` (``nb`` frames)."""
    centres, radii, where = [], [], []
    for r in rows:
        fr = r["fr"]
        c = np.zeros((F, 3))
        rad = np.full(F, np.inf)
        c[fr] = r["g"] - pos[fr, r["lim"].upper]
        rad[fr] = r["R"]
        centres.append(c)
        radii.append(rad)
        where.append(np.isfinite(rad))
    # only frames where some held limb cannot reach from where the edit puts the root need the projections
    sub = np.flatnonzero(np.any([w & (np.linalg.norm(c, axis=-1) > rad) for c, rad, w in zip(centres, radii, where)],
                                axis=0))
    x_all = np.zeros((F, 3))
    if not sub.size:
        return x_all
    centres, radii, where = [c[sub] for c in centres], [r[sub] for r in radii], [w[sub] for w in where]
    x = np.zeros((sub.size, 3))
    inc = [np.zeros((sub.size, 3)) for _ in range(len(rows) + 1)]
    for _ in range(_DYKSTRA_STEPS):
        for k, (c, rad, w) in enumerate(zip(centres, radii, where)):
            y = x + inc[k]
            d = y - c
            n = np.linalg.norm(d, axis=-1)
            out = w & (n > rad)
            z = np.where(out[:, None], c + d * (np.where(out, rad, 0.0) / np.maximum(n, 1e-300))[:, None], y)
            inc[k], x = y - z, z
        y = x + inc[-1]
        z = y.copy()
        z[:, 1] = np.clip(z[:, 1], -cap_down, 0.0)
        side = np.hypot(z[:, 0], z[:, 2])
        scale = np.minimum(1.0, cap_side / np.maximum(side, 1e-300))
        z[:, 0] *= scale
        z[:, 2] *= scale
        inc[-1], x = y - z, z
    x_all[sub] = x
    x = x_all
    out = np.zeros((F, 3))
    for k in range(3):
        out[:, k] = _envelope(np.maximum(x[:, k], 0.0), nb) - _envelope(np.maximum(-x[:, k], 0.0), nb)
    return out


def _reach(reach: float, length: np.ndarray, extension: np.ndarray, source_share: np.ndarray) -> np.ndarray:
    """Largest upper-effector distance a held limb may use ``(n,)``: ``reach`` of its ``length``, or the
    ``extension`` the edited pose already has, or the share of its length the source used at the plant's
    source time (``source_share``), whichever is more; never the full length."""
    return np.minimum(np.maximum(np.maximum(reach, source_share) * length, extension), length * (1 - 1e-9))


