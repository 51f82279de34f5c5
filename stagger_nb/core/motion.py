"""A frozen, uniformly sampled skeletal motion.

Glossary used across the package: F frames, J joints, K staggered poses, D degrees of freedom.
Times at the API are seconds; frame ranges are half-open ``[start, stop)``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._arrays import readonly
from .rotations import quat_continuous, quat_normalize, slerp
from .skeleton import Skeleton

__all__ = ["Motion", "concatenate", "MIN_FRAME_TIME", "MAX_FRAME_TIME", "MAX_FRAME_JOINTS"]

_UNIT_TOL = 1e-12  # |norm - 1| above which a quaternion is renormalised on construction

#: Shortest frame time accepted (seconds): 10 kHz. The fastest optical capture systems record at 1-2 kHz,
#: and the techniques' costs grow with the frame rate (smoothing passes in ``staggered.extract`` grow as
#: 1/frame_time^2), so a shorter frame time is a corrupt file, not a capture.
MIN_FRAME_TIME = 1e-4
#: Longest frame time accepted (seconds): one frame an hour. Longer ones overflow durations and rates.
MAX_FRAME_TIME = 3600.0
#: Most frames x joints a reader or a core function allocates from a file or a user-given number
#: (resampling): 4 x 10^6 joint samples, 128 MB of quaternions (a 1-joint rig: + 96 MB of root positions),
#: so reading or resampling to the limit stays within ~500 MB. A 100,000-frame, 31-joint take holds
#: 3.1 x 10^6. (It was 10^7: a 20 MB file of 10^7 one-channel frames read at 674 MB, and resampling
#: CMU 01_01 to 1e-4 s peaked at 1.28 GB.)
MAX_FRAME_JOINTS = 4_000_000
#: Frames slerped at once by :meth:`Motion.sample`, times joints (temporaries of ~10 MB).
_SAMPLE_BLOCK = 1 << 16


def check_frame_time(frame_time, name: str = "frame_time") -> float:
    """``frame_time`` as a float within [MIN_FRAME_TIME, MAX_FRAME_TIME] seconds; ``ValueError`` naming
    ``name`` otherwise."""
    try:
        ft = float(frame_time)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number of seconds, got {frame_time!r}") from None
    if not np.isfinite(ft) or ft <= 0:
        raise ValueError(f"{name} must be a positive number of seconds, got {frame_time!r}")
    if not MIN_FRAME_TIME <= ft <= MAX_FRAME_TIME:
        raise ValueError(f"{name} must be between {MIN_FRAME_TIME:g} s ({1 / MIN_FRAME_TIME:g} Hz) and "
                         f"{MAX_FRAME_TIME:g} s, got {ft:g}")
    return ft


def check_frame_count(frames: int, joints: int, name: str) -> int:
    """``frames`` if ``frames * joints`` is within :data:`MAX_FRAME_JOINTS`; else a ``ValueError`` naming
    ``name``, the size and the remedy, raised before anything is allocated."""
    if frames * max(joints, 1) > MAX_FRAME_JOINTS:
        raise ValueError(f"{name} asks for {frames:,} frames x {joints} joints, more than the "
                         f"{MAX_FRAME_JOINTS:,} joint samples supported: use a longer frame time or a shorter "
                         f"clip (Motion.slice)")
    return frames


@dataclass(frozen=True, eq=False)
class Motion:
    """Skeletal motion sampled every ``frame_time`` seconds.

    Attributes
    ----------
    skeleton : Skeleton
    frame_time : float
        Seconds between frames (> 0).
    root_positions : ndarray, shape (F, 3)
        World translation of the root joint, file units.
    local_quats : ndarray, shape (F, J, 4), (x, y, z, w)
        Unit quaternions of each joint relative to its parent; made hemisphere-continuous over time
        on construction (``q`` and ``-q`` are the same rotation; consecutive frames have dot >= 0).
    local_translations : ndarray, shape (F, J, 3), or None
        Per-frame translation of each joint relative to its parent, for files that animate non-root
        joint positions (BVH position channels replace the OFFSET). ``None`` means ``skeleton.offsets``.
        Row 0 (the root) is ignored: ``root_positions`` is the root's translation.
    staggered : StaggeredMotion or None
        The staggered motion this one is the evaluation of, on its default frames, or ``None``: set by
        ``staggered.evaluate`` and the contact layer only (any other new Motion, from ``replace``, ``slice``,
        ``resample``, a reader or an edit of the frames, has ``None``). :func:`stagger_nb.quality.compare` reads
        it to carry the source's contacts through the staggered timing edit (its ``staggered=`` default). Not
        validated, not copied, never written to files.
    """

    skeleton: Skeleton
    frame_time: float
    root_positions: np.ndarray
    local_quats: np.ndarray
    local_translations: np.ndarray | None = None
    staggered: Any = field(default=None, repr=False, metadata={"shared": True})

    def __post_init__(self):
        ft = check_frame_time(self.frame_time, "Motion: frame_time")
        if not isinstance(self.skeleton, Skeleton):
            raise ValueError(f"Motion: skeleton must be a Skeleton, got {type(self.skeleton).__name__}")
        J = self.skeleton.num_joints
        q = np.asarray(self.local_quats, dtype=float)
        if q.ndim != 3 or q.shape[1:] != (J, 4):
            raise ValueError(f"Motion: local_quats must have shape (F, {J}, 4), got {q.shape}")
        F = q.shape[0]
        rp = np.asarray(self.root_positions, dtype=float)
        if rp.shape != (F, 3):
            raise ValueError(f"Motion: root_positions must have shape ({F}, 3), got {rp.shape}")
        lt = self.local_translations
        if lt is not None:
            lt = np.asarray(lt, dtype=float)
            if lt.shape != (F, J, 3):
                raise ValueError(f"Motion: local_translations must have shape ({F}, {J}, 3), got {lt.shape}")
            if not np.all(np.isfinite(lt)):
                raise ValueError("Motion: local_translations must be finite (no NaN / inf)")
            lt = readonly(lt)
        for name, a in (("local_quats", q), ("root_positions", rp)):
            if not np.all(np.isfinite(a)):
                raise ValueError(f"Motion: {name} must be finite (no NaN / inf)")
        object.__setattr__(self, "frame_time", ft)
        # renormalise only what is not unit already, so slicing / replacing keeps values bit for bit
        off = np.abs(np.sqrt(np.einsum("fji,fji->fj", q, q)) - 1.0) > _UNIT_TOL
        if off.any():
            q = np.where(off[..., None], quat_normalize(q), q)
        q = quat_continuous(q, axis=0)  # a new array: the caller's is never aliased
        q.setflags(write=False)
        object.__setattr__(self, "local_quats", q)
        object.__setattr__(self, "root_positions", readonly(rp))
        object.__setattr__(self, "local_translations", lt)

    @classmethod
    def _from_owned(cls, skeleton: Skeleton, frame_time: float, root_positions: np.ndarray,
                    local_quats: np.ndarray, local_translations: np.ndarray | None = None,
                    continuous: bool = False) -> Motion:
        """Package-internal constructor for arrays the caller has just made and hands over (the readers):
        finite, float64, C-contiguous, of the right shapes, quaternions unit to rounding. They are taken
        without copies (made hemisphere-continuous in place, then read-only), so reading a long take
        holds one quaternion table, not three. ``continuous=True``: the caller already made the
        quaternions continuous exactly as :func:`.rotations.quat_continuous` would (the BVH reader's C
        accelerator does)."""
        ft = check_frame_time(frame_time, "Motion: frame_time")
        if not continuous:
            _continuous_inplace(local_quats)
        obj = object.__new__(cls)
        for name, a in (("root_positions", root_positions), ("local_quats", local_quats),
                        ("local_translations", local_translations)):
            if a is not None:
                a.setflags(write=False)
            object.__setattr__(obj, name, a)
        object.__setattr__(obj, "skeleton", skeleton)
        object.__setattr__(obj, "frame_time", ft)
        return obj

    @classmethod
    def _trusted(cls, skeleton: Skeleton, frame_time: float, root_positions: np.ndarray, local_quats: np.ndarray,
                 local_translations: np.ndarray | None = None, staggered=None) -> Motion:
        """Package-internal constructor for a result the library has just computed from valid motions
        (``staggered.evaluate``, the constraint layer): ``local_quats`` (F, J, 4) float64 is owned by the new
        Motion (not aliased by anyone: it is modified in place), the other arrays are finite float64 of the
        right shapes and not written afterwards. Skips the checks of :meth:`__post_init__` (shapes,
        finiteness) and its copies, and does the rest the same way (renormalising what is off unit by
        more than 1e-12, hemisphere continuity), so the values equal ``Motion(...)``'s bit for bit."""
        q = local_quats
        off = np.abs(np.sqrt(np.einsum("fji,fji->fj", q, q)) - 1.0) > _UNIT_TOL
        if off.any():
            q[off] = quat_normalize(q[off])
        _continuous_inplace(q)
        q.setflags(write=False)
        obj = object.__new__(cls)
        for name, a in (("root_positions", root_positions), ("local_translations", local_translations)):
            if a is not None and a.flags.writeable:
                a = a.view()
                a.setflags(write=False)
            object.__setattr__(obj, name, a)
        object.__setattr__(obj, "local_quats", q)
        object.__setattr__(obj, "skeleton", skeleton)
        object.__setattr__(obj, "frame_time", float(frame_time))
        object.__setattr__(obj, "staggered", staggered)
        return obj

    def _evaluated_from(self, sm) -> Motion:
        """Package-internal: this motion (its arrays shared, read-only) as the evaluation of the staggered
        motion ``sm`` on its default frames (:attr:`staggered`)."""
        obj = object.__new__(type(self))
        obj.__dict__.update(self.__dict__)
        object.__setattr__(obj, "staggered", sm)
        return obj

    # -- basic properties -------------------------------------------------------------------------
    @property
    def num_frames(self) -> int:
        return int(self.local_quats.shape[0])

    @property
    def num_joints(self) -> int:
        return self.skeleton.num_joints

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame: ``(F - 1) * frame_time``."""
        return (self.num_frames - 1) * self.frame_time

    @property
    def times(self) -> np.ndarray:
        """Frame times in seconds, shape (F,)."""
        return np.arange(self.num_frames) * self.frame_time

    def translations(self) -> np.ndarray:
        """Per-frame joint translations ``(F, J, 3)`` (offsets broadcast where not animated), root row
        = ``root_positions``."""
        if self.local_translations is None:
            t = np.broadcast_to(self.skeleton.offsets, (self.num_frames, self.num_joints, 3)).copy()
        else:
            t = np.array(self.local_translations)
        t[:, 0] = self.root_positions
        return t

    # -- new motions ------------------------------------------------------------------------------
    def replace(self, **changes) -> Motion:
        """A new Motion with some fields replaced (validated again)."""
        fields = dict(skeleton=self.skeleton, frame_time=self.frame_time, root_positions=self.root_positions,
                      local_quats=self.local_quats, local_translations=self.local_translations)
        fields.update(changes)
        return Motion(**fields)

    def slice(self, start: int | None = None, stop: int | None = None, step: int | None = None) -> Motion:
        """Frames ``[start, stop)`` (every ``step``-th, ``step >= 1``) as a new Motion; ``start``/``stop``
        are integers (or None) with Python's meaning of negative indices. ``ValueError`` names the argument."""
        for name, v in (("start", start), ("stop", stop), ("step", step)):
            if v is not None and (isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer))):
                raise ValueError(f"Motion.slice: {name} must be an integer frame index or None, got {v!r}")
        if step is not None and step < 1:
            raise ValueError(f"Motion.slice: step must be a positive integer, got {step}")
        if step is not None and step > 1:
            check_frame_time(self.frame_time * int(step), f"Motion.slice: step={step} (frame time x step)")
        sl = slice(start, stop, step)
        idx = np.arange(self.num_frames)[sl]
        if idx.size == 0:
            raise ValueError(f"Motion.slice: start, stop: frames [{start}, {stop}) of a {self.num_frames}-frame "
                             "motion are empty")
        lt = None if self.local_translations is None else self.local_translations[sl]
        return Motion(self.skeleton, self.frame_time * (step or 1), self.root_positions[sl],
                      self.local_quats[sl], lt)

    def sample(self, frames: np.ndarray, frame_time: float | None = None) -> Motion:
        """Evaluate at fractional frame indices ``frames (N,)`` (clamped to the clip): rotations by slerp,
        translations linearly. The result is sampled every ``frame_time`` (default: this one)."""
        f = np.clip(np.asarray(frames, dtype=float).reshape(-1), 0.0, self.num_frames - 1)
        n, J = f.size, self.num_joints
        q = np.empty((n, J, 4))
        rp = np.empty((n, 3))
        lt = None if self.local_translations is None else np.empty((n, J, 3))
        step = max(1, _SAMPLE_BLOCK // max(J, 1))  # blocks of frames: slerp's temporaries stay ~10 MB
        for b0 in range(0, n, step):
            fb = f[b0:b0 + step]
            i0 = np.minimum(np.floor(fb).astype(int), self.num_frames - 1)
            i1 = np.minimum(i0 + 1, self.num_frames - 1)
            a = fb - i0
            q[b0:b0 + step] = slerp(self.local_quats[i0], self.local_quats[i1], a[:, None])
            rp[b0:b0 + step] = self.root_positions[i0] * (1 - a)[:, None] + self.root_positions[i1] * a[:, None]
            if lt is not None:
                lt[b0:b0 + step] = (self.local_translations[i0] * (1 - a)[:, None, None]
                                    + self.local_translations[i1] * a[:, None, None])
        return Motion(self.skeleton, self.frame_time if frame_time is None else frame_time, rp, q, lt)

    def sample_times(self, times: np.ndarray, frame_time: float | None = None) -> Motion:
        """Like :meth:`sample` with times in seconds."""
        return self.sample(np.asarray(times, dtype=float) / self.frame_time, frame_time)

    def resample(self, frame_time: float) -> Motion:
        """Resample to a new frame time (seconds) covering the same duration (slerp / linear).

        Raises ``ValueError`` naming ``frame_time`` when it is outside [MIN_FRAME_TIME, MAX_FRAME_TIME] or
        the result would hold more than :data:`MAX_FRAME_JOINTS` frames x joints (checked before
        allocating)."""
        frame_time = check_frame_time(frame_time, "Motion.resample: frame_time")
        n = int(np.floor(self.duration / frame_time + 1e-9)) + 1
        check_frame_count(n, self.num_joints, f"Motion.resample: frame_time={frame_time:g}")
        return self.sample_times(np.arange(n) * frame_time, frame_time)

    def __len__(self) -> int:
        return self.num_frames

    def __repr__(self) -> str:
        return (f"Motion({self.num_frames} frames @ {self.fps:.4g} Hz = {self.duration:.3f} s, "
                f"{self.num_joints} joints)")


def _continuous_inplace(q: np.ndarray, block: int = 4096) -> None:
    """Flip signs of ``q (F, J, 4)`` in place so consecutive frames have dot >= 0 (as
    :func:`.rotations.quat_continuous`), in blocks of frames so the temporaries stay small."""
    F = q.shape[0]
    for f0 in range(0, F, block):
        f1 = min(F, f0 + block)
        lo = max(f0 - 1, 0)
        seg = q[lo:f1]
        neg = np.einsum("fji,fji->fj", seg[1:], seg[:-1]) < 0  # against the (already fixed) previous frame
        if lo == f0:  # first block: frame 0 is never flipped
            neg = np.concatenate([np.zeros((1,) + neg.shape[1:], dtype=bool), neg])
        flips = np.logical_xor.accumulate(neg, axis=0)  # odd number of sign changes so far
        if flips.any():
            q[f0:f1][flips] *= -1.0


def concatenate(motions: list[Motion]) -> Motion:
    """Join motions end to end (same skeleton and frame time); root positions are kept as they are."""
    if not motions:
        raise ValueError("concatenate: no motions given")
    first = motions[0]
    for k, m in enumerate(motions[1:], 1):
        if m.skeleton != first.skeleton:
            raise ValueError(f"concatenate: motion {k} has a different skeleton")
        if abs(m.frame_time - first.frame_time) > 1e-12:
            raise ValueError(f"concatenate: motion {k} has frame_time {m.frame_time}, expected {first.frame_time}")
    has_lt = any(m.local_translations is not None for m in motions)
    lt = np.concatenate([m.translations() for m in motions]) if has_lt else None
    return Motion(first.skeleton, first.frame_time, np.concatenate([m.root_positions for m in motions]),
                  np.concatenate([m.local_quats for m in motions]), lt)
