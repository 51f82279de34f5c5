"""Displacement maps (Coleman et al. 2008, §3, §4.1.1): ``d = v ⊖ s``, what the spline leaves of the motion, as
rotation vectors unwrapped along each (segment, joint) grid.
"""
from __future__ import annotations

import numpy as np

from . import _kernels as K

__all__ = ["displacement_rotvecs"]


_LOG_SMALL = 1e-12   # below this |v| the logarithm uses its Taylor branch (as core.rotations)


def displacement_rotvecs(s, targets, pair):
    """Displacement samples ``d = v ⊖ s`` as rotation vectors (N, 3), unwrapped along each pair.

    The quaternions ``s^-1 v`` are made sign-continuous along each pair's samples (starting on the
    ``w >= 0`` side), then mapped by the logarithm without hemisphere folding, so angles run continuously
    in [0, 2 pi): linear interpolation between neighbouring samples then never jumps across the pi
    ambiguity (large residuals occur on long merged segments).

    ``s, targets (N, 4)`` (transposed views of component-first ``(4, N)`` arrays are used without a
    copy); ``pair (N,)``, samples of a pair contiguous. Works on ``(4, N)`` rows throughout."""
    S = np.asarray(s, dtype=float).T
    T = np.asarray(targets, dtype=float).T
    N = S.shape[1]
    if N == 0:
        return np.zeros((0, 3))
    CH = K.CHUNK                                     # blocks of samples: every temporary stays in cache
    e = np.empty((4, N))                             # s^-1 v
    sc, tmp = np.empty((4, CH)), np.empty(CH)
    for a in range(0, N, CH):
        b = min(N, a + CH)
        np.negative(S[:3, a:b], out=sc[:3, :b - a])
        sc[3, :b - a] = S[3, a:b]
        K.qmul_into(sc[:, :b - a], T[:, a:b], e[:, a:b], tmp[:b - a])
    first = np.concatenate([[True], pair[1:] != pair[:-1]])
    f = np.flatnonzero(first)
    e[:, f] = np.where(e[3, f] < 0, -e[:, f], e[:, f])                  # each pair starts with w >= 0
    d = np.empty(max(N - 1, 0))
    for a in range(0, N - 1, CH):
        b = min(N - 1, a + CH)
        K.dot_into(e[:, a + 1:b + 1], e[:, a:b], d[a:b], tmp[:b - a])
    neg = np.concatenate([[0], np.cumsum((d < 0) & ~first[1:])])
    scale2 = np.where((neg - np.repeat(neg[f], np.diff(np.append(f, N)))) % 2 == 1, -2.0, 2.0)
    out = np.empty((N, 3))
    for a in range(0, N, CH):
        b = min(N, a + CH)
        x = e[:, a:b] * scale2[a:b]                 # sign-continuous, and x2: rotvec = 2 log(q)
        n = np.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])          # 2 |v|
        half = np.arctan2(n, x[3])                                      # half angle in [0, pi]
        big = n > 2.0 * _LOG_SMALL
        # angle / |v| = 2 half / |v|; Taylor below _LOG_SMALL: 2 / w (as core.rotations.quat_log)
        sc_ = np.where(big, 2.0 * half / np.where(big, n, 1.0), 2.0 / np.where(x[3] != 0, x[3], 1.0))
        out[a:b] = (x[:3] * sc_).T
    return out
