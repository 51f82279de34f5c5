"""Values the readers check and convert: decimal tokens (:func:`finite_number`, :func:`split_values`) and the
euler -> quaternion conversion of BVH and ASF/AMC channels (:func:`euler_deg_to_quat`, :func:`euler_components`).
Re-exported by :mod:`._common`."""
from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

import numpy as np

from ..core.rotations import quat_mul

if TYPE_CHECKING:
    from ._common import FormatError

__all__ = ["finite_number", "split_values", "MAX_TOKEN", "euler_components", "euler_deg_to_quat", "quarter_tan"]


#: A decimal number as files write it: ASCII digits only. ``float`` also takes ``1_000``, Arabic-Indic or
#: full-width digits, which no exporter writes and which would read differently elsewhere.
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:nan|inf|infinity)", re.ASCII | re.I)


def finite_number(tok: str, what: str, source: str, line: int, error: type[FormatError]) -> float:
    """``float(tok)`` of an ASCII decimal token, raising ``error`` naming ``what`` was expected if it is not
    a finite number."""
    if not _NUMBER.fullmatch(tok):
        raise error(source, line, f"expected a number for {what}, found {tok!r}")
    v = float(tok)
    if not math.isfinite(v):
        raise error(source, line, f"expected a finite number for {what}, found {tok!r}")
    return v


MAX_TOKEN = 1024  # characters of one value in a motion line (real files: <= 25)


def split_values(text, n: int, truncated: bool, what: str, source: str, line: int, error: type[FormatError]):
    """The ``n`` whitespace-separated values of ``text`` (``str`` or ``bytes``: a line, or its first
    characters when ``truncated``), split into at most ``n + 1`` pieces whatever the line holds; ``error``
    naming ``what`` (e.g. ``"on frame 3"``) when there are not exactly ``n``."""
    vals = text.split(None, n)
    if len(vals) <= n and truncated:
        raise error(source, line, f"expected {n} values {what}, found a value of more than {MAX_TOKEN} characters")
    if len(vals) != n:
        found = f"more than {n}" if len(vals) > n else str(len(vals))
        raise error(source, line, f"expected {n} values {what}, found {found}")
    return vals


_EULER_BLOCK = 16384  # rotations per block in euler_components (128 KB per temporary)


def quarter_tan(angles_deg: np.ndarray, tmp: np.ndarray) -> np.ndarray:
    """``tan(a/4)`` of angles ``a`` in degrees, in place (returns ``angles_deg``), after wrapping them to
    [-180, 180] when any lies outside (``tmp``: scratch of the same shape; an angle already inside keeps
    every bit, the sign of zero included, so no angle's result depends on its neighbours): the first step of
    :func:`_half_sin_cos`, shared with the BVH reader's C accelerator, which does the rest."""
    a = angles_deg
    if a.size and (a.max() > 180.0 or a.min() < -180.0):  # two reductions instead of four passes
        np.divide(a, 360.0, out=tmp)
        np.rint(tmp, out=tmp)
        tmp *= 360.0
        tmp += 0.0  # -0 -> +0: an angle in [-180, 180] is then unchanged to the bit, -0 included (-0 - -0 is +0),
        a -= tmp    # so whether a block was wrapped (it depends on how the block was cut) changes no bit
    a *= np.pi / 720.0  # a/4 in radians
    return np.tan(a, out=a)


