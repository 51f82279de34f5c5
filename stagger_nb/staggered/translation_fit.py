"""Cubic Bézier fits of the root translation (Coleman et al. 2008, §4.1.1): inner control points by linear least
squares (also the closed-form start of the rotation fit, on logarithms), C1 matching at the knots, and the root
translation's knots, Béziers and displacement table of :func:`~.fitting.fit_staggered`.
"""
from __future__ import annotations

import numpy as np

from .channel import TRANSLATION, Channel
from .displacement import displacement_table, displacements_of
from .sampling import sample_segments

__all__ = ["fit_translation_tangents", "match_translation_tangents"]


_RIDGE = 1e-9       # pulls under-determined inner controls (segments with < 2 interior samples) to the chord


def _fit_inner_controls(tn, y, pair, b0, b3, num_pairs):
    """Least-squares ``(b1, b2)`` of cubic Béziers with fixed ends ``b0, b3 (P, D)``; samples ``y (N, D)``.

    A tiny ridge toward the straight chord (``b1 = (2 b0 + b3)/3``, ``b2 = (b0 + 2 b3)/3``) decides
    segments with fewer than two interior samples. Returns ``(P, 2, D)``.
    """
    u = 1.0 - tn
    B1 = 3.0 * u * u * tn
    B2 = 3.0 * u * tn * tn
    r = y - (u ** 3)[:, None] * b0[pair] - (tn ** 3)[:, None] * b3[pair]
    g11 = np.bincount(pair, B1 * B1, num_pairs) + _RIDGE
    g12 = np.bincount(pair, B1 * B2, num_pairs)
    g22 = np.bincount(pair, B2 * B2, num_pairs) + _RIDGE
    c1 = (2.0 * b0 + b3) / 3.0
    c2 = (b0 + 2.0 * b3) / 3.0
    D = y.shape[1]
    h1 = np.stack([np.bincount(pair, B1 * r[:, d], num_pairs) for d in range(D)], axis=1) + _RIDGE * c1
    h2 = np.stack([np.bincount(pair, B2 * r[:, d], num_pairs) for d in range(D)], axis=1) + _RIDGE * c2
    det = (g11 * g22 - g12 * g12)[:, None]
    x1 = (g22[:, None] * h1 - g12[:, None] * h2) / det
    x2 = (g11[:, None] * h2 - g12[:, None] * h1) / det
    return np.stack([x1, x2], axis=1)


def fit_translation_tangents(tn, y, pair, p0, p3, num_pairs):
    """Inner control points ``(P, 2, 3)`` of cubic Béziers with ends ``p0, p3 (P, 3)`` fitted to samples
    ``y (N, 3)`` at normalised times ``tn (N,)`` of pair ``pair (N,)`` (linear least squares, §4.1.1)."""
    return _fit_inner_controls(tn, y, pair, p0, p3, num_pairs)


def match_translation_tangents(values, tangents, knots):
    """C1 root-translation Béziers: at interior knots both sides get the velocity
    ``(Δ_{k-1}² u_in + Δ_k² u_out) / (Δ_{k-1}² + Δ_k²)`` with ``u_in = 3 (p_k - p2_{k-1}) / Δ_{k-1}`` and
    ``u_out = 3 (p1_k - p_k) / Δ_k``. ``values (K, 3)``, ``tangents (K - 1, 2, 3)``, ``knots (K,)``."""
    tangents = np.array(tangents, dtype=float)
    if values.shape[0] < 3:
        return tangents
    d = np.diff(knots)[:, None]
    v = values[1:-1]
    u_in = 3.0 * (v - tangents[:-1, 1]) / d[:-1]
    u_out = 3.0 * (tangents[1:, 0] - v) / d[1:]
    a2, b2 = d[:-1] ** 2, d[1:] ** 2
    u = (a2 * u_in + b2 * u_out) / (a2 + b2)
    tangents[:-1, 1] = v - u * d[:-1] / 3.0
    tangents[1:, 0] = v + u * d[1:] / 3.0
    return tangents


def _fit_root(root_at, rk, refinements, ft, start_time, oversample, continuity) -> Channel:
    """The root translation channel of :func:`~.fitting.fit_staggered` (§4.1.1): cubic Béziers through
    ``root_at(frames) (N, 3)`` at the knots ``rk (K,)`` s (``pose_times + refinements``), inner controls by least
    squares (C1-matched on "C1"), and the displacement table."""
    rk = np.asarray(rk, dtype=float)[:, None]
    rpair, rm, rcounts, rtn, rframes = sample_segments(rk, ft, start_time, oversample)
    ry = root_at(rframes)
    root_values = root_at((rk[:, 0] - start_time) / ft)
    p0, p3 = root_values[:-1], root_values[1:]
    ry[rm == 0] = p0[rpair[rm == 0]]
    ry[rm == rcounts[rpair] - 1] = p3[rpair[rm == rcounts[rpair] - 1]]
    rtan = fit_translation_tangents(rtn, ry, rpair, p0, p3, rk.shape[0] - 1)
    if continuity == "C1":
        rtan = match_translation_tangents(root_values, rtan, rk[:, 0])
    d = displacements_of(TRANSLATION, p0, rtan[:, 0], rtan[:, 1], p3, rpair, rtn, ry, rpair)
    table = displacement_table(rpair, rm, d, (rk.shape[0] - 1, int(rcounts.max()), 3))
    return Channel(TRANSLATION, root_values[:, None], rtan[:, None], np.asarray(refinements)[:, None], table[:, None],
                   rcounts[:, None])
