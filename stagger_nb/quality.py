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
* ``detail`` (ratio): high-frequency energy of the edited joint curves over the source's, read on the detail
  grid ``t_n = n h``, ``h = k * source.frame_time`` (the source's frames; every k-th one for a clip faster than
  ``DETAIL_RATE`` = 60 Hz, e.g. k = 2 at 120 Hz: the band measured is far below 30 Hz): per joint the local
  angular velocity ``ω(n) = rotvec(q(n)⁻¹ q(n+1)) / h`` (rad/s), band-passed (its Gaussian low-pass of
  σ = 0.015 s minus that of σ = 0.08 s, the nearest sample repeated past the ends: the wiggles of roughly
  2-10 Hz, not frame-level jitter), squared and averaged over the grid; the ratio of the sums over joints
  (1: the detail is kept; smoothing lowers it, added jitter raises it). The edited curve is read at each
  joint's warped time (``warp_times(staggered, t_n, j)``, slerp between edited frames), so retiming alone
  keeps the ratio near 1.

Speed: :func:`prepare` computes the source's part once (a :class:`SourceFigures`; ``compare(...,
prepared=)``), and the edit's part is vectorised over frames, joints and contacts (benchmarks/bench_quality.py).

:attr:`QualityReport.failures` checks them against :class:`Bounds` (default the ``"mild"`` preset, the goals
of issue "Edits an animator would keep"); :attr:`~QualityReport.summary` says it in one line.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .core.body import pelvis_joint, up_axis
from .core.kinematics import _fk_component_major, _to_component_major, _to_frame_major, forward_kinematics
from .core.motion import Motion
from .core.rotations import _SMALL, quat_angle, quat_mul_components
from .core.skeleton import Skeleton

__all__ = ["compare", "prepare", "SourceFigures", "QualityReport", "SummaryItem", "ContactFigures", "Bounds", "PRESETS",
           "body_height", "scaled", "ROW_FIELDS",
           "BODY_CM", "DETAIL_SIGMA", "DETAIL_FINE", "DETAIL_RATE", "SOURCE_SHRINK"]

#: The body every length is expressed on (cm): the figures read as on a 170 cm person.
BODY_CM = 170.0
#: Percentile of the per-frame vertical extent taken as the body height (see :func:`body_height`).
HEIGHT_PERCENTILE = 90.0
#: Gaussian σs (seconds) of the band-pass whose output is the "detail" of a joint curve: what a 0.08 s
#: low-pass removes (the wiggles), less what a 0.015 s low-pass removes (frame-level jitter, and the smoothing
#: that reading a curve between its frames does: neither is visible detail).
DETAIL_SIGMA = 0.08
DETAIL_FINE = 0.015
#: Highest sampling rate (Hz) of the detail grid: the source's frames, every k-th one for a faster clip (the
#: band of the detail, roughly 2-10 Hz, is far below the grid's Nyquist frequency).
DETAIL_RATE = 60.0
#: Elements per temporary array in the detail's slerp and velocity (blocks of joints stay in cache).
_BLOCK = 8192
#: Seconds cut from each end of a source contact for ``foot_travel_source`` (heel strike and toe-off).
SOURCE_SHRINK = 0.1
#: Added pops (degrees) and jumps (cm) below this are rounding (e.g. of a frame-rate ratio): 0.
_ROUNDING = 1e-9
#: The fields of :meth:`QualityReport.to_row`, in order.
ROW_FIELDS = ("ok", "summary", "foot_travel", "foot_height", "floor", "pelvis", "pelvis_vs_baseline", "added_pop",
              "added_pop_joint", "knots_out_of_order", "detail", "moved")
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


def _positive(x, name: str) -> float:
    x = _number(x, name)
    if x <= 0:
        raise ValueError(f"{name} must be > 0, got {x}")
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
class SummaryItem:
    """One part of :attr:`QualityReport.summary`: ``figure`` (the report field it states, e.g.
    ``"foot_travel"``, ``"pelvis_vs_baseline"``, ``"added_pop"``), ``text`` (the words shown), ``value`` and
    ``bound`` (in ``unit``: cm, ° or × for the detail ratio, whose bound is (low, high); None: not bounded),
    ``ok`` (False: out of bounds, to be shown red) and ``joint`` (the joint it is about, or None)."""

    figure: str
    text: str
    value: float | None
    bound: float | tuple | None
    ok: bool
    unit: str
    joint: str | None = None

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        if isinstance(self.bound, tuple):
            d["bound"] = list(self.bound)
        return d


def _over(value, bound) -> bool:
    return bound is not None and value is not None and value > bound + 1e-9


def _cm(x: float) -> str:
    return f"{x:.1f} cm" if x < 9.95 else f"{x:.0f} cm"


