"""How good is an edit? :func:`compare` measures what an edit did to a motion, against its source.

The papers promise detail-preserving timing edits with the environmental contacts kept (Coleman et al. 2008,
§3 and §5.2). :func:`compare` states that promise as numbers that can fail, each one defined once here:

lengths are in **cm of a 170 cm body**: file units times ``scale = 170 / body_height(source)``, where the
body height (:func:`body_height`) is the 90th percentile over the source's frames of its vertical extent
(highest joint minus lowest joint along :func:`~stagger_nb.core.body.up_axis`; End Sites left out). It is
read from the animation, not the rest pose: rigs whose OFFSETs disagree with their animated translations
(iClone/CC position channels, the Bandai static root) have meaningless rest poses, and the percentile keeps
a clip that crouches most of the time (a get-down) at its standing height. The figures therefore do not
change when a clip is scaled uniformly.

Times: frame ``n`` of the source is at ``n * source.frame_time``; frame ``n`` of the edited motion at
``t0 + n * edited.frame_time`` with ``t0 = staggered.pose_times[0]`` (the time ``evaluate`` starts at; 0
without a StaggeredMotion). "The source at the same time" is the source's FK positions interpolated linearly
at that time (exact where the frames coincide).

Contacts: the source's (default :func:`~stagger_nb.staggered.detect_contacts`), carried through the timing
edit with each contact joint's own time warp (``carry_contacts(staggered, contacts, source.frame_time,
carry_by="joint")``); without a StaggeredMotion they stay on their frames. Inside a carried contact frame
``n`` corresponds to the source time ``w⁻¹(t_n)`` (:func:`~stagger_nb.staggered.warp_times`, inverse, of the
contact joint).

The figures (:class:`QualityReport`):

* ``foot_travel`` (cm): how far a held joint travels inside its carried contact *against the source's own
  motion there*: ``max_n |(p(n) - p(a)) - (p_src(w⁻¹ t_n) - p_src(w⁻¹ t_a))|`` (3-D, ``a`` the contact's first
  frame), the largest over contacts. 0 for an unedited motion; a layer that keeps the source's heel-toe roll
  scores 0, a foot pinned to one point scores the source's own roll (detected contacts allow a still joint
  2 % of the body height, 3.4 cm, of drift). ``foot_travel_raw``: the displacement alone, ``max |p(n) -
  p(a)|`` (what a pinned foot makes 0); ``foot_path``: its path length ``Σ |p(n+1) - p(n)|``;
  ``foot_travel_source``: ``foot_travel`` inside the *source's* contact intervals shrunk by 0.1 s at each end,
  at the same times (no carrying); ``foot_travel_source_raw`` likewise.
* ``foot_height`` (cm): ``max |h(n) - h_src(w⁻¹ t_n)|`` of the held joints inside carried contacts (h: the
  height along the up axis).
* ``floor`` (cm >= 0): how far the lowest joint of any edited frame goes below the source's floor (the lowest
  height any joint of the source reaches).
* ``pelvis`` (cm): ``max_n |h_pelvis(n) - h_pelvis,src(t_n)|``, the same time, the pelvis
  :func:`~stagger_nb.core.body.pelvis_joint`; ``pelvis_drop`` the largest lowering (>= 0); with a ``baseline``
  (the same edit without the contact layer) ``pelvis_vs_baseline``: the same against the baseline, the layer's
  own change.
* ``added_pop`` (degrees): per joint, the largest frame-to-frame rotation of its local rotation in the edited
  motion minus the source's largest (per source frame: scaled by ``source.frame_time / edited.frame_time``
  when they differ); the largest over joints (>= 0), and which joint. ``added_jump`` (cm): the same with world
  positions.
* ``moved`` (cm) / ``rotated`` (degrees): the largest displacement of any joint's world position / angle of
  its local rotation from the source at the same time (what an unedited layer must keep near 0).
* ``knots_out_of_order``: names of the joints (and ``"<root translation>"``) of ``staggered`` whose refined
  knot times ``t_k + r[k, j]`` are not strictly increasing (``None`` without a StaggeredMotion).
* ``detail`` (ratio): high-frequency energy of the edited joint curves over the source's: per joint the local
  angular velocity ``ω(n) = rotvec(q(n)⁻¹ q(n+1)) / frame_time`` (rad/s), band-passed (its Gaussian low-pass
  of σ = 0.015 s minus that of σ = 0.08 s: the wiggles of roughly 2-10 Hz, not frame-level jitter), squared
  and averaged over frames; the ratio of the sums over joints (1: the detail is kept; smoothing lowers it,
  added jitter raises it). Both curves are read on the source's frames, the edited one
  at each joint's warped time (``warp_times(staggered, n * source.frame_time, j)``, slerp between edited
  frames), so retiming alone keeps the ratio near 1.

:attr:`QualityReport.failures` checks them against :class:`Bounds` (default the ``"mild"`` preset, the goals
of issue "Edits an animator would keep"); :attr:`~QualityReport.summary` says it in one line.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .core.body import pelvis_joint, up_axis
from .core.kinematics import forward_kinematics
from .core.motion import Motion
from .core.rotations import quat_angle, quat_mul, quat_conj, quat_to_rotvec, slerp
from .core.skeleton import Skeleton

__all__ = ["compare", "QualityReport", "ContactFigures", "Bounds", "PRESETS", "body_height", "scaled",
           "BODY_CM", "DETAIL_SIGMA", "DETAIL_FINE", "SOURCE_SHRINK"]

#: The body every length is expressed on (cm): the figures read as on a 170 cm person.
BODY_CM = 170.0
#: Percentile of the per-frame vertical extent taken as the body height (see :func:`body_height`).
HEIGHT_PERCENTILE = 90.0
#: Gaussian σs (seconds) of the band-pass whose output is the "detail" of a joint curve: what a 0.08 s
#: low-pass removes (the wiggles), less what a 0.015 s low-pass removes (frame-level jitter, and the smoothing
#: that reading a curve between its frames does: neither is visible detail).
DETAIL_SIGMA = 0.08
DETAIL_FINE = 0.015
#: Seconds cut from each end of a source contact for ``foot_travel_source`` (heel strike and toe-off).
SOURCE_SHRINK = 0.1
#: Tolerance (cm) of "no more sliding than without the layer" (rounding of the two evaluations).
_BASELINE_SLACK = 0.1


def _number(x, name: str) -> float:
    try:
        x = float(x)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {x!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return x


# -- bounds --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Bounds:
    """Largest allowed figures of a :class:`QualityReport` (``None``: not checked).

    Attributes: ``travel``, ``height``, ``floor``, ``pelvis``, ``moved`` (cm of a 170 cm body), ``pop``
    (degrees), ``knots`` (joints whose knots are out of order), ``detail`` ((low, high) ratio) and
    ``no_worse_than_baseline`` (the held feet travel no more than in the ``baseline``, when one is given).
    ``pelvis`` is checked against ``pelvis_vs_baseline`` when a baseline is given (the layer's own change),
    else against ``pelvis`` (vs the source).
    """

    travel: float | None = 1.0
    height: float | None = 1.5
    floor: float | None = 1.5
    pelvis: float | None = 3.0
    pop: float | None = 5.0
    moved: float | None = None
    knots: int | None = 0
    detail: tuple | None = (0.5, 2.0)
    no_worse_than_baseline: bool = False

    def __post_init__(self):
        for name in ("travel", "height", "floor", "pelvis", "pop", "moved"):
            v = getattr(self, name)
            if v is not None:
                v = _number(v, f"bounds.{name}")
                if v < 0:
                    raise ValueError(f"bounds.{name} must be >= 0 or None, got {v}")
                object.__setattr__(self, name, v)
        if self.knots is not None:
            if isinstance(self.knots, bool) or not isinstance(self.knots, (int, np.integer)) or self.knots < 0:
                raise ValueError(f"bounds.knots must be a non-negative int or None, got {self.knots!r}")
            object.__setattr__(self, "knots", int(self.knots))
        if self.detail is not None:
            try:
                lo, hi = (float(x) for x in self.detail)
            except (TypeError, ValueError):
                raise ValueError(f"bounds.detail must be (low, high) or None, got {self.detail!r}") from None
            if not (0 <= lo <= hi) or not math.isfinite(hi):
                raise ValueError(f"bounds.detail must satisfy 0 <= low <= high < inf, got {self.detail!r}")
            object.__setattr__(self, "detail", (lo, hi))
        object.__setattr__(self, "no_worse_than_baseline", bool(self.no_worse_than_baseline))

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["detail"] = None if self.detail is None else list(self.detail)
        return d


#: Named bounds: the goals of issue "Edits an animator would keep" (cm of a 170 cm body, degrees).
#: ``unedited``: the contact layer on an unedited extraction moves no joint more than 2 cm.
PRESETS = {
    "unedited": Bounds(travel=1.0, height=1.5, floor=1.5, pelvis=2.0, pop=5.0, moved=2.0),
    "mild": Bounds(travel=1.0, height=1.5, floor=1.5, pelvis=3.0, pop=5.0),
    "moderate": Bounds(travel=2.0, height=2.0, floor=2.0, pelvis=5.0, pop=5.0),
    "strong": Bounds(travel=2.0, height=3.0, floor=3.0, pelvis=8.0, pop=10.0, no_worse_than_baseline=True),
}


def _bounds(bounds) -> Bounds:
    if bounds is None:
        return PRESETS["mild"]
    if isinstance(bounds, Bounds):
        return bounds
    if isinstance(bounds, str):
        if bounds not in PRESETS:
            raise ValueError(f"bounds: unknown preset {bounds!r}; presets are {', '.join(PRESETS)}")
        return PRESETS[bounds]
    if isinstance(bounds, dict):
        names = {f.name for f in dataclasses.fields(Bounds)}
        bad = sorted(set(bounds) - names - {"preset"})
        if bad:
            raise ValueError(f"bounds: unknown field(s) {', '.join(map(repr, bad))}; "
                             f"fields are {', '.join(sorted(names))}")
        base = _bounds(bounds.get("preset"))
        return dataclasses.replace(base, **{k: v for k, v in bounds.items() if k != "preset"})
    raise ValueError(f"bounds must be a preset name ({', '.join(PRESETS)}), a Bounds, a dict or None, "
                     f"got {type(bounds).__name__}")


# -- the report ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ContactFigures:
    """One carried contact: ``joint``; ``source_frames`` (start, stop) half-open source frames; ``frames``
    (start, stop) half-open frames of the edited motion (after carrying); ``travel``, ``travel_raw``,
    ``path``, ``height`` (cm, see :mod:`stagger_nb.quality`); ``baseline_travel`` (cm, or None)."""

    joint: str
    source_frames: tuple
    frames: tuple
    travel: float
    travel_raw: float
    path: float
    height: float
    baseline_travel: float | None = None

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["source_frames"], d["frames"] = list(self.source_frames), list(self.frames)
        return d


@dataclass(frozen=True)
class QualityReport:
    """What :func:`compare` measured (every length in cm of a 170 cm body; see :mod:`stagger_nb.quality`).

    Per-joint detail: ``joints`` (names), ``pop_added`` / ``jump_added`` / ``detail_by_joint`` (one value
    per joint, same order), ``contacts`` (one :class:`ContactFigures` per carried contact).
    """

    scale: float
    body_height: float
    foot_travel: float
    foot_travel_raw: float
    foot_path: float
    foot_height: float
    foot_travel_source: float
    foot_travel_source_raw: float
    floor: float
    pelvis: float
    pelvis_drop: float
    pelvis_vs_baseline: float | None
    added_pop: float
    added_pop_joint: str | None
    added_jump: float
    added_jump_joint: str | None
    moved: float
    moved_joint: str | None
    rotated: float
    knots_out_of_order: tuple | None
    detail: float
    baseline_foot_travel: float | None
    contacts: tuple
    joints: tuple
    pop_added: tuple
    jump_added: tuple
    detail_by_joint: tuple
    bounds: Bounds = field(default_factory=Bounds)

    # -- verdicts ---------------------------------------------------------------------------------------
    @property
    def failures(self) -> tuple:
        """Figures outside :attr:`bounds`, one plain string each (empty when all are inside)."""
        b, out = self.bounds, []

        def over(value, bound, what, unit="cm"):
            if bound is not None and value is not None and value > bound + 1e-9:
                out.append(f"{what} {value:.2f} {unit} > {bound:g} {unit}")

        over(self.foot_travel, b.travel, "foot travel")
        over(self.foot_height, b.height, "foot height vs plant")
        over(self.floor, b.floor, "floor penetration")
        pel, what = ((self.pelvis_vs_baseline, "pelvis vs no layer") if self.pelvis_vs_baseline is not None
                     else (self.pelvis, "pelvis"))
        over(pel, b.pelvis, what)
        over(self.added_pop, b.pop, f"added pop ({self.added_pop_joint})", "°")
        over(self.moved, b.moved, f"joint moved ({self.moved_joint})")
        if b.knots is not None and self.knots_out_of_order is not None and len(self.knots_out_of_order) > b.knots:
            out.append(f"{len(self.knots_out_of_order)} joints' knots out of order > {b.knots}")
        if b.detail is not None and not b.detail[0] <= self.detail <= b.detail[1]:
            out.append(f"detail ratio {self.detail:.2f} outside [{b.detail[0]:g}, {b.detail[1]:g}]")
        if (b.no_worse_than_baseline and self.baseline_foot_travel is not None
                and self.foot_travel > self.baseline_foot_travel + _BASELINE_SLACK):
            out.append(f"foot travel {self.foot_travel:.2f} cm > {self.baseline_foot_travel:.2f} cm without the layer")
        return tuple(out)

    @property
    def ok(self) -> bool:
        """True when every bounded figure is inside :attr:`bounds`."""
        return not self.failures

    def with_bounds(self, bounds) -> "QualityReport":
        """The same figures judged against other ``bounds`` (a preset name, :class:`Bounds` or dict)."""
        return dataclasses.replace(self, bounds=_bounds(bounds))

    @property
    def summary(self) -> str:
        """One line, e.g. ``"feet held · pelvis ±0.8 cm · no pops"``; figures out of bounds are named with
        their bound (``"feet slide 3.1 cm (> 1)"``)."""
        b = self.bounds
        parts = []
        if not self.contacts:
            parts.append("no contacts")
        else:
            bad_t = b.travel is not None and self.foot_travel > b.travel + 1e-9
            bad_h = b.height is not None and self.foot_height > b.height + 1e-9
            if bad_t:
                parts.append(f"feet slide {self.foot_travel:.1f} cm (> {b.travel:g})")
            if bad_h:
                parts.append(f"feet {self.foot_height:.1f} cm off their plants (> {b.height:g})")
            if not bad_t and not bad_h:
                parts.append("feet held")
        if b.floor is not None and self.floor > b.floor + 1e-9:
            parts.append(f"{self.floor:.1f} cm below the floor (> {b.floor:g})")
        pel = self.pelvis_vs_baseline if self.pelvis_vs_baseline is not None else self.pelvis
        txt = f"pelvis ±{pel:.1f} cm"
        if b.pelvis is not None and pel > b.pelvis + 1e-9:
            txt += f" (> {b.pelvis:g})"
        parts.append(txt)
        if b.pop is not None and self.added_pop > b.pop + 1e-9:
            parts.append(f"pop {self.added_pop:.0f}° at {self.added_pop_joint} (> {b.pop:g})")
        elif self.added_pop < 0.5:
            parts.append("no pops")
        else:
            parts.append(f"pops ≤ {self.added_pop:.0f}°")
        if b.moved is not None and self.moved > b.moved + 1e-9:
            parts.append(f"{self.moved_joint} moved {self.moved:.1f} cm (> {b.moved:g})")
        if self.knots_out_of_order:
            n = len(self.knots_out_of_order)
            parts.append((f"{n} joints'" if n > 1 else "1 joint's") + " knots out of order")
        if b.detail is not None and not b.detail[0] <= self.detail <= b.detail[1]:
            parts.append(f"detail ×{self.detail:.2f}")
        return " · ".join(parts)

    def to_dict(self) -> dict:
        """JSON-safe dict of every figure, the per-contact and per-joint detail, the bounds, ``failures``,
        ``ok`` and ``summary``."""
        d = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name == "contacts":
                v = [c.to_dict() for c in v]
            elif f.name == "bounds":
                v = v.to_dict()
            elif isinstance(v, tuple):
                v = list(v)
            d[f.name] = v
        d.update(failures=list(self.failures), ok=self.ok, summary=self.summary)
        return d

    def __repr__(self) -> str:
        return f"QualityReport({self.summary!r})"


# -- helpers ---------------------------------------------------------------------------------------------

def _heights(pos: np.ndarray, up: np.ndarray) -> np.ndarray:
    return pos @ up


def body_height(motion: Motion, positions: np.ndarray | None = None) -> float:
    """The body height of ``motion`` (file units): the 90th percentile over frames of the vertical extent
    of its joints (highest minus lowest along :func:`~stagger_nb.core.body.up_axis`, End Sites left out).

    ``positions`` (F, J, 3): ``forward_kinematics(motion)[0]`` when the caller has it. A motion whose joints
    never spread vertically (every frame flat) is a ValueError.
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"motion must be a Motion, got {type(motion).__name__}")
    pos = forward_kinematics(motion)[0] if positions is None else positions
    h = _heights(pos, up_axis(motion, pos))
    ext = float(np.percentile(h.max(axis=1) - h.min(axis=1), HEIGHT_PERCENTILE))
    if not ext > 0:
        raise ValueError("motion: its joints have no vertical extent; a body height cannot be measured")
    return ext


