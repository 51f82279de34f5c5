"""Component-first quaternion kernels for the hot loops of ``evaluate()`` and the spline fit.

Quaternions here are ``(4, N)`` arrays (rows x, y, z, w): whole rows vectorise, while reducing over a
length-4 last axis does not. Two measured costs shape the code:

* numpy's float64 ``sin`` runs scalar libm on this platform, ~15x slower than the degree-19 Horner
  polynomial :func:`sin_poly` (exact to double rounding on [0, pi/2], the only range slerp needs);
* every fresh array of more than ~128 KiB is mmap-ed and page-faulted in on first touch, which in a VM costs
  more than the arithmetic. The ``*_into`` kernels therefore write into buffers of a thread-local,
  grow-only :class:`Workspace` that is reused from call to call (one slider move to the next).
"""
from __future__ import annotations

import bisect
import math
import threading

import numpy as np

from ..core.accel import NO_ACCEL_ENV, accel_allowed  # noqa: F401 (NO_ACCEL_ENV: the switch's name, here too)
from ..core.rotations import quat_mul_components

try:
    from . import _cspline  # the optional C kernel of evaluate's samples (setup.py builds it where a compiler is found)
except ImportError:  # pragma: no cover - depends on the build
    _cspline = None


MIN_ARC = 1e-8  # arcs below this (radians on S^3) use this angle: slerp weights then equal lerp to ~1e-16


class Workspace(threading.local):
    """Named, grow-only scratch buffers (one set per thread)."""

    def __init__(self):
        self.bufs: dict[str, np.ndarray] = {}
        self.views: dict[str, dict] = {}      # per key: shape as asked -> view of the current buffer

    def get(self, key: str, shape) -> np.ndarray:
        views = self.views.get(key)
        if views is not None:
            v = views.get(shape)
            if v is not None:                  # the fit and evaluate ask the same shapes over and over
                return v
        dims = (int(shape),) if np.isscalar(shape) else tuple(int(s) for s in shape)
        size = math.prod(dims)
        b = self.bufs.get(key)
        if b is None or b.size < size:
            b = np.empty(max(size, 1))
            self.bufs[key] = b
            views = None
        if views is None or len(views) >= 8:
            views = self.views[key] = {}
        v = views[shape] = b[:size].reshape(dims)
        return v


WORK = Workspace()


_TAYLOR = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(10)]   # x, x^3, ..., x^19


# |x| below _TERM_LIMITS[n - 1]: n terms leave a first omitted term xmax^(2n+1) / (2n+1)! below 1e-16
_TERM_LIMITS = [(1e-16 * math.factorial(2 * n + 1)) ** (1.0 / (2 * n + 1)) for n in range(1, 10)]


_TAYLOR_ARR = np.array(_TAYLOR)
_LIMITS_ARR = np.array(_TERM_LIMITS)


def accelerated() -> bool:
    """Whether :func:`rotations_block_c` runs (the C kernel is built and ``STAGGER_NB_NO_ACCEL`` is unset or 0)."""
    return _cspline is not None and accel_allowed()


def rotations_block_c(ctrl, arcp, table, counts, M: int, idx, t, out, s0: int, work: Workspace) -> bool:
    """``evaluation._rotations_block`` in C (``_cspline.c``: the same operations in the same order, so
    the same bits, in one loop per level instead of one numpy pass per operation) into ``out[:, s0:s0 + n]``
    of a C-contiguous ``out (4, N)``. ``ctrl (16, P)``, ``arcp (9, P)``, ``table (3, P * M)`` float64 and
    ``counts (P,)``, ``idx (n,)`` int64 contiguous, ``t (n,)``; ``M = 0`` (``table`` empty, ``counts`` any
    P int64): no displacement, the spline renormalised (``bezier_into``'s default). The three per-sample arcs'
    angles are numpy's ``arccos`` between the kernel's four stages. False when the kernel is not built or disabled
    (the caller then runs the numpy path)."""
    if not accelerated():
        return False
    n = t.shape[0]
    w = work.get("cs_work", (56, n))
    args = (ctrl, arcp, table, counts, int(M), idx, t, out.reshape(-1)[s0:], out.shape[1], w, _TAYLOR_ARR, _LIMITS_ARR)
    for stage in range(4):
        if stage:
            np.arccos(w[47], out=w[46])          # rows 45-47 of the scratch: the arc in progress (sg, th, ct)
        _cspline.rotations_block(stage, *args)
    return True


def _terms_for(xmax: float) -> int:
    """Fewest Taylor terms of sin whose first omitted term is below 1e-16 for |x| <= xmax (<= 10)."""
    return bisect.bisect_right(_TERM_LIMITS, xmax) + 1