def _part(joint: str | None) -> tuple[str, str]:
    """``(words, verb ending)`` for a joint: ``("left foot", "s")``, ``("right toes", "")``."""
    if joint is None:
        return "a joint", "s"
    from .staggered.timing_report import body_part
    words = body_part(joint)
    if words == str(joint):
        return words, "s"
    words = words[4:] if words.startswith("the ") else words
    return words, "" if words.split()[-1] in ("toes", "fingers", "hips") else "s"


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
    pelvis_vs_baseline_drop: float | None = None

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

    def with_bounds(self, bounds) -> QualityReport:
        """The same figures judged against other ``bounds`` (a preset name, :class:`Bounds` or dict)."""
        return dataclasses.replace(self, bounds=_bounds(bounds))

    @property
    def items(self) -> tuple:
        """The one-line summary as structured parts (:class:`SummaryItem`: figure, text, value, bound, ok), in
        the order of :attr:`summary`: the feet, the pelvis, the pops, then whatever else is out of bounds (the
        floor, a moved joint, knots out of order, detail). A widget shows ``text`` and colours it red where
        ``ok`` is False."""
        b, out = self.bounds, []
        worst_c = max(self.contacts, key=lambda c: c.travel, default=None)
        high_c = max(self.contacts, key=lambda c: c.height, default=None)
        if not self.contacts:
            out.append(SummaryItem("contacts", "no contacts", None, None, True, ""))
        else:
            bad_t = _over(self.foot_travel, b.travel)
            bad_h = _over(self.foot_height, b.height)
            worse = (b.no_worse_than_baseline and self.baseline_foot_travel is not None
                     and self.foot_travel > self.baseline_foot_travel + _BASELINE_SLACK)
            if bad_t:
                part, s = _part(worst_c.joint)
                out.append(SummaryItem("foot_travel", f"{part} slide{s} {_cm(self.foot_travel)}", self.foot_travel,
                                       b.travel, False, "cm", worst_c.joint))
            if worse:
                part, s = _part(worst_c.joint)
                out.append(SummaryItem("foot_travel_vs_baseline",
                                       f"{part} slide{s} {_cm(self.foot_travel)}, more than without the layer "
                                       f"({_cm(self.baseline_foot_travel)})", self.foot_travel,
                                       self.baseline_foot_travel + _BASELINE_SLACK, False, "cm", worst_c.joint))
            if bad_h:
                part, s = _part(high_c.joint)
                whose = 'their' if s == '' else 'its'
                out.append(SummaryItem("foot_height", f"{part} {_cm(self.foot_height)} off {whose} "
                                       "plant", self.foot_height, b.height, False, "cm", high_c.joint))
            if not (bad_t or bad_h or worse):
                out.append(SummaryItem("foot_travel", "feet held", self.foot_travel, b.travel, True, "cm"))
        if _over(self.floor, b.floor):
            out.append(SummaryItem("floor", f"{_cm(self.floor)} below the floor", self.floor, b.floor, False, "cm"))
        if self.pelvis_vs_baseline is not None:
            name, pel, drop = "pelvis_vs_baseline", self.pelvis_vs_baseline, self.pelvis_vs_baseline_drop
        else:
            name, pel, drop = "pelvis", self.pelvis, self.pelvis_drop
        if _over(pel, b.pelvis):
            way = "drops" if drop is not None and drop >= pel - 1e-9 else "rises"
            out.append(SummaryItem(name, f"pelvis {way} {_cm(pel)}", pel, b.pelvis, False, "cm"))
        else:
            out.append(SummaryItem(name, f"pelvis ±{pel:.1f} cm", pel, b.pelvis, True, "cm"))
        if _over(self.added_pop, b.pop):
            part, s = _part(self.added_pop_joint)
            out.append(SummaryItem("added_pop", f"{part} pop{s} {self.added_pop:.0f}°", self.added_pop, b.pop, False,
                                   "°", self.added_pop_joint))
        else:
            text = "no pops" if self.added_pop < 0.5 else f"pops ≤ {self.added_pop:.0f}°"
            out.append(SummaryItem("added_pop", text, self.added_pop, b.pop, True, "°", self.added_pop_joint))
        if _over(self.moved, b.moved):
            part, s = _part(self.moved_joint)
            out.append(SummaryItem("moved", f"{part} moved {_cm(self.moved)}", self.moved, b.moved, False, "cm",
                                   self.moved_joint))
        if self.knots_out_of_order:
            n = len(self.knots_out_of_order)
            parts = list(dict.fromkeys(_part(j)[0] for j in self.knots_out_of_order))
            where = ", ".join(parts[:3]) + (f" and {len(parts) - 3} more" if len(parts) > 3 else "")
            out.append(SummaryItem("knots_out_of_order", f"poses out of order in {where}", float(n),
                                   None if b.knots is None else float(b.knots), b.knots is None or n <= b.knots, ""))
        if b.detail is not None and not b.detail[0] <= self.detail <= b.detail[1]:
            text = (f"detail lost (×{self.detail:.2f})" if self.detail < b.detail[0]
                    else f"jitter added (×{self.detail:.2f})")
            out.append(SummaryItem("detail", text, self.detail, b.detail, False, "×"))
        return tuple(out)

    @property
    def summary(self) -> str:
        """One line for an animator: ``"feet held · pelvis ±0.8 cm · no pops"`` when every figure is inside
        :attr:`bounds`; what is out of bounds is said plainly instead (``"left foot slides 3.2 cm · pelvis
        drops 6.0 cm · no pops"``). The parts, with their figures and bounds: :attr:`items`."""
        return " · ".join(item.text for item in self.items)

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
        d.update(failures=list(self.failures), ok=self.ok, summary=self.summary,
                 items=[item.to_dict() for item in self.items])
        return d

    def to_row(self) -> dict:
        """The main figures as one flat row of JSON scalars (what a table of clips shows, e.g. the batch
        report): ``ok``, ``summary`` and :data:`ROW_FIELDS`' figures (cm of a 170 cm body, degrees, the detail
        ratio; ``pelvis_vs_baseline`` None without a baseline; ``knots_out_of_order`` a count, None without a
        StaggeredMotion)."""
        row = {"ok": self.ok, "summary": self.summary}
        for name in ROW_FIELDS[2:]:
            v = getattr(self, name)
            row[name] = len(v) if name == "knots_out_of_order" and v is not None else v
        return row

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