def scaled(motion: Motion, factor: float | None = None, *, height: float | None = None) -> Motion:
    """``motion`` scaled uniformly by ``factor`` (root positions, offsets, End Sites, animated translations),
    or so that its :func:`body_height` becomes ``height`` (e.g. ``scaled(m, height=170)``). Rotations and
    timing are unchanged; a new Motion (``motion`` is not modified)."""
    if not isinstance(motion, Motion):
        raise ValueError(f"motion must be a Motion, got {type(motion).__name__}")
    if (factor is None) == (height is None):
        raise ValueError("give exactly one of factor= or height=")
    if height is not None:
        height = _number(height, "height")
        if height <= 0:
            raise ValueError(f"height must be > 0, got {height}")
        factor = height / body_height(motion)
    factor = _number(factor, "factor")
    if factor <= 0:
        raise ValueError(f"factor must be > 0, got {factor}")
    sk = motion.skeleton
    skel = Skeleton(sk.names, sk.parents, sk.offsets * factor, sk.channels,
                    {j: o * factor for j, o in sk.end_sites.items()})
    lt = None if motion.local_translations is None else motion.local_translations * factor
    return Motion(skel, motion.frame_time, motion.root_positions * factor, motion.local_quats, lt)


_body_height = body_height   # (compare's parameter of the same name shadows it)