def _half_sin_cos(angles_deg: np.ndarray, tmp: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``sin`` and ``cos`` of half of each angle (degrees), through one tangent: with ``t = tan(a/4)``,
    ``sin(a/2) = 2t / (1 + t^2)`` and ``cos(a/2) = (1 - t^2) / (1 + t^2)``. numpy vectorises ``tan`` but
    evaluates float64 ``sin``/``cos`` one value at a time (~15x slower here). Angles are first wrapped
    to [-180, 180] so ``|t| <= 1``; wrapping by 360 degrees negates the half-angle pair, i.e. the
    quaternion, which is the same rotation. Works in place: ``angles_deg`` is overwritten (it returns the
    sines) and ``tmp``, a float64 array of its shape (allocated when not given), receives the cosines."""
    # in place on two buffers: every fresh large temporary costs page faults, which are expensive in VMs
    if tmp is None:
        tmp = np.empty_like(angles_deg)
    t = quarter_tan(angles_deg, tmp)
    den = np.multiply(t, t, out=tmp)
    den += 1.0  # 1 + t^2
    np.divide(t, den, out=t)
    t *= 2.0  # sin(a/2) = 2t / (1 + t^2)
    np.divide(2.0, den, out=den)
    den -= 1.0  # cos(a/2) = (1 - t^2) / (1 + t^2) = 2 / (1 + t^2) - 1
    return t, den


def euler_components(angles: np.ndarray, axes: str, out: np.ndarray | None = None,
                     overwrite: bool = False) -> np.ndarray:
    """Component-major form of :func:`euler_deg_to_quat` for three distinct axes: ``angles (3, ...)``
    degrees (first index: the angle about ``axes[k]``) -> ``(4, ...)`` quaternion components x, y, z, w.
    Every step is one contiguous numpy operation on a block of ``_EULER_BLOCK`` rotations (the
    temporaries stay in cache and are reused: fresh pages are expensive in VMs). With ``out``, an
    ``(N, 4)`` float64 array (N rotations: ``angles`` holds ``(3, N)`` values), the components are written
    into its rows block by block (no transpose of the whole table afterwards) and ``out.T`` is returned.
    ``overwrite=True`` lets it use ``angles`` (a float64 array) as scratch, sparing a copy."""
    i, j, k = ("XYZ".index(ax) for ax in axes.upper())
    eps = 1.0 if (j - i) % 3 == 1 else -1.0  # +1 when e_i x e_j = e_k
    flat = np.asarray(angles, dtype=float).reshape(3, -1)
    N = flat.shape[1]
    # with ``out``, each block is computed contiguously (ufuncs writing strided columns are ~4x slower)
    # and copied into the block's rows of ``out`` with one 2-D transpose
    q = np.empty((4, N)) if out is None else None
    plus, minus = (np.add, np.subtract) if eps > 0 else (np.subtract, np.add)
    # one workspace for every temporary of every block: the cosines (3 rows), the four products, a copy of
    # the angles unless they may be overwritten, the block of components when written to ``out``. Many
    # separate 128 KB temporaries cost ~30 % more here (each a fresh allocation and its page faults)
    B = min(N, _EULER_BLOCK)
    work = np.empty((7 + (0 if overwrite else 3) + (0 if out is None else 4), B))
    for r0 in range(0, N, _EULER_BLOCK):
        r1 = min(N, r0 + _EULER_BLOCK)
        n = r1 - r0
        if overwrite:
            ang = flat[:, r0:r1]
        else:
            ang = work[7:10, :n]
            np.copyto(ang, flat[:, r0:r1])
        qb = q[:, r0:r1] if out is None else work[-4:, :n]
        (s1, s2, s3), (c1, c2, c3) = _half_sin_cos(ang, work[0:3, :n])
        c1c2 = np.multiply(c1, c2, out=work[3, :n])
        s1s2 = np.multiply(s1, s2, out=work[4, :n])
        s1c2 = np.multiply(s1, c2, out=work[5, :n])
        c1s2 = np.multiply(c1, s2, out=work[6, :n])
        tmp = np.multiply(c1s2, s3, out=s1)  # s1 is no longer needed: its buffer holds each second term
        plus(np.multiply(s1c2, c3, out=qb[i]), tmp, out=qb[i])  # s1 c2 c3 + eps c1 s2 s3
        np.multiply(s1c2, s3, out=tmp)
        minus(np.multiply(c1s2, c3, out=qb[j]), tmp, out=qb[j])  # c1 s2 c3 - eps s1 c2 s3
        np.multiply(s1s2, c3, out=tmp)
        plus(np.multiply(c1c2, s3, out=qb[k]), tmp, out=qb[k])  # c1 c2 s3 + eps s1 s2 c3
        np.multiply(s1s2, s3, out=tmp)
        minus(np.multiply(c1c2, c3, out=qb[3]), tmp, out=qb[3])  # c1 c2 c3 - eps s1 s2 s3
        if out is not None:
            out[r0:r1] = qb.T
    return q.reshape((4,) + np.shape(angles)[1:]) if out is None else out.T


def euler_deg_to_quat(angles_deg: np.ndarray, axes: str) -> np.ndarray:
    """Intrinsic rotations about ``axes`` (e.g. ``"ZXY"``: the BVH channel order, first axis outermost,
    ``R = Rz Rx Ry``) by ``angles_deg (..., len(axes))`` degrees -> unit quaternions ``(..., 4)``
    (x, y, z, w). Three distinct axes use the closed-form product of the elementary quaternions
    (:func:`euler_components`; scipy's ``from_euler`` is ~20x slower here); agrees with
    ``Rotation.from_euler(axes.upper(), ...)`` (checked in tests/test_io_bvh.py)."""
    axes = axes.upper()
    idx = ["XYZ".index(ax) for ax in axes]
    if len(axes) == 3 and len(set(axes)) == 3:
        ang = np.asarray(angles_deg, dtype=float)
        comps = euler_components(ang.reshape(-1, 3).T, axes)
        q = np.empty((comps.shape[1], 4))
        for c in range(4):
            q[:, c] = comps[c]
        return q.reshape(ang.shape[:-1] + (4,))
    a = np.radians(np.asarray(angles_deg, dtype=float))
    a *= 0.5
    s, c = np.sin(a), np.cos(a)
    q = np.zeros(a.shape[:-1] + (4,))
    q[..., 3] = 1.0
    for n, k in enumerate(idx):
        e = np.zeros(q.shape)
        e[..., k] = s[..., n]
        e[..., 3] = c[..., n]
        q = quat_mul(q, e)
    return q
