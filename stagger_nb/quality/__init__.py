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
edit by the package's one carry, the one the contact layer holds (``carry_contacts(staggered, contacts,
source.frame_time)``, :mod:`stagger_nb.staggered.plants_carry`): on the time warp ``w`` of the pelvis, the joint
the legs hang from (a contact joint not on a limb below the pelvis: of the joint whose rotation sets its
position); without a StaggeredMotion they stay on their frames. Inside a carried contact frame ``n``
corresponds to the source time ``w⁻¹(t_n)`` (:func:`~stagger_nb.staggered.warp_times`, inverse, of the clock
that carried it).

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
* ``pelvis`` (cm): ``max_n |h_pelvis(n) - h_pelvis,src(w⁻¹ t_n)|``, the pelvis
  :func:`~stagger_nb.core.body.pelvis_joint` against the source's at the time the root translation's warp
  ``w`` (which carries the pelvis height) maps frame ``n`` to (the same time without a StaggeredMotion): a
  timing edit alone changes no height, so what is measured is the pelvis the edit (the contact layer) raised or
  lowered; ``pelvis_drop`` the largest lowering (>= 0); with a ``baseline``
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

Modules (each one job): :mod:`.constants`, :mod:`.bounds` (Bounds, PRESETS), :mod:`.report` (QualityReport and
its parts), :mod:`.body` (body_height, scaled), :mod:`.inputs` (argument checks), :mod:`.arrays` (the vectorised
steps), :mod:`.source` (prepare), :mod:`.detail` (time warps, the detail energy), :mod:`.measure` (compare).
"""
from .body import body_height, scaled
from .bounds import PRESETS, Bounds
from .constants import BODY_CM, DETAIL_FINE, DETAIL_RATE, DETAIL_SIGMA, ROW_FIELDS, SOURCE_SHRINK
from .measure import compare
from .report import ContactFigures, QualityReport, SummaryItem
from .source import SourceFigures, prepare

__all__ = ["compare", "prepare", "SourceFigures", "QualityReport", "SummaryItem", "ContactFigures", "Bounds", "PRESETS",
           "body_height", "scaled", "ROW_FIELDS",
           "BODY_CM", "DETAIL_SIGMA", "DETAIL_FINE", "DETAIL_RATE", "SOURCE_SHRINK"]