def _as_motion(x, name: str):
    """(Motion, StaggeredMotion or None) of a compare() argument."""
    from .staggered import StaggeredMotion, evaluate
    if isinstance(x, StaggeredMotion):
        return evaluate(x), x
    if isinstance(x, Motion):
        return x, None
    raise ValueError(f"{name} must be a Motion or a StaggeredMotion, got {type(x).__name__}")


def _same_rig(source: Motion, other, name: str) -> None:
    a, b = source.skeleton, other.skeleton
    if a.names != b.names or not np.array_equal(a.parents, b.parents):
        diff = next((f"joint {i}: {x!r} vs {y!r}" for i, (x, y) in enumerate(zip(a.names, b.names)) if x != y),
                    f"{a.num_joints} vs {b.num_joints} joints" if a.num_joints != b.num_joints else "parents differ")
        raise ValueError(f"{name} must have the source's skeleton ({diff})")


def _finite_motion(m: Motion, name: str) -> None:
    for attr in ("local_quats", "root_positions", "local_translations"):
        a = getattr(m, attr)
        if a is not None and not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: {attr} must be finite (no NaN / inf)")


def _check_contacts(source: Motion, contacts) -> list:
    out = []
    names = source.skeleton.names
    for i, item in enumerate(contacts):
        try:
            name, a, b = item
            a, b = int(a), int(b)
        except (TypeError, ValueError):
            raise ValueError(f"contacts[{i}]: must be (joint_name, start_frame, stop_frame), got {item!r}") from None
        if isinstance(name, (int, np.integer)) and 0 <= int(name) < len(names):
            name = names[int(name)]
        if name not in names:
            raise ValueError(f"contacts[{i}]: unknown joint {name!r}")
        if not 0 <= a < b <= source.num_frames:
            raise ValueError(f"contacts[{i}]: frames [{a}, {b}) of {name!r} must lie in [0, {source.num_frames}) "
                             "and be non-empty")
        out.append((str(name), a, b))
    return out


