"""Staggered poses (Coleman, Bibliowicz, Singh & Gleicher 2008): extraction, representation, editing.

Public names: :func:`extract`, :func:`evaluate`, :func:`cull`, :func:`detect_contacts`,
:class:`StaggeredMotion` (``sm.pose_times (K,)``, ``sm.refinements (K, J)`` in seconds).

Modules, one job each (paper sections in brackets):

* ``channel``: one kind of control variable (knots, tangents, refinements, displacement maps) and its algebra
  (⊕/⊖ and the spline: quaternion product for rotations, + for the root translation), §3;
  ``representation``: :class:`StaggeredMotion`, which holds a rotation channel and a translation channel;
  ``evaluation``: the one evaluator of a channel, and :func:`evaluate` (§3; the C kernel ``_cspline.c`` behind
  ``_kernels`` where built).
* ``features`` (motion-trail curvature, §4.1), ``contacts`` (detection, Appendix B), ``extraction``
  (:func:`extract`, :func:`cull`, §4.1).
* fitting (§4.1.1, Appendix A): ``sampling`` (grids), ``rotation_fit`` (C0) and ``rotation_fit_c1`` (C1),
  ``translation_fit``, ``displacement`` (maps and their re-measuring), ``fitting`` (:func:`fit_staggered`).
* editing (§5): ``geometry`` (:func:`edit_pose`, :func:`exaggerate`, §5.1), ``timing`` (:func:`succession`,
  :func:`random_timing`, :func:`retime`, one knot: :func:`refine`, their saturation :func:`saturate_offsets`,
  the per-joint time warp :func:`warp_times`, §5.2), ``timing_report`` (:func:`timing_warnings`; the one plain
  sentence of a timing edit: :func:`timing_summary`), ``structure`` (:func:`insert_pose`, :func:`delete_pose`).
* constraints (§3): ``ik`` (:func:`two_bone_ik`, :func:`ik_pose`), ``limbs`` (the limbs that hold a contact, on
  any rig), ``plants`` (the contact layer, :func:`keep_contacts` / :func:`hold_plants`: the source's contacts
  carried through the timing edits and held where the source holds them; issue 20).

The editing tools (§5): every tool is a pure function ``StaggeredMotion -> StaggeredMotion`` whose parameters
are JSON-serialisable (joint names, numbers, lists), so an edit session can record
``{"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 2.0}`` and replay it; tools take an optional
``joints=`` subset (partial poses, §6).

Notation (as in ``representation``): K poses at times ``t_k``, J joints, refinements ``r[k, i]``, knot
times ``T[k, i] = t_k + r[k, i]``, extreme-value knots ``v[k, i]``, editing knots ``v⁰[k, i]`` (the true pose at
``t_k``). For rotations ``a ⊕ b = a b`` (quaternion product, ``b`` in the joint's local frame) and
``c ⊖ a = a⁻¹ c``; "``w`` times a rotation" is a rotation scale ``exp(w log q)`` (§5.1 footnote).
"""
from __future__ import annotations

from .contacts import detect_contacts, end_effectors
from .evaluation import evaluate, evaluate_arrays
from .extraction import PoseEvidence, cull, cull_keep, extract, locate_poses, pose_priorities
from .features import motion_trail_curvature
from .fitting import fit_staggered
from .geometry import OffsetBasis, edit_pose, exaggerate, mean_pose, pose_offset_basis, spread_offsets
from .ik import IKPoseResult, ik_pose, solve_limb, two_bone_ik
from .plants import (
                     PlantsResult,
                     apply_contact_constraints,
                     attenuation_weights,
                     carry_contacts,
                     contact_errors,
                     contact_positions,
                     foot_skate,
                     hold_plants,
                     keep_contacts,
)
from .representation import StaggeredMotion, knot_times
from .saturation import TIMING_LIMIT, saturate_offsets
from .source_times import source_knot_times, source_pose_times, warp_times
from .structure import delete_pose, insert_pose
from .timing import random_timing, refine, retime, succession
from .timing_report import TimingWarning, body_part, summarize_timing_warnings, timing_summary, timing_warnings

__all__ = ["StaggeredMotion", "extract", "evaluate", "cull", "cull_keep", "detect_contacts", "end_effectors",
           "locate_poses", "PoseEvidence", "pose_priorities", "motion_trail_curvature", "fit_staggered",
           "evaluate_arrays", "knot_times",
           "TimingWarning", "timing_warnings", "summarize_timing_warnings", "timing_summary", "body_part",
           "saturate_offsets", "TIMING_LIMIT", "source_knot_times", "source_pose_times", "warp_times", "spread_offsets",
           "edit_pose", "exaggerate", "OffsetBasis", "pose_offset_basis", "retime", "refine", "succession",
           "random_timing",
           "insert_pose", "delete_pose", "mean_pose", "apply_contact_constraints", "two_bone_ik",
           "contact_positions", "contact_errors", "foot_skate", "attenuation_weights", "carry_contacts",
           "keep_contacts", "hold_plants", "PlantsResult", "IKPoseResult", "ik_pose", "solve_limb"]
