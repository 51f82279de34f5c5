"""What a timing edit reports (Coleman et al. 2008, §5.2): refined knot times that reach a neighbouring pose
(:class:`TimingWarning`, :func:`timing_warnings`), one plain sentence about them
(:func:`summarize_timing_warnings`), and the metadata dict that computes them on first read (``_LazyWarnings``).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ._checks import _finite
from .representation import StaggeredMotion

__all__ = ["TimingWarning", "timing_warnings", "summarize_timing_warnings"]


@dataclass(frozen=True)
class TimingWarning:
    """A refined knot time closer to a neighbouring pose than to its own pose (§5.2).

    Attributes: ``pose`` (k), ``joint`` (name, or ``"<root translation>"``), ``refined_time`` (s),
    ``neighbour`` (index of the nearer pose), ``message``. :meth:`to_dict` gives a JSON-ready dict.
    """

    pose: int
    joint: str
    refined_time: float
    neighbour: int
    message: str

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


_MIN_ANGLE_DEG = 2.0   # knots around a pose spanning less than this: the joint barely moves (a 20 cm hand tip < 7 mm)


def timing_warnings(sm: StaggeredMotion, *, min_angle: float = _MIN_ANGLE_DEG) -> tuple[TimingWarning, ...]:
    """Knots of ``sm`` whose refined time is closer to a neighbouring staggered pose than to its own (§5.2).

    §5.2: "care must be taken to avoid large nonlinear time warps, as this can introduce sudden
    acceleration. We warn users when refined times are set large enough to be closer to a neighboring
    staggered pose than the staggered pose with which the knot is associated." Read per control variable
    ``i`` (a staggered pose happens at a different time for every joint, that is what "staggered" means):

    * the neighbouring staggered pose of joint ``i`` is its knot ``T[k±1, i] = t_{k±1} + r[k±1, i]``; the
      knot ``T[k, i]`` is flagged when ``|T[k, i] - T[k±1, i]| + frame_time < |r[k, i]|`` (closer to the
      neighbour's knot than to its own pose time ``t_k``, by more than the frame resolution of the
      refinements), or when the knots of the joint cross (``T[k+1, i] <= T[k, i]``: evaluation then
      collapses the segment). A succession shifts every interior knot of a joint by the same amount, a
      shift that keeps the knots' spacing and warps nothing, so it is not flagged unless it pushes knots
      into each other or past the anchored first/last pose. On an unedited extraction (small neighbour
      refinements) this is the pose-time reading ``|T[k, i] - t_{k±1}| < |r[k, i]|``.
    * only control variables that move are checked: a joint whose knots ``v``/``v⁰`` of poses
      ``k-1 .. k+1`` span less than ``min_angle`` degrees (fingers held still, end joints, a procedural
      clip's fixed joints; a root translation that does not change) has no acceleration to introduce, and
      retiming it is invisible.

    Parameters
    ----------
    sm : StaggeredMotion
    min_angle : float, degrees (>= 0)
        Smallest rotation range of a knot's neighbourhood that counts as moving (0 checks every joint).

    Returns
    -------
    tuple of :class:`TimingWarning` sorted by (pose, joint); :func:`summarize_timing_warnings` puts them in
    one sentence.
    """
    min_angle = _finite(min_angle, "min_angle")
    if min_angle < 0:
        raise ValueError(f"min_angle must be >= 0 degrees, got {min_angle}")
    return _timing_warnings(sm.pose_times, sm.refinements, sm.root_refinements, sm.values, sm.editing_knots,
                            sm.root_values, sm.frame_time, sm.skeleton.names, min_angle)


def _timing_warnings(t, refinements, root_refinements, values, editing_knots, root_values, frame_time, names,
                     min_angle: float = _MIN_ANGLE_DEG) -> tuple[TimingWarning, ...]:
    """:func:`timing_warnings` of the StaggeredMotion fields given (``min_angle`` already checked): what
    :func:`_refresh` keeps for a lazy ``metadata["warnings"]`` without keeping the StaggeredMotion itself."""
    K, J = refinements.shape
    names = list(names) + ["<root translation>"]
    r = np.concatenate([refinements, root_refinements[:, None]], axis=1)    # (K, J + 1)
    T = t[:, None] + r
    bad = np.zeros((K, J + 1), bool)
    nearer = np.full((K, J + 1), -1)
    for side in (-1, 1):
        n = np.arange(K) + side
        ok = ((n >= 0) & (n < K))[:, None]
        Tn = T[np.clip(n, 0, K - 1)]
        close = np.abs(T - Tn) + frame_time < np.abs(r)
        crossed = (Tn <= T) if side > 0 else (Tn >= T)
        hit = ok & (close | crossed) & ~bad
        nearer[hit] = np.broadcast_to(np.clip(n, 0, K - 1)[:, None], hit.shape)[hit]
        bad |= hit
    if not bad.any():
        return ()
    # does the control variable move around the knot? (rotation range of the knots of poses k-1 .. k+1)
    ks, cols = np.nonzero(bad)
    idx = np.clip(ks[:, None] + np.array([-1, 0, 1]), 0, K - 1)                # (n, 3) neighbouring poses
    keep = np.ones(ks.size, bool)
    rot = cols < J
    if rot.any():
        c = cols[rot][:, None]
        v = np.concatenate([values[idx[rot], c], editing_knots[idx[rot], c]], axis=1)   # (n, 6, 4)
        dots = np.abs(np.einsum("nac,nbc->nab", v, v)).min(axis=(1, 2))
        keep[rot] = 2.0 * np.degrees(np.arccos(np.clip(dots, -1.0, 1.0))) >= min_angle
    if (~rot).any():
        p = root_values[idx[~rot]]                                                  # (n, 3, 3)
        keep[~rot] = np.ptp(p, axis=1).max(axis=1) > 1e-9 * (1.0 + np.abs(p).max(axis=(1, 2)))
    out = []
    for k, i in zip(ks[keep], cols[keep]):
        nb = int(nearer[k, i])
        where = "previous" if nb < k else "next"
        out.append(TimingWarning(int(k), names[i], float(T[k, i]), nb,
                                 f"pose {k}, {names[i]}: refined time {T[k, i]:.3f} s (refinement {r[k, i]:+.3f} s)"
                                 f" reaches the {where} pose's knot ({T[nb, i]:.3f} s, pose {nb} at {t[nb]:.3f} s)"))
    out.sort(key=lambda w: (w.pose, w.joint))
    return tuple(out)


def summarize_timing_warnings(warnings) -> str:
    """One plain sentence for a student: how many refined times reach a neighbouring pose, where, and the
    fix ('' when there are none). Details stay in :func:`timing_warnings` (§5.2).

    Parameters
    ----------
    warnings : iterable of :class:`TimingWarning` (or their ``to_dict()`` dicts)
    """
    ws = [w if isinstance(w, TimingWarning) else TimingWarning(**w) for w in (warnings or ())]
    if not ws:
        return ""
    joints = sorted({w.joint for w in ws}, key=lambda n: (-sum(w.joint == n for w in ws), n))
    poses = sorted({w.pose for w in ws})
    jtxt = ", ".join(joints[:3]) + (f" and {len(joints) - 3} more joints" if len(joints) > 3 else "")
    ptxt = (f"pose {poses[0]}" if len(poses) == 1 else
            f"poses {', '.join(map(str, poses[:4]))}" + (" …" if len(poses) > 4 else ""))
    n = len(ws)
    what = "refined time reaches" if n == 1 else "refined times reach"
    return (f"{n} {what} a neighbouring pose ({jtxt}; {ptxt}), which can make those joints jump or "
            f"speed up suddenly: lower s or l (succession), lower τ (random timing), or stagger fewer joints.")


class _LazyWarnings(dict):
    """The metadata dict of an edited StaggeredMotion whose ``"warnings"`` entry (:func:`timing_warnings`,
    ~0.3-3.5 ms on a 900-frame clip) is computed on its first read, not by every edit: a slider's replay
    (exaggerate, succession, τ on every move) never reads it; the session computes the warnings of the
    last staggered state once, when asked (``Session.timing_warnings``). Any read of the entry or of the
    whole dict (iteration, ``items()``, ``len``, ``==``, a copy, pickling) sees it as a plain dict would
    have: the entry filled. ``make`` holds the fields it needs, not the StaggeredMotion (no reference
    cycle)."""

    __slots__ = ("_make",)

    def __init__(self, data: dict, make):
        super().__init__(data)
        self._make = make

    def _fill(self) -> "_LazyWarnings":
        make = self._make
        if make is not None:
            dict.__setitem__(self, "warnings", make())
            self._make = None
        return self

    def __getitem__(self, key):
        if key == "warnings":
            self._fill()
        return dict.__getitem__(self, key)

    def get(self, key, default=None):
        if key == "warnings":
            self._fill()
        return dict.get(self, key, default)

    def __contains__(self, key):
        return (key == "warnings" and self._make is not None) or dict.__contains__(self, key)

    def __reduce__(self):
        return dict, (dict(self._fill()),)

    def __repr__(self):
        return dict.__repr__(self._fill())


def _whole(name):
    def method(self, *args, **kwargs):
        return getattr(dict, name)(self._fill(), *args, **kwargs)
    method.__name__ = name
    return method


for _name in ("__iter__", "__len__", "__eq__", "__ne__", "keys", "items", "values", "copy", "pop", "popitem",
              "setdefault", "update", "__setitem__", "__delitem__", "__or__", "__ior__", "__reversed__", "clear"):
    setattr(_LazyWarnings, _name, _whole(_name))
del _name