def _at_times(pos: np.ndarray, frame_time: float, times: np.ndarray) -> np.ndarray:
    """``pos (F, ...)`` sampled at ``times (N,)`` seconds by linear interpolation (clamped at the ends; exact
    where a time falls on a frame)."""
    f = np.clip(np.asarray(times, float) / frame_time, 0.0, pos.shape[0] - 1)
    i0 = np.floor(f + 1e-9).astype(np.int64)
    np.minimum(i0, pos.shape[0] - 1, out=i0)
    w = f - i0
    w[np.abs(w) < 1e-9] = 0.0
    i1 = np.minimum(i0 + 1, pos.shape[0] - 1)
    w = w.reshape((-1,) + (1,) * (pos.ndim - 1))
    out = pos[i0].copy()
    moving = w.reshape(-1) > 0
    if moving.any():
        out[moving] = pos[i0[moving]] * (1 - w[moving]) + pos[i1[moving]] * w[moving]
    return out


def _frame_steps(q: np.ndarray) -> np.ndarray:
    """Largest frame-to-frame rotation angle (degrees) of each joint, ``q (F, J, 4)`` -> ``(J,)``."""
    if q.shape[0] < 2:
        return np.zeros(q.shape[1])
    return np.degrees(quat_angle(q[:-1], q[1:])).max(axis=0)


