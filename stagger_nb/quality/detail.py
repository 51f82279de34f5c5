"""The edit's time warps as :mod:`stagger_nb.quality` reads them, and the edited motion's detail energy on the
source's detail grid (each joint read at its warped time)."""
from __future__ import annotations

import numpy as np

from .arrays import _band_pass_energy, _fractional, _relative_rotvecs, _slerp_cm
from .constants import _BLOCK
from .source import SourceFigures


def _warp_table(sm):
    """``(tables, table)``: ``(S, T)`` of the time warps of ``sm`` (every control variable's,
    :func:`staggered.warp_times`), and the same or None when no knot moved (the warp is the identity);
    ``(None, None)`` without a StaggeredMotion."""
    if sm is None:
        return None, None
    from ..staggered.timing import _warp_tables
    S, T = _warp_tables(sm)
    return (S, T), None if np.array_equal(S, T) else (S, T)


def _warp(table, c: int, times: np.ndarray, inverse: bool = False) -> np.ndarray:
    from ..staggered.timing import _warp_column
    return times if table is None else _warp_column(*table, c, times, inverse)


def _warp_rows(table, J: int, times: np.ndarray) -> np.ndarray:
    """``_warp(table, j, times)`` of every joint ``j < J`` at once, ``(J, n)`` for sorted ``times (n,)`` (the
    same numbers: ``np.interp`` between the knots, slope 1 past the end knots)."""
    S, T = table
    Y = np.empty((J, times.size))
    for j in range(J):
        Y[j] = np.interp(times, S[:, j], T[:, j])
    if times.size:
        for j in np.flatnonzero(times[0] < S[0, :J]):
            x = times < S[0, j]
            Y[j, x] = T[0, j] + (times[x] - S[0, j])
        for j in np.flatnonzero(times[-1] > S[-1, :J]):
            x = times > S[-1, j]
            Y[j, x] = T[-1, j] + (times[x] - S[-1, j])
    return Y



def _detail_energies(prep: SourceFigures, Qe: np.ndarray, ft_e: float, table, t0: float):
    """``(edited, source)`` detail energies ``(J,)``, both on the source's detail grid (its frames, every
    ``_detail_step``-th): the edited rotations ``Qe (4, J, F)`` are read at each joint's warped time
    ``w_j(t_n)`` (slerp between its frames; exact where a time falls on a frame), so a timing edit that only
    retimes a curve keeps its detail. Grid times whose warped time falls outside the edited motion (any
    joint) are left out of both."""
    src = prep.source
    J, F, k = src.num_joints, Qe.shape[2], prep._step
    h = k * src.frame_time
    ts = np.arange(0, src.num_frames, k) * src.frame_time
    G = ts.size
    if table is None:
        f = np.broadcast_to((ts - t0) / ft_e, (J, G))
    else:
        f = (_warp_rows(table, J, ts) - t0) / ft_e                                   # (J, G)
    keep = np.all((f >= -1e-6) & (f <= F - 1 + 1e-6), axis=0)
    n = int(keep.sum())
    if n < 3:
        return np.zeros(J), np.zeros(J)
    lo = int(np.argmax(keep))
    span = bool(keep[lo:lo + n].all())                        # the kept samples are one run [lo, lo + n)
    f = f[:, lo:lo + n] if span else f[:, keep]
    i0, i1, w = _fractional(f, F)
    i0 += (np.arange(J) * F)[:, None]                         # flat indices into (4, J * F)
    i1 += (np.arange(J) * F)[:, None]
    Qflat = Qe.reshape(4, J * F)
    V = np.empty((3, J, n - 1))
    block = max(1, _BLOCK // n)                               # joints per block: temporaries stay in cache
    for j0 in range(0, J, block):
        rows = slice(j0, j0 + block)
        q = np.take(Qflat, i0[rows], axis=1)                                     # (4, rows, n)
        frac = w[rows] > 0
        if frac.any():
            q = np.where(frac, _slerp_cm(q, np.take(Qflat, i1[rows], axis=1), w[rows]), q)
        V[:, rows] = _relative_rotvecs(q[:, :, :-1], q[:, :, 1:])
    V /= h
    e_e = _band_pass_energy(V, prep._kernel)
    if n == G:
        e_s = prep.detail
    elif span:
        e_s = _band_pass_energy(prep.velocity[:, :, lo:lo + n - 1], prep._kernel)
    else:
        Qs = prep._Q[:, :, ::k][:, :, keep]
        e_s = _band_pass_energy(_relative_rotvecs(Qs[:, :, :-1], Qs[:, :, 1:]) / h, prep._kernel)
    return e_e, e_s


def _carried(sm, contacts, frame_time: float, tables) -> tuple[list, list]:
    """Each source contact carried through the timing edit by the package's one carry
    (:func:`staggered.plants_carry.carry_windows` with the default clocks, those of ``staggered.carry_contacts``
    and the contact layer: the joint whose rotation sets the contact joint's position): ``(start, stop)``
    frames of the edited motion, or None where it keeps no frame; and the clock (time-warp column) of each."""
    from ..staggered.plants_carry import carry_clocks, carry_windows
    from ..staggered.representation import default_times
    if not contacts:
        return [], []
    names = sm.skeleton.names
    t0, ft, F = float(sm.pose_times[0]), sm.frame_time, default_times(sm).size
    clocks = carry_clocks(sm.skeleton, [names.index(c[0]) for c in contacts])
    ends = np.array([(a, b - 1) for _, a, b in contacts], dtype=float) * frame_time        # (N, 2) seconds
    _, start, stop = carry_windows(tables, t0, ft, F, ends, clocks)
    return ([(int(a), int(b)) if b > a else None for a, b in zip(start, stop)], [cs[0] for cs in clocks])