def _check_contacts(source: Motion, contacts) -> tuple:
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
    return tuple(out)


def _positions_arg(x, motion: Motion, name: str) -> np.ndarray:
    """``x`` (F, J, 3) checked as ``forward_kinematics(motion)[0]``'s shape and finite, component-major."""
    p = np.asarray(x, dtype=float)
    want = (motion.num_frames, motion.num_joints, 3)
    if p.shape != want or not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be finite, of shape {want} (forward_kinematics(...)[0]), got {p.shape}")
    return _to_component_major(p)


def _height_rows(P: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Heights along the coordinate axis ``up`` (±X/±Y/±Z) of component-major positions ``P (3, ...)``."""
    a = int(np.argmax(np.abs(up)))
    return P[a] if up[a] > 0 else -P[a]


# -- vectorised kernels on component-major arrays (C, J, F): each step one contiguous numpy operation -------

def _fk_cm(motion: Motion, joints=None) -> tuple[np.ndarray, np.ndarray | None]:
    """``(P, Q)``: world positions ``P (3, J, F)`` (component-major ``forward_kinematics(motion)[0]``, the
    same products: equal bit for bit) and the local rotations ``Q (4, J, F)``; with ``joints`` only those
    and their ancestors are computed (``P (3, n, F)`` for ``sub``, see :func:`_fk_rows`; Q is None)."""
    sk = motion.skeleton
    if joints is None:
        Q = _to_component_major(motion.local_quats)
        T = (sk.offsets.T[:, :, None] if motion.local_translations is None
             else _to_component_major(motion.local_translations))
        return _fk_component_major(Q, T, motion.root_positions.T, sk.parents)[1], Q
    from .staggered.contacts import chain_subset
    sub, sub_par, _ = chain_subset(sk.parents, joints)
    Q = np.empty((4, sub.size, motion.num_frames))
    for c in range(4):
        Q[c] = motion.local_quats[:, sub, c].T
    if motion.local_translations is None:
        T = sk.offsets[sub].T[:, :, None]
    else:
        T = np.empty((3, sub.size, motion.num_frames))
        for c in range(3):
            T[c] = motion.local_translations[:, sub, c].T
    return _fk_component_major(Q, T, np.ascontiguousarray(motion.root_positions.T), sub_par)[1], None


def _fk_rows(motion: Motion, joints) -> np.ndarray:
    """World positions ``(3, J, F)`` of ``joints`` (their chains' FK; the other rows NaN)."""
    from .staggered.contacts import chain_subset
    sub, _, _ = chain_subset(motion.skeleton.parents, joints)
    P = np.full((3, motion.num_joints, motion.num_frames), np.nan)
    P[:, sub] = _fk_cm(motion, joints)[0]
    return P


def _dot(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Component dot product of component-first quaternions ``(4, ...)`` -> ``(...)``."""
    d = A[0] * B[0]
    for c in (1, 2, 3):
        d += A[c] * B[c]
    return d


def _largest_angles(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Largest rotation angle (degrees) between ``A`` and ``B`` (4, J, n) over ``n``, per joint ``(J,)``.

    The angle grows with the chord ``|a - s b|`` (``s`` the sign of ``a·b``: the shorter arc), which has no
    cancellation for small angles (``1 - |a·b|`` has, and unit quaternions are unit to ~1e-12 only): the
    frame of the longest chord is found for all joints at once, and
    :func:`~stagger_nb.core.rotations.quat_angle` evaluated there only (one pair per joint)."""
    J, n = A.shape[1], A.shape[2]
    if n == 0:
        return np.zeros(J)
    sign = np.copysign(1.0, _dot(A, B))
    chord = np.zeros(A.shape[1:])
    for c in range(4):
        d = A[c] - sign * B[c]
        d *= d
        chord += d
    k = np.argmax(chord, axis=1)
    cols = np.arange(J)
    a, b = A[:, cols, k].T, B[:, cols, k].T                                   # (J, 4)
    out = np.degrees(quat_angle(a, b))
    out[np.all(a == b, axis=1)] = 0.0
    return out


def _step_angles(Q: np.ndarray) -> np.ndarray:
    """Largest frame-to-frame rotation angle (degrees) of each joint of ``Q (4, J, F)`` -> ``(J,)``."""
    if Q.shape[2] < 2:
        return np.zeros(Q.shape[1])
    return _largest_angles(Q[:, :, :-1], Q[:, :, 1:])


def _norms2(D: np.ndarray) -> np.ndarray:
    """Squared lengths of component-first vectors ``D (3, ...)``."""
    return D[0] * D[0] + D[1] * D[1] + D[2] * D[2]


def _step_lengths(P: np.ndarray) -> np.ndarray:
    """Largest frame-to-frame displacement of each joint of ``P (3, J, F)`` -> ``(J,)`` (file units)."""
    if P.shape[2] < 2:
        return np.zeros(P.shape[1])
    return np.sqrt(_norms2(np.diff(P, axis=2)).max(axis=1))


def _relative_rotvecs(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Rotation vectors ``rotvec(a⁻¹ b)`` (angle in [0, π], as :func:`~stagger_nb.core.rotations.quat_to_rotvec`:
    ``2 atan2(|v|, |w|) v / |v|`` on the hemisphere ``w >= 0``, ``2 v / w`` below ``|v| = 1e-12``) of
    component-first quaternions ``A, B (4, ...)`` -> ``(3, ...)``."""
    R = np.empty(np.broadcast_shapes(A.shape, B.shape))
    tmp = np.empty(R.shape[1:])
    quat_mul_components((-A[0], -A[1], -A[2], A[3]), B, R, tmp)
    V, w = R[:3], R[3]
    s = np.sqrt(_norms2(V))
    aw = np.abs(w)
    big = s > _SMALL
    scale = np.arctan2(s, aw, out=tmp)
    scale /= np.where(big, s, 1.0)
    if not big.all():
        scale[~big] = 1.0 / aw[~big]
    scale *= 2.0
    np.copysign(scale, w, out=scale)                     # -q for w < 0: the same rotation, the short way
    V *= scale
    return V


def _slerp_cm(A: np.ndarray, B: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation of component-first quaternions ``A, B (4, ...)`` at ``t (...)`` along the
    shorter arc, as :func:`~stagger_nb.core.rotations.slerp`: ``sin((1 - t) θ) a + sin(t θ) b`` normalised (the
    common ``1 / sin θ`` cancels in the normalisation; below ``sin θ = 1e-9`` the weights ``1 - t`` and ``t``)."""
    d = _dot(A, B)
    sign = np.copysign(1.0, d)
    np.abs(d, out=d)
    theta = np.arccos(np.minimum(d, 1.0, out=d), out=d)
    small = theta < 1e-9
    w0 = np.sin((1.0 - t) * theta)
    w1 = np.sin(t * theta)
    if small.any():
        w0[small] = (1.0 - t)[small] if np.ndim(t) else 1.0 - t
        w1[small] = t[small] if np.ndim(t) else t
    w1 *= sign
    out = A * w0
    out += B * w1
    out /= np.sqrt(_dot(out, out))
    return out


def _fractional(f: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(i0, i1, w)`` of fractional frame indices ``f`` into ``count`` frames: ``f`` clamped, ``w = 0``
    within 1e-9 of a frame (a time on a frame reads that frame exactly)."""
    f = np.clip(f, 0.0, count - 1)
    i0 = np.minimum(np.floor(f + 1e-9).astype(np.int64), count - 1)
    w = f - i0
    w[np.abs(w) < 1e-9] = 0.0
    return i0, np.minimum(i0 + 1, count - 1), w


def _read_positions(P: np.ndarray, joints: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """``P (3, J, F)`` at fractional ``frames (n,)`` of ``joints (n,)`` (linear) -> ``(3, n)``."""
    i0, i1, w = _fractional(frames, P.shape[2])
    out = P[:, joints, i0]
    moving = w > 0
    if moving.any():
        wm = w[moving]
        out[:, moving] = P[:, joints[moving], i0[moving]] * (1 - wm) + P[:, joints[moving], i1[moving]] * wm
    return out


def _band_pass_energy(V: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Mean over samples of the squared band-passed angular velocity ``V (3, J, n)`` -> ``(J,)`` (rad²/s²):
    ``kernel`` is the difference of the two Gaussian low-passes (:func:`_detail_kernel`), one correlation along
    time (the nearest sample repeated past each end, as ``gaussian_filter1d(mode="nearest")``)."""
    from scipy.ndimage import correlate1d
    C, J, n = V.shape
    if n < 2:
        return np.zeros(J)
    hp = correlate1d(V.reshape(C * J, n), kernel, axis=1, mode="nearest")
    hp *= hp
    return hp.reshape(C, J, n).sum(axis=0).mean(axis=1)


def _detail_kernel(frame_time: float) -> np.ndarray:
    """Correlation weights of ``gaussian_filter1d(σ = DETAIL_FINE) - gaussian_filter1d(σ = DETAIL_SIGMA)``
    on samples ``frame_time`` apart (scipy's kernels: truncated at 4 σ, normalised), one kernel."""
    from scipy.ndimage._filters import _gaussian_kernel1d
    sf, sc = DETAIL_FINE / frame_time, DETAIL_SIGMA / frame_time
    rf, rc = int(4.0 * sf + 0.5), int(4.0 * sc + 0.5)
    k = -_gaussian_kernel1d(sc, 0, rc)[::-1]
    k[rc - rf: rc + rf + 1] += _gaussian_kernel1d(sf, 0, rf)[::-1]
    return k


def _segments(lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(starts, owner)`` of consecutive segments of ``lengths`` (all > 0) laid end to end: the start of
    each segment and, per element, its segment's start."""
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    return starts, np.repeat(starts, lengths)


def _travels(pe: np.ndarray, ps: np.ndarray, starts: np.ndarray, owner: np.ndarray):
    """Per segment: ``(travel against the source, raw travel)`` of positions ``pe (3, n)`` against
    ``ps (3, n)``: ``max |(p(n) - p(a)) - (p_src(n) - p_src(a))|`` and ``max |p(n) - p(a)|`` (``a`` the
    segment's first element)."""
    de = pe - pe[:, owner]
    rel = np.sqrt(np.maximum.reduceat(_norms2(de - (ps - ps[:, owner])), starts))
    raw = np.sqrt(np.maximum.reduceat(_norms2(de), starts))
    return rel, raw


# -- the source's figures, once ---------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class SourceFigures:
    """Everything :func:`compare` reads of the source alone, computed once by :func:`prepare` (read-only
    arrays; a session caches one per source). Pass it as ``compare(source, edited, prepared=...)``: the
    figures are the same, bit for bit, as without it.

    Attributes
    ----------
    source : Motion
        The motion these figures are of (``compare`` checks it is the ``source`` it is given).
    positions : ndarray, shape (F, J, 3)
        ``forward_kinematics(source)[0]``, file units.
    up : ndarray, shape (3,)
        The vertical axis (:func:`~stagger_nb.core.body.up_axis`).
    body_height, scale : float
        :func:`body_height` (file units) and ``BODY_CM / body_height``.
    contacts : tuple of (joint_name, start_frame, stop_frame)
        The source's contacts (default :func:`~stagger_nb.staggered.detect_contacts`), half-open frames.
    floor : float
        The lowest height any joint of the source reaches (file units).
    pelvis : int
        :func:`~stagger_nb.core.body.pelvis_joint`.
    step_angles : ndarray, shape (J,)
        Each joint's largest frame-to-frame rotation (degrees).
    step_lengths : ndarray, shape (J,)
        Each joint's largest frame-to-frame displacement (file units).
    velocity : ndarray, shape (3, J, G - 1)
        Local angular velocity on the detail grid (G samples ``h`` apart, see :mod:`stagger_nb.quality`):
        ``rotvec(q(n)⁻¹ q(n+1)) / h`` (rad/s), component-major.
    detail : ndarray, shape (J,)
        Band-passed energy of ``velocity`` over the whole grid (rad²/s²).
    """

    source: Motion
    positions: np.ndarray
    up: np.ndarray
    body_height: float
    scale: float
    contacts: tuple
    floor: float
    pelvis: int
    step_angles: np.ndarray
    step_lengths: np.ndarray
    velocity: np.ndarray
    detail: np.ndarray
    _P: np.ndarray = field(repr=False, default=None)          # positions, component-major (3, J, F)
    _Q: np.ndarray = field(repr=False, default=None)          # local rotations, component-major (4, J, F)
    _kernel: np.ndarray = field(repr=False, default=None)     # the detail band-pass (see _detail_kernel)
    _step: int = field(repr=False, default=1)                 # source frames per detail sample (_detail_step)

    def __repr__(self) -> str:
        return (f"SourceFigures({self.source.num_frames} frames x {self.source.num_joints} joints, body "
                f"{self.body_height:.4g} units, {len(self.contacts)} contacts)")


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def prepare(source: Motion, *, contacts=None, body_height: float | None = None,
            source_positions: np.ndarray | None = None) -> SourceFigures:
    """The figures of ``source`` that :func:`compare` needs for any edit (its FK, contacts, body height,
    floor, per-joint largest frame-to-frame rotation and displacement, angular velocity and its detail
    energy), computed once: ``compare(source, edited, prepared=prepare(source))`` then measures only the
    edit (one FK of the edited motion, or none with ``edited_positions=``).

    Parameters are those of :func:`compare` of the same names (``contacts`` default
    :func:`~stagger_nb.staggered.detect_contacts`; ``body_height`` default :func:`body_height`;
    ``source_positions``: ``forward_kinematics(source)[0]`` when the caller has it). Returns a frozen
    :class:`SourceFigures`.
    """
    from . import staggered as stg
    if not isinstance(source, Motion):
        raise ValueError(f"source must be a Motion, got {type(source).__name__}")
    _finite_motion(source, "source")
    if source_positions is None:
        P, Q = _fk_cm(source)
    else:
        P, Q = _positions_arg(source_positions, source, "source_positions"), _to_component_major(source.local_quats)
    pos = _readonly(_to_frame_major(P))
    up = up_axis(source, pos)
    h_body = _body_height(source, pos) if body_height is None else _positive(body_height, "body_height")
    if contacts is None:
        contacts = stg.detect_contacts(source, positions=pos)
    contacts = _check_contacts(source, contacts)
    step = _detail_step(source.frame_time)
    h = step * source.frame_time
    Qg = Q[:, :, ::step]
    V = (_relative_rotvecs(Qg[:, :, :-1], Qg[:, :, 1:]) / h if Qg.shape[2] > 1
         else np.zeros((3, source.num_joints, 0)))
    kernel = _detail_kernel(h)
    detail = _band_pass_energy(V, kernel) if Qg.shape[2] >= 3 else np.zeros(source.num_joints)
    return SourceFigures(
        source=source, positions=pos, up=_readonly(up), body_height=h_body, scale=BODY_CM / h_body,
        contacts=contacts, floor=float(_height_rows(P, up).min()), pelvis=pelvis_joint(source.skeleton),
        step_angles=_readonly(_step_angles(Q)), step_lengths=_readonly(_step_lengths(P)),
        velocity=_readonly(V), detail=_readonly(detail), _P=_readonly(P), _Q=_readonly(Q), _kernel=_readonly(kernel),
        _step=step)


# -- the edit's figures -------------------------------------------------------------------------------------

def _warp_table(sm):
    """``(tables, table)``: ``(S, T)`` of the time warps of ``sm`` (every control variable's,
    :func:`staggered.warp_times`), and the same or None when no knot moved (the warp is the identity);
    ``(None, None)`` without a StaggeredMotion."""
    if sm is None:
        return None, None
    from .staggered.timing import _warp_tables
    S, T = _warp_tables(sm)
    return (S, T), None if np.array_equal(S, T) else (S, T)


def _warp(table, c: int, times: np.ndarray, inverse: bool = False) -> np.ndarray:
    from .staggered.timing import _warp_column
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


def _detail_step(frame_time: float) -> int:
    """Source frames between two samples of the detail grid: the grid is the source's frames, every k-th
    one above DETAIL_RATE (a 120 Hz clip is read at 60 Hz)."""
    return max(1, int(1.0 / (DETAIL_RATE * frame_time) + 1e-9))


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


def _carried(sm, contacts, frame_time: float, tables) -> list:
    """Each source contact carried through its joint's own timing: ``(start, stop)`` frames of the edited
    motion, or None where it keeps no frame. The numbers of ``staggered.carry_contacts(sm, contacts,
    frame_time, carry_by="joint")`` (its first and last active times mapped through the joint's time warp,
    the edited frames inside), computed for all contacts at once, one warp per contact joint."""
    from .staggered.representation import default_times
    from .staggered.timing import _warp_column
    if not contacts:
        return []
    names = sm.skeleton.names
    S, T = tables
    t0, ft, F = float(sm.pose_times[0]), sm.frame_time, default_times(sm).size
    joints = np.array([names.index(c[0]) for c in contacts])
    ends = np.array([(a, b - 1) for _, a, b in contacts], dtype=float) * frame_time        # (N, 2) seconds
    for j in np.unique(joints):
        at = joints == j
        ends[at] = _warp_column(S, T, int(j), ends[at].ravel()).reshape(-1, 2)
    e = (ends - t0) / ft
    start = np.maximum(np.ceil(e[:, 0] - 1e-6), 0).astype(np.int64)
    stop = np.minimum(np.floor(e[:, 1] + 1e-6) + 1, F).astype(np.int64)
    return [(int(a), int(b)) if b > a else None for a, b in zip(start, stop)]


def compare(source: Motion, edited, *, staggered=None, contacts=None, baseline=None, bounds=None,
            body_height: float | None = None, source_positions: np.ndarray | None = None,
            prepared: SourceFigures | None = None, edited_positions: np.ndarray | None = None,
            baseline_positions: np.ndarray | None = None) -> QualityReport:
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
        Source contacts, half-open source frames; default ``prepared.contacts``, else
        ``staggered.detect_contacts(source)``.
    baseline : Motion or StaggeredMotion, optional
        The same edit without the contact layer: ``pelvis_vs_baseline`` and ``baseline_foot_travel`` are
        measured against it.
    bounds : "mild" | "moderate" | "strong" | "unedited" | Bounds | dict, optional
        What :attr:`QualityReport.failures` checks (default ``"mild"``; a dict overrides fields of its
        ``"preset"``, e.g. ``{"preset": "strong", "pop": 8}``).
    body_height : float, optional
        The source's body height in file units (default ``prepared.body_height``, else :func:`body_height`).
    source_positions : ndarray (F, J, 3), optional
        ``forward_kinematics(source)[0]`` when the caller has it (the same figures, one FK fewer; not read
        with ``prepared``).
    prepared : SourceFigures, optional
        :func:`prepare` of ``source``: the source's figures, computed once for any number of edits (the
        same report, bit for bit).
    edited_positions, baseline_positions : ndarray (F_edited, J, 3), optional
        ``forward_kinematics(edited)[0]`` / ``(baseline)[0]`` when the caller has them (the baseline's is
        otherwise computed for the pelvis and the contact joints' chains only).

    Returns
    -------
    QualityReport (frozen): the figures, per-contact and per-joint detail, ``.summary``, ``.items``, ``.ok``,
    ``.failures``, ``.to_dict()``.
    """
    from . import staggered as stg
    if not isinstance(source, Motion):
        raise ValueError(f"source must be a Motion, got {type(source).__name__}")
    if prepared is None:
        prepared = prepare(source, contacts=contacts, body_height=body_height, source_positions=source_positions)
        contacts = body_height = None
    elif not isinstance(prepared, SourceFigures):
        raise ValueError(f"prepared must be quality.prepare(source), got {type(prepared).__name__}")
    elif prepared.source is not source:
        raise ValueError("prepared: computed for another source motion (use quality.prepare(source) of this one)")
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
    elif baseline_positions is not None:
        raise ValueError("baseline_positions: given without a baseline")
    bnds = _bounds(bounds)
    contacts = prepared.contacts if contacts is None else _check_contacts(source, contacts)
    if body_height is None:
        scale, h_body = prepared.scale, prepared.body_height
    else:
        h_body = _positive(body_height, "body_height")
        scale = BODY_CM / h_body
    if edited_positions is None:
        Pe, Qe = _fk_cm(motion)
    else:
        Pe, Qe = _positions_arg(edited_positions, motion, "edited_positions"), _to_component_major(motion.local_quats)
    return _measure(prepared, motion, sm, Pe, Qe, base, baseline_positions, contacts, scale, h_body, bnds)


def _measure(prep: SourceFigures, motion: Motion, sm, Pe: np.ndarray, Qe: np.ndarray, base, base_positions,
             contacts: tuple, scale: float, h_body: float, bnds: Bounds) -> QualityReport:
    """The figures of :func:`compare` from the source's (``prep``) and the edit's FK ``Pe (3, J, F)`` and
    rotations ``Qe (4, J, F)``."""
    src, sk, up = prep.source, prep.source.skeleton, prep.up
    names = sk.names
    Fs, J, F = src.num_frames, src.num_joints, motion.num_frames
    Ps = prep._P
    ft_s, ft_e = src.frame_time, motion.frame_time
    t0 = float(sm.pose_times[0]) if sm is not None else 0.0
    tables, table = _warp_table(sm)
    te = t0 + np.arange(F) * ft_e
    n_in = int(np.searchsorted(te, src.duration + 0.5 * ft_s + 1e-9, side="right"))   # frames the source covers
    # the source at the same times (te increasing: the covered frames are the first n_in)
    i0, i1, w = _fractional(te[:n_in] / ft_s, Fs)
    same_frames = not w.any() and np.array_equal(i0, np.arange(n_in))
    if same_frames:
        src_at, q_src = Ps[:, :, :n_in], prep._Q[:, :, :n_in]
    else:
        src_at, q_src = Ps[:, :, i0], prep._Q[:, :, i0]
        frac = w > 0
        if frac.any():
            wf = w[frac]
            src_at[:, :, frac] = Ps[:, :, i0[frac]] * (1 - wf) + Ps[:, :, i1[frac]] * wf
            q_src[:, :, frac] = _slerp_cm(prep._Q[:, :, i0[frac]], prep._Q[:, :, i1[frac]],
                                          np.broadcast_to(wf, (J, wf.size)))

    # whole-body figures
    if n_in:
        moved_j = np.sqrt(_norms2(Pe[:, :, :n_in] - src_at).max(axis=1))
        rotated = float(_largest_angles(q_src, Qe[:, :, :n_in]).max())
    else:
        moved_j, rotated = np.zeros(J), 0.0
    mj = int(np.argmax(moved_j))
    pel = prep.pelvis
    He = _height_rows(Pe, up)                                                     # (J, F)
    dpel = He[pel, :n_in] - _height_rows(src_at[:, pel], up)
    pelvis = float(np.abs(dpel).max()) * scale if dpel.size else 0.0
    pelvis_drop = float(max(-dpel.min(), 0.0)) * scale if dpel.size else 0.0
    pelvis_vs_base = pelvis_base_drop = None
    Pb = None
    if base is not None:
        if base_positions is not None:
            Pb = _positions_arg(base_positions, base, "baseline_positions")
        else:
            Pb = _fk_rows(base, sorted({pel} | {sk.index(c[0]) for c in contacts}))   # (NaN elsewhere)
        n = min(base.num_frames, F)
        db = He[pel, :n] - _height_rows(Pb[:, pel, :n], up)
        pelvis_vs_base = float(np.abs(db).max()) * scale if n else 0.0
        pelvis_base_drop = float(max(-db.min(), 0.0)) * scale if n else 0.0
    floor_pen = max(prep.floor - float(He.min()), 0.0) * scale

    ratio = ft_s / ft_e
    pop_added = np.maximum(_step_angles(Qe) * ratio - prep.step_angles, 0.0)
    pop_added[pop_added < _ROUNDING] = 0.0            # a frame-rate ratio's rounding is no pop (nor a joint)
    pj = int(np.argmax(pop_added))
    jump_added = np.maximum(_step_lengths(Pe) * ratio - prep.step_lengths, 0.0) * scale
    jump_added[jump_added < _ROUNDING] = 0.0
    jj = int(np.argmax(jump_added))
    e_e, e_s = _detail_energies(prep, Qe, ft_e, table, t0)
    total_s = float(e_s.sum())
    detail = float(e_e.sum()) / total_s if total_s > 0 else 1.0
    # per joint; a joint still in the source (energy at rounding level: 1e-12 of the mean) reads 1 when it
    # stays still, else its energy over that floor
    tiny = max(1e-12 * total_s / max(e_s.size, 1), 1e-300)
    detail_j = np.where(e_s > tiny, e_e / np.maximum(e_s, tiny), np.where(e_e > tiny, e_e / tiny, 1.0))

    knots_bad = None
    if sm is not None:
        T = np.concatenate([sm.knot_times(), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)
        bad = ~np.all(np.diff(T, axis=0) > 0, axis=0)
        knots_bad = tuple((list(names) + ["<root translation>"])[c] for c in np.flatnonzero(bad))

    figures = _contact_figures(prep, contacts, sm, tables, table, Pe, He, Pb, te, F, base, scale)
    in_src, in_src_raw = _source_interval_travel(prep, contacts, Pe, te, scale)

    def worst(attr):
        return max((getattr(c, attr) for c in figures), default=0.0)

    base_travel = None if base is None else max((c.baseline_travel for c in figures), default=0.0)
    return QualityReport(
        scale=scale, body_height=h_body,
        foot_travel=worst("travel"), foot_travel_raw=worst("travel_raw"), foot_path=worst("path"),
        foot_height=worst("height"), foot_travel_source=in_src, foot_travel_source_raw=in_src_raw,
        floor=floor_pen, pelvis=pelvis, pelvis_drop=pelvis_drop, pelvis_vs_baseline=pelvis_vs_base,
        added_pop=float(pop_added[pj]), added_pop_joint=names[pj] if pop_added[pj] > 0 else None,
        added_jump=float(jump_added[jj]), added_jump_joint=names[jj] if jump_added[jj] > 0 else None,
        moved=float(moved_j[mj]) * scale, moved_joint=names[mj] if moved_j[mj] > 0 else None,
        rotated=rotated, knots_out_of_order=knots_bad, detail=detail, baseline_foot_travel=base_travel,
        contacts=tuple(figures), joints=tuple(names), pop_added=tuple(pop_added.tolist()),
        jump_added=tuple(jump_added.tolist()), detail_by_joint=tuple(detail_j.tolist()),
        bounds=bnds, pelvis_vs_baseline_drop=pelvis_base_drop)


def _contact_figures(prep, contacts, sm, tables, table, Pe, He, Pb, te, F, base, scale) -> list:
    """One :class:`ContactFigures` per contact carried onto at least one frame, all contacts at once."""
    sk = prep.source.skeleton
    carried = (_carried(sm, contacts, prep.source.frame_time, tables) if sm is not None
               else [(a, b) for _, a, b in contacts])
    kept = [(c, a, min(b, F)) for c, ab in zip(contacts, carried) if ab is not None
            for a, b in [ab] if min(b, F) > a]
    if not kept:
        return []
    first = np.array([a for _, a, _ in kept], dtype=np.int64)
    lengths = np.array([b for _, _, b in kept], dtype=np.int64) - first
    starts, owner = _segments(lengths)
    frames = np.arange(owner.size) + np.repeat(first - starts, lengths)
    joints = np.repeat([sk.index(c[0]) for c, _, _ in kept], lengths)
    tt = te[frames]
    ts = np.empty_like(tt)
    for j in np.unique(joints):                                  # the source time of each frame, per joint
        at = joints == j
        ts[at] = _warp(table, int(j), tt[at], inverse=True)
    ps = _read_positions(prep._P, joints, ts / prep.source.frame_time)
    pe = Pe[:, joints, frames]
    rel, raw = _travels(pe, ps, starts, owner)
    steps = np.sqrt(_norms2(np.diff(pe, axis=1))) if pe.shape[1] > 1 else np.zeros(0)
    steps = np.append(steps, 0.0)
    steps[starts[1:] - 1] = 0.0                                  # no step from one contact into the next
    steps[-1] = 0.0
    path = np.add.reduceat(steps, starts)
    height = np.maximum.reduceat(np.abs(He[joints, frames] - _height_rows(ps, prep.up)), starts)
    bt = [None] * len(kept)
    if Pb is not None:
        inb = frames < base.num_frames                            # a prefix of each contact
        fb = np.minimum(frames, base.num_frames - 1)
        pb = Pb[:, joints, fb]
        d = _norms2((pb - pb[:, owner]) - (ps - ps[:, owner]))
        d[~inb | ~inb[owner]] = 0.0
        bt = (np.sqrt(np.maximum.reduceat(d, starts)) * scale).tolist()
    return [ContactFigures(c[0], (c[1], c[2]), (int(a), int(b)), float(r * scale), float(w * scale),
                           float(p * scale), float(h * scale), t)
            for (c, a, b), r, w, p, h, t in zip(kept, rel, raw, path, height, bt)]


def _source_interval_travel(prep, contacts, Pe, te, scale) -> tuple[float, float]:
    """``(foot_travel_source, foot_travel_source_raw)``: inside the source's own contact intervals shrunk by
    SOURCE_SHRINK at each end, at the same times (no carrying)."""
    ft_s = prep.source.frame_time
    spans, sk = [], prep.source.skeleton
    for name, a, b in contacts:
        s = int(np.searchsorted(te, a * ft_s + SOURCE_SHRINK - 1e-9, side="left"))
        e = int(np.searchsorted(te, (b - 1) * ft_s - SOURCE_SHRINK + 1e-9, side="right"))
        if e - s >= 2:
            spans.append((sk.index(name), s, e))
    if not spans:
        return 0.0, 0.0
    first = np.array([s for _, s, _ in spans], dtype=np.int64)
    lengths = np.array([e for _, _, e in spans], dtype=np.int64) - first
    starts, owner = _segments(lengths)
    frames = np.arange(owner.size) + np.repeat(first - starts, lengths)
    joints = np.repeat([j for j, _, _ in spans], lengths)
    ps = _read_positions(prep._P, joints, te[frames] / ft_s)
    rel, raw = _travels(Pe[:, joints, frames], ps, starts, owner)
    return float(rel.max()) * scale, float(raw.max()) * scale