def sin_poly(x: np.ndarray, out: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``out = sin(x)`` for ``x`` in [-pi/2, pi/2] (error < 3e-16); ``z`` is scratch of the same shape.

    A Horner scheme on ``x²`` whose degree adapts to ``max |x|``: small arcs (the usual case between a
    segment's control quaternions) need 5-7 terms instead of 10."""
    n = _terms_for(max(float(x.max()), -float(x.min()))) if x.size else 1
    np.multiply(x, x, out=z)
    out.fill(_TAYLOR[n - 1])
    for c in _TAYLOR[n - 2::-1]:
        out *= z
        out += c
    out *= x
    return out


def dot_into(a, b, out, tmp):
    np.multiply(a[0], b[0], out=out)
    for r in (1, 2, 3):
        np.multiply(a[r], b[r], out=tmp)
        out += tmp
    return out


def arc_into(a, b, out, tmp, tmp2):
    """First-level arc data of ``a -> b`` (4, N), shortest way, into ``out (3, N)``:
    rows ``sgn/sin θ``, ``θ``, ``cos θ / sin θ`` with θ in [MIN_ARC, pi/2]."""
    d = dot_into(a, b, tmp, tmp2)
    sgn_inv, theta, cot = out
    np.abs(d, out=cot)
    np.minimum(cot, 1.0, out=cot)
    np.arccos(cot, out=theta)
    np.maximum(theta, MIN_ARC, out=theta)
    sin_poly(theta, sgn_inv, tmp2)
    np.divide(1.0, sgn_inv, out=sgn_inv)
    cot *= sgn_inv
    np.copysign(sgn_inv, d, out=sgn_inv)
    return out


def slerp_into(a, b, t, arc, out, s, w0, z, z4=None):
    """``out (4, N) = slerp(a, b, t)`` along the short arc, given ``arc`` from :func:`arc_into`.

    Uses ``sin(uθ)/sin θ = cos(tθ) - cos θ sin(tθ)/sin θ`` (one sine), with ``cos(tθ) = sqrt(1 - sin²)``
    (tθ <= pi/2). ``s, w0, z`` are (N,) scratch, ``z4`` optional (4, N) scratch (fewer numpy calls, same
    values). ``out`` must not alias ``a`` or ``b``.
    """
    sgn_inv, theta, cot = arc
    np.multiply(t, theta, out=w0)
    sin_poly(w0, s, z)
    np.multiply(s, s, out=w0)
    np.subtract(1.0, w0, out=w0)
    np.maximum(w0, 0.0, out=w0)
    np.sqrt(w0, out=w0)
    np.multiply(cot, s, out=z)
    w0 -= z
    s *= sgn_inv
    np.multiply(a, w0, out=out)
    if z4 is not None:
        np.multiply(b, s, out=z4)
        out += z4
        return out
    for r in range(4):
        np.multiply(b[r], s, out=z)
        out[r] += z
    return out


def bezier_into(c0, c1, c2, c3, t, arcs, work: Workspace = WORK, tag: str = "", normalize: bool = True) -> np.ndarray:
    """Recursive-slerp quaternion Bézier (Appendix A) of (4, N) controls at ``t (N,)`` into a workspace
    buffer (valid until the next call with the same ``tag``). ``arcs``: three (3, N) first-level arcs or
    None to compute them. ``normalize=False`` skips the final renormalisation (slerps of unit quaternions
    are unit to ~1e-15: for callers that renormalise anyway, e.g. ``evaluate``'s ``Motion``)."""
    N = t.shape[0]
    g = lambda k, sh: work.get(tag + k, sh)  # noqa: E731
    s, w0, z, tmp, z4 = g("s", N), g("w0", N), g("z", N), g("tmp", N), g("z4", (4, N))
    if arcs is None:
        arcs = [arc_into(x, y, g(f"arc{i}", (3, N)), tmp, z) for i, (x, y) in enumerate(((c0, c1), (c1, c2), (c2, c3)))]
    A = slerp_into(c0, c1, t, arcs[0], g("A", (4, N)), s, w0, z, z4)
    B = slerp_into(c1, c2, t, arcs[1], g("B", (4, N)), s, w0, z, z4)
    C = slerp_into(c2, c3, t, arcs[2], g("C", (4, N)), s, w0, z, z4)
    arc = g("arcL", (3, N))
    D = slerp_into(A, B, t, arc_into(A, B, arc, tmp, z), g("D", (4, N)), s, w0, z, z4)
    E = slerp_into(B, C, t, arc_into(B, C, arc, tmp, z), A, s, w0, z, z4)         # A is free again
    out = slerp_into(D, E, t, arc_into(D, E, arc, tmp, z), C, s, w0, z, z4)       # C is free again
    if not normalize:
        return out
    dot_into(out, out, tmp, z)
    np.sqrt(tmp, out=tmp)
    out /= tmp
    return out


def qexp_into(v, out, h, tmp):
    """``out (4, N) = exp(v)`` for half rotation vectors ``v (3, N)`` (``axis * angle / 2``) with
    ``|v| <= pi`` (rotations up to a full turn: displacement maps are unwrapped, see ``fitting``).
    ``h, tmp``: (N,) scratch."""
    np.multiply(v[0], v[0], out=h)
    for r in (1, 2):
        np.multiply(v[r], v[r], out=tmp)
        h += tmp
    np.sqrt(h, out=h)
    np.minimum(h, np.pi, out=h)
    if h.size and h.max() <= 1.0:       # the usual case (displacements below 2 rad): cos h = sqrt(1 - sin^2 h)
        sin_poly(h, out[1], tmp)        # is exact to ~4e-16 there (cos h >= 0.54) and saves a degree-19 sine
        np.multiply(out[1], out[1], out=out[3])
        np.subtract(1.0, out[3], out=out[3])
        np.sqrt(out[3], out=out[3])
        sinc = out[0]
    else:
        sinc = _sin_cos_wide(h, out, tmp)
    np.maximum(h, 1e-6, out=tmp)
    np.divide(out[1], tmp, out=sinc)                 # sin(h)/h; below 1e-6 use the Taylor value
    small = h < 1e-6
    if small.any():
        sinc[small] = 1.0 - h[small] ** 2 / 6.0
    np.multiply(v[1], sinc, out=out[1])
    np.multiply(v[2], sinc, out=out[2])
    np.multiply(v[0], sinc, out=out[0])
    return out


def _sin_cos_wide(h, out, tmp):
    """``out[3] = cos h``, ``out[1] = sin h`` for ``h`` in [0, pi] (:func:`qexp_into`'s general case);
    returns ``out[0]`` (scratch)."""
    np.subtract(np.pi / 2, h, out=out[0])
    sin_poly(out[0], out[3], tmp)                    # cos h = sin(pi/2 - h), argument in [-pi/2, pi/2]
    sinc = out[0]
    np.subtract(np.pi, h, out=tmp)
    np.minimum(tmp, h, out=sinc)                     # sin h = sin(min(h, pi - h))
    sin_poly(sinc, out[1], tmp)
    return sinc


def qmul_into(a, b, out, tmp):
    """Hamilton product of (4, N) quaternions into ``out`` (must not alias ``a`` or ``b``); ``tmp`` (N,):
    :func:`~stagger_nb.core.rotations.quat_mul_components` on the rows."""
    return quat_mul_components(a, b, out, tmp)


def rotvec_between_into(a, b, out, work: Workspace = WORK, tag: str = "rv") -> np.ndarray:
    """``out (3, N)``: rotation vectors (radians, the short way) of ``a^-1 b`` for (4, N) unit quaternions."""
    N = a.shape[1]
    r = work.get(tag + "r", (4, N))
    tmp = work.get(tag + "tmp", N)
    ac = work.get(tag + "ac", (4, N))
    np.negative(a[:3], out=ac[:3])
    ac[3] = a[3]
    qmul_into(ac, b, r, tmp)
    sgn = np.copysign(1.0, r[3], out=work.get(tag + "sgn", N))
    s = work.get(tag + "s", N)
    np.multiply(r[0], r[0], out=s)
    for k in (1, 2):
        np.multiply(r[k], r[k], out=tmp)
        s += tmp
    np.sqrt(s, out=s)
    np.multiply(r[3], sgn, out=tmp)
    np.arctan2(s, tmp, out=tmp)                       # half angle in [0, pi/2]
    tmp *= 2.0
    small = s <= 1e-12
    np.maximum(s, 1e-12, out=s)
    np.divide(tmp, s, out=tmp)
    if small.any():
        tmp[small] = 2.0                               # angle/|v| -> 2/w, w -> 1
    tmp *= sgn
    np.multiply(r[:3], tmp, out=out)
    return out


def bezier(c0, c1, c2, c3, t, arcs=None) -> np.ndarray:
    """Allocating :func:`bezier_into` on (4, N) controls; returns a fresh (4, N) array."""
    return bezier_into(c0, c1, c2, c3, np.ascontiguousarray(t, dtype=float), arcs, tag="bz").copy()


def rotvec_between(a, b) -> np.ndarray:
    """Allocating :func:`rotvec_between_into`: (3, N) rotation vectors of ``a^-1 b``."""
    return rotvec_between_into(a, b, np.empty((3, a.shape[1])))


def qmul(a, b) -> np.ndarray:
    return qmul_into(a, b, np.empty((4,) + a.shape[1:]), np.empty(a.shape[1:]))


def qexp(v) -> np.ndarray:
    """(3, N) half rotation vectors with |v| <= pi/2 -> (4, N) unit quaternions."""
    N = v.shape[1]
    return qexp_into(v, np.empty((4, N)), np.empty(N), np.empty(N))


def arcs_of(c0, c1, c2, c3) -> list:
    """The three first-level arcs (3, N) of control polygons (4, N)."""
    N = c0.shape[1]
    tmp, z = np.empty(N), np.empty(N)
    return [arc_into(a, b, np.empty((3, N)), tmp, z) for a, b in ((c0, c1), (c1, c2), (c2, c3))]


CHUNK = 8192   # samples per block of the chunked kernels: their scratch stays in cache (~2x faster than whole)


def take_cols_into(a, idx, out):
    """``out[r] = a[r, idx]`` for each row of ``a (R, P)`` (1-D gathers, much faster than ``take(axis=1)``).
    ``idx`` must be valid (0 <= idx < P): ``mode="wrap"`` skips the buffered bounds check (4x faster)."""
    for r in range(a.shape[0]):
        np.take(a[r], idx, out=out[r], mode="wrap")
    return out


def _pair_arcs(c0, c1, c2, c3, work: Workspace, tag: str) -> np.ndarray:
    """The three first-level arcs of per-pair control polygons ``(4, P)`` as one ``(9, P)`` workspace array."""
    P = c0.shape[1]
    arcs = work.get(tag + "arcs", (9, P))
    tmp, z = work.get(tag + "atmp", P), work.get(tag + "az", P)
    for i, (a, b) in enumerate(((c0, c1), (c1, c2), (c2, c3))):
        arc_into(a, b, arcs[3 * i:3 * i + 3], tmp, z)
    return arcs


def _spline_blocks(c0, c1, c2, c3, pair, t, work: Workspace, tag: str):
    """Yield ``(start, stop, spline (4, n))`` blocks of ``CHUNK`` samples of per-pair Béziers: controls and
    their first-level arcs computed once per pair and gathered per block (a pair's arcs do not depend on t).
    Through the C kernel where built (:func:`rotations_block_c` without displacement: the same bits)."""
    arcs = _pair_arcs(c0, c1, c2, c3, work, tag)
    N = t.shape[0]
    if accelerated():
        P = c0.shape[1]
        ctrl = work.get(tag + "cctrl", (16, P))
        for i, c in enumerate((c0, c1, c2, c3)):
            ctrl[4 * i:4 * i + 4] = c
        pair = np.ascontiguousarray(pair, dtype=np.int64)
        t = np.ascontiguousarray(t, dtype=float)
        none, zeros = np.empty(0), np.zeros(P, np.int64)
        for s in range(0, N, CHUNK):
            e = min(N, s + CHUNK)
            out = work.get(tag + "cout", (4, e - s))
            rotations_block_c(ctrl, arcs, none, zeros, 0, pair[s:e], t[s:e], out, 0, work)
            yield s, e, out
        return
    for s in range(0, N, CHUNK):
        e = min(N, s + CHUNK)
        idx = pair[s:e]
        g = [take_cols_into(c, idx, work.get(f"{tag}c{i}", (4, e - s))) for i, c in enumerate((c0, c1, c2, c3))]
        a = take_cols_into(arcs, idx, work.get(tag + "ga", (9, e - s)))
        yield s, e, bezier_into(*g, t[s:e], (a[0:3], a[3:6], a[6:9]), work, tag=tag)


def spline_residual_into(targets, c0, c1, c2, c3, pair, t, out, work: Workspace = WORK) -> np.ndarray:
    """``out (3, N)``: rotation vectors from ``targets (4, N)`` to the quaternion Béziers of per-pair controls
    ``c0..c3 (4, P)`` at ``t (N,)`` for pair ``pair (N,)`` (``log(q^-1 s(t))``), in blocks of ``CHUNK``."""
    for s, e, sp in _spline_blocks(c0, c1, c2, c3, pair, t, work, "sr_"):
        rotvec_between_into(targets[:, s:e], sp, out[:, s:e], work, tag="sr_rv")
    return out


def spline_into(c0, c1, c2, c3, pair, t, out, work: Workspace = WORK) -> np.ndarray:
    """``out (4, N)``: quaternion Béziers of per-pair controls ``c0..c3 (4, P)`` at ``t (N,)`` for pair
    ``pair (N,)``, in blocks of ``CHUNK``."""
    for s, e, sp in _spline_blocks(c0, c1, c2, c3, pair, t, work, "sp_"):
        out[:, s:e] = sp
    return out