def _position_steps(p: np.ndarray) -> np.ndarray:
    if p.shape[0] < 2:
        return np.zeros(p.shape[1])
    return np.linalg.norm(np.diff(p, axis=0), axis=-1).max(axis=0)


def _detail_energy(q: np.ndarray, frame_time: float) -> np.ndarray:
    """High-frequency energy (rad²/s²) of each joint's local angular velocity, ``q (F, J, 4)`` -> ``(J,)``."""
    from scipy.ndimage import gaussian_filter1d
    if q.shape[0] < 3:
        return np.zeros(q.shape[1])
    w = quat_to_rotvec(quat_mul(quat_conj(q[:-1]), q[1:])) / frame_time          # (F-1, J, 3)
    hp = (gaussian_filter1d(w, DETAIL_FINE / frame_time, axis=0, mode="nearest")
          - gaussian_filter1d(w, DETAIL_SIGMA / frame_time, axis=0, mode="nearest"))
    return np.mean(np.sum(hp * hp, axis=-1), axis=0)


def _detail_energies(source: Motion, motion: Motion, sm, t0: float) -> tuple[np.ndarray, np.ndarray]:
    """``(edited, source)`` detail energies ``(J,)``, both on the source's frames: the edited motion's local
    rotations are read at each joint's warped time ``w_j(n * source.frame_time)`` (slerp between its frames;
    exact where a time falls on a frame), so a timing edit that only retimes a curve keeps its detail. Frames
    whose warped time falls outside the edited motion (any joint) are left out of both."""
    from .staggered import warp_times
    Fs, J = source.num_frames, source.num_joints
    ts = np.arange(Fs) * source.frame_time
    if sm is None:
        te = np.broadcast_to(ts[:, None], (Fs, J))
    else:
        te = np.stack([warp_times(sm, ts, j) for j in range(J)], axis=1)
    f = (te - t0) / motion.frame_time
    F = motion.num_frames
    keep = np.all((f >= -1e-6) & (f <= F - 1 + 1e-6), axis=1)
    if keep.sum() < 3:
        return np.zeros(J), np.zeros(J)
    f = np.clip(f[keep], 0.0, F - 1)
    i0 = np.minimum(np.floor(f + 1e-9).astype(np.int64), F - 1)
    w = f - i0
    w[np.abs(w) < 1e-9] = 0.0
    cols = np.broadcast_to(np.arange(J), i0.shape)
    q = motion.local_quats[i0, cols]                                                # (n, J, 4)
    frac = w > 0
    if frac.any():
        i1 = np.minimum(i0 + 1, F - 1)
        q[frac] = slerp(q[frac], motion.local_quats[i1[frac], cols[frac]], w[frac])
    return _detail_energy(q, source.frame_time), _detail_energy(source.local_quats[keep], source.frame_time)


