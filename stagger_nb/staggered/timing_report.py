"""What a timing edit reports (Coleman et al. 2008, §5.2): refined knot times that reach a neighbouring pose
(:class:`TimingWarning`, :func:`timing_warnings`, the detailed API; :func:`summarize_timing_warnings` counts
them), the one plain sentence a student reads (:func:`timing_summary`: a timing edit limited to keep the poses
in order, or knots that cross, by body part: :func:`body_part`), and the metadata dict that computes the
warnings on first read (``_LazyWarnings``).
"""
from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

import numpy as np

from ._checks import _check, _finite
from .representation import StaggeredMotion, knot_times

__all__ = ["TimingWarning", "timing_warnings", "summarize_timing_warnings", "timing_summary", "body_part"]


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


# -- the plain timing sentence -------------------------------------------------------------------------------

_SIDE_TOKENS = {"left": "left", "l": "left", "right": "right", "r": "right"}
_ASF_LIMB = re.compile(r"^([lr])(hand|wrist|femur|tibia|foot|toes|humerus|radius|clavicle|fingers|thumb|hipjoint)$")
_PARTS = (   # (pattern on the joint's name without its side, words), first match wins
    (re.compile(r"toe"), "toes"),
    (re.compile(r"thumb|index|middle|mid\d|ring\d|ring$|pinky|finger"), "fingers"),
    (re.compile(r"foot|ankle|heel"), "foot"),
    (re.compile(r"upleg|thigh|knee|calf|leg|femur|tibia|shin"), "leg"),
    (re.compile(r"hand|wrist"), "hand"),
    (re.compile(r"arm|elbow|shoulder|clavicle|collar|humerus|radius"), "arm"),
    (re.compile(r"head|neck|jaw|eye|teeth|tongue|facial|nose"), "head"),
    (re.compile(r"spine|chest|back|waist|breast|ribs|abdomen|torso"), "spine"),
    (re.compile(r"hips|hip|pelvis|root"), "hips"),
)


def body_part(name: str) -> str:
    """Plain words for the body part a joint belongs to: ``"the left arm"``, ``"the right fingers"``,
    ``"the spine"``, ``"the head"`` ... (from the joint's name: CMU, Mixamo, Bandai, iClone/CC and ASF
    spellings); the joint's own name when no word fits."""
    bare = str(name).split(":")[-1]
    tokens = [t.lower() for t in re.findall(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])|\d+", bare)]
    side = next((_SIDE_TOKENS[t] for t in tokens if t in _SIDE_TOKENS), None)
    rest = "".join(t for t in tokens if t not in _SIDE_TOKENS)
    asf = _ASF_LIMB.match(bare.lower())
    if side is None and asf:
        side, rest = ("left" if asf.group(1) == "l" else "right"), asf.group(2)
    for pattern, word in _PARTS:
        if pattern.search(rest):
            if word == "hips" and side is None or word in ("head", "spine"):
                return f"the {word}"
            if word == "hips":           # a hip joint with a side (CMU's LeftHip) is the top of a leg
                word = "leg"
            return f"the {side} {word}" if side else f"the {word}"
    return str(name)


def timing_summary(sm: StaggeredMotion) -> str:
    """One plain sentence about the timing edits of ``sm`` for a student, or ``''``.

    It appears only when a timing edit was limited noticeably to keep a joint's poses in order
    (:func:`succession` / :func:`random_timing` with a ``limit``: "To keep each joint's poses in order, the
    delay was limited for the right fingers (to 0.21 s of 3.20 s asked) ...") or when, without the limit,
    a joint's refined knots now cross (its poses play out of order, so it jumps). The knots themselves are
    listed by :func:`timing_warnings` (§5.2's warning, the detailed API).
    """
    _check(sm)
    T = knot_times(sm)
    crossed = np.flatnonzero(~np.all(np.diff(T, axis=0) > 0, axis=0))
    rk = sm.pose_times + sm.root_refinements
    parts = list(dict.fromkeys(body_part(sm.skeleton.names[j]) for j in crossed))
    if not np.all(np.diff(rk) > 0) and "the hips" not in parts:
        parts.append("the hips")
    if parts:
        return (f"The poses of {_enumerate(parts)} now play out of order (a timing offset passes a neighbouring "
                f"pose), which makes {'it' if len(parts) == 1 else 'them'} jump: lower s, l or τ, or keep the "
                "timing limit on.")
    records = sm.metadata.get("timing_limits") or ()
    if not records:
        return ""
    kinds = {r["op"] for r in records}
    signs = {np.sign(r["asked"]) for r in records}
    if kinds == {"succession"}:
        word, pm = ("delay" if signs == {1.0} else "lead" if signs == {-1.0} else "delay or lead"), ""
    elif kinds == {"random_timing"}:
        word, pm = "typical random offsets", "±"
    else:
        word, pm = "timing offsets", ""
    groups = {}
    for r in records:
        g = groups.setdefault(body_part(r["joint"]), [0.0, 0.0])
        g[0], g[1] = max(g[0], abs(r["asked"])), max(g[1], abs(r["applied"]))
    order = sorted(groups, key=lambda p: groups[p][1] - groups[p][0])      # the most limited first
    shown = [f"{p} (to {pm}{_seconds(groups[p][1])} of {pm}{_seconds(groups[p][0])} asked)" for p in order[:3]]
    if len(order) > 3:
        shown.append(f"{len(order) - 3} more body part{'s' if len(order) > 4 else ''}")
    were = "was" if word in ("delay", "lead", "delay or lead") else "were"
    return f"To keep each joint's poses in order, the {word} {were} limited for {_enumerate(shown)}."


def _seconds(x: float) -> str:
    return f"{x:.2f} s" if x < 10 else f"{x:.0f} s"


def _enumerate(items) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


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

    def _fill(self) -> _LazyWarnings:
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
