"""What :func:`~stagger_nb.quality.compare` returns: :class:`QualityReport` (its failures against the bounds,
its one-line summary, its dict and row), one :class:`ContactFigures` per carried contact and the
:class:`SummaryItem` parts of the summary."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from .bounds import Bounds, _bounds
from .constants import _BASELINE_SLACK, ROW_FIELDS


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
    from ..staggered.timing_report import body_part
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