def _travel(pe: np.ndarray, ps: np.ndarray) -> tuple[float, float, float]:
    """(travel against the source, raw travel, path length) of positions ``pe (n, 3)`` against ``ps (n, 3)``."""
    de, ds = pe - pe[0], ps - ps[0]
    rel = float(np.linalg.norm(de - ds, axis=-1).max())
    raw = float(np.linalg.norm(de, axis=-1).max())
    path = float(np.linalg.norm(np.diff(pe, axis=0), axis=-1).sum()) if pe.shape[0] > 1 else 0.0
    return rel, raw, path


# -- compare ---------------------------------------------------------------------------------------------

def compare(source: Motion, edited, *, staggered=None, contacts=None, baseline=None, bounds=None,
            body_height: float | None = None, source_positions: np.ndarray | None = None) -> QualityReport:
    """Measure what an edit did to ``source`` (definitions: :mod:`stagger_nb.quality`).

    Parameters
    ----------
    source : Motion
        The unedited motion.
    edited : Motion or StaggeredMotion
        The edited motion (a StaggeredMotion is evaluated, and is then also ``staggered`` by default).
    staggered : StaggeredMotion, optional
        The edited StaggeredMotion: its time warps carry the contacts, its knots are checked for order.
        Without it the contacts stay on their frames and ``knots_out_of_order`` is None.
    contacts : list of (joint_name, start_frame, stop_frame), optional
        Source contacts, half-open source frames; default ``staggered.detect_contacts(source)``.
    baseline : Motion or StaggeredMotion, optional
        The same edit without the contact layer: ``pelvis_vs_baseline`` and ``baseline_foot_travel`` are
        measured against it.
    bounds : "mild" | "moderate" | "strong" | "unedited" | Bounds | dict, optional
        What :attr:`QualityReport.failures` checks (default ``"mild"``; a dict overrides fields of its
        ``"preset"``, e.g. ``{"preset": "strong", "pop": 8}``).
    body_height : float, optional
        The source's body height in file units (default :func:`body_height` of the source).
    source_positions : ndarray (F, J, 3), optional
        ``forward_kinematics(source)[0]`` when the caller has it (the same figures, one FK fewer).

    Returns
    -------
    QualityReport (frozen): the figures, per-contact and per-joint detail, ``.summary``, ``.ok``,
    ``.failures``, ``.to_dict()``.
    """
    from . import staggered as stg
    if not isinstance(source, Motion):
        raise ValueError(f"source must be a Motion, got {type(source).__name__}")
    _finite_motion(source, "source")
    motion, sm = _as_motion(edited, "edited")
    if staggered is not None:
        if not isinstance(staggered, stg.StaggeredMotion):
            raise ValueError(f"staggered must be a StaggeredMotion, got {type(staggered).__name__}")
        sm = staggered
    _same_rig(source, motion, "edited")
    _finite_motion(motion, "edited")
    if sm is not None:
        _same_rig(source, sm, "staggered")
    base = None
    if baseline is not None:
        base, _ = _as_motion(baseline, "baseline")
        _same_rig(source, base, "baseline")
        _finite_motion(base, "baseline")
    bnds = _bounds(bounds)
    sk = source.skeleton
    names = sk.names
    if source_positions is None:
        src_pos, _ = forward_kinematics(source)
    else:
        src_pos = np.asarray(source_positions, dtype=float)
        if src_pos.shape != (source.num_frames, source.num_joints, 3) or not np.all(np.isfinite(src_pos)):
            raise ValueError(f"source_positions must be finite, of shape ({source.num_frames}, {source.num_joints}, 3)"
                             f" (forward_kinematics(source)[0]), got {src_pos.shape}")
    up = up_axis(source, src_pos)
    if body_height is None:
        h_body = _body_height(source, src_pos)
    else:
        h_body = _number(body_height, "body_height")
        if h_body <= 0:
            raise ValueError(f"body_height must be > 0, got {h_body}")
    scale = BODY_CM / h_body
    if contacts is None:
        contacts = stg.detect_contacts(source, positions=src_pos)
    contacts = _check_contacts(source, contacts)

    ft_s, ft_e = source.frame_time, motion.frame_time
    t0 = float(sm.pose_times[0]) if sm is not None else 0.0
    pos, _ = forward_kinematics(motion)
    F = motion.num_frames
    te = t0 + np.arange(F) * ft_e
    inside = te <= source.duration + 0.5 * ft_s + 1e-9          # frames the source covers
    src_at = _at_times(src_pos, ft_s, te[inside])               # (n, J, 3) the source at the same times

    # whole-body figures
    moved_j = np.linalg.norm(pos[inside] - src_at, axis=-1).max(axis=0) if inside.any() else np.zeros(len(names))
    mj = int(np.argmax(moved_j))
    if inside.any():
        fs = np.clip(te[inside] / ft_s, 0, source.num_frames - 1)
        i0 = np.floor(fs + 1e-9).astype(np.int64)
        i1 = np.minimum(i0 + 1, source.num_frames - 1)
        w = np.where(np.abs(fs - i0) < 1e-9, 0.0, fs - i0)
        q_src = source.local_quats[i0]
        frac = w > 0
        if frac.any():
            q_src[frac] = slerp(source.local_quats[i0[frac]], source.local_quats[i1[frac]], w[frac][:, None])
        q_e = motion.local_quats[inside]
        ang = np.where(np.all(q_src == q_e, axis=-1), 0.0, quat_angle(q_src, q_e))   # exact 0 where equal
        rotated = float(np.degrees(ang).max())
    else:
        rotated = 0.0
    pel = pelvis_joint(sk)
    hp_e, hp_s = _heights(pos[inside, pel], up), _heights(src_at[:, pel], up)
    dpel = hp_e - hp_s
    pelvis = float(np.abs(dpel).max()) * scale if dpel.size else 0.0
    pelvis_drop = float(max(-dpel.min(), 0.0)) * scale if dpel.size else 0.0
    pelvis_vs_base = None
    base_pos = None
    if base is not None:
        base_pos, _ = forward_kinematics(base)
        n = min(base_pos.shape[0], F)
        pelvis_vs_base = float(np.abs(_heights(pos[:n, pel] - base_pos[:n, pel], up)).max()) * scale if n else 0.0
    floor = float(_heights(src_pos, up).min())
    below = floor - float(_heights(pos, up).min())
    floor_pen = max(below, 0.0) * scale

    ratio = ft_s / ft_e
    pop_e, pop_s = _frame_steps(motion.local_quats) * ratio, _frame_steps(source.local_quats)
    pop_added = np.maximum(pop_e - pop_s, 0.0)
    pj = int(np.argmax(pop_added))
    jump_added = np.maximum(_position_steps(pos) * ratio - _position_steps(src_pos), 0.0) * scale
    jj = int(np.argmax(jump_added))
    e_e, e_s = _detail_energies(source, motion, sm, t0)
    total_s = float(e_s.sum())
    detail = float(e_e.sum()) / total_s if total_s > 0 else 1.0
    detail_j = np.where(e_s > 0, e_e / np.where(e_s > 0, e_s, 1.0), 1.0)

    knots_bad = None
    if sm is not None:
        T = np.concatenate([sm.knot_times(), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)
        bad = ~np.all(np.diff(T, axis=0) > 0, axis=0)
        knots_bad = tuple((list(names) + ["<root translation>"])[c] for c in np.flatnonzero(bad))

    # contacts carried through each contact joint's own timing
    figures = []
    for name, a0, b0 in contacts:
        if sm is not None:
            moved_c = stg.carry_contacts(sm, [(name, a0, b0)], ft_s, carry_by="joint")
            if not moved_c:
                continue                       # carried onto no frame
            _, a, b = moved_c[0]
        else:
            a, b = a0, b0
        b = min(b, F)
        if b <= a:
            continue
        j = sk.index(name)
        frames = np.arange(a, b)
        tt = te[frames]
        ts = stg.warp_times(sm, tt, j, inverse=True) if sm is not None else tt
        ps = _at_times(src_pos[:, j], ft_s, ts)
        pe = pos[frames, j]
        rel, raw, path = _travel(pe, ps)
        height = float(np.abs(_heights(pe - ps, up)).max())
        bt = None
        if base_pos is not None:
            fb = frames[frames < base_pos.shape[0]]
            bt = _travel(base_pos[fb, j], ps[: fb.size])[0] * scale if fb.size else 0.0
        figures.append(ContactFigures(name, (a0, b0), (int(a), int(b)), rel * scale, raw * scale,
                                      path * scale, height * scale, bt))
    # inside the source's own intervals, shrunk by SOURCE_SHRINK at each end, at the same times
    in_src, in_src_raw = 0.0, 0.0
    for name, a, b in contacts:
        j = sk.index(name)
        lo, hi = a * ft_s + SOURCE_SHRINK, (b - 1) * ft_s - SOURCE_SHRINK
        frames = np.flatnonzero((te >= lo - 1e-9) & (te <= hi + 1e-9))
        if frames.size < 2:
            continue
        rel, raw, _ = _travel(pos[frames, j], _at_times(src_pos[:, j], ft_s, te[frames]))
        in_src, in_src_raw = max(in_src, rel * scale), max(in_src_raw, raw * scale)

    def worst(attr):
        return max((getattr(c, attr) for c in figures), default=0.0)

    base_travel = None
    if base_pos is not None:
        base_travel = max((c.baseline_travel for c in figures), default=0.0)
    return QualityReport(
        scale=scale, body_height=h_body,
        foot_travel=worst("travel"), foot_travel_raw=worst("travel_raw"), foot_path=worst("path"),
        foot_height=worst("height"), foot_travel_source=in_src, foot_travel_source_raw=in_src_raw,
        floor=floor_pen, pelvis=pelvis, pelvis_drop=pelvis_drop, pelvis_vs_baseline=pelvis_vs_base,
        added_pop=float(pop_added[pj]), added_pop_joint=names[pj] if pop_added[pj] > 0 else None,
        added_jump=float(jump_added[jj]), added_jump_joint=names[jj] if jump_added[jj] > 0 else None,
        moved=float(moved_j[mj]) * scale, moved_joint=names[mj] if moved_j[mj] > 0 else None,
        rotated=rotated, knots_out_of_order=knots_bad, detail=detail, baseline_foot_travel=base_travel,
        contacts=tuple(figures), joints=tuple(names), pop_added=tuple(float(x) for x in pop_added),
        jump_added=tuple(float(x) for x in jump_added), detail_by_joint=tuple(float(x) for x in detail_j),
        bounds=bnds)
