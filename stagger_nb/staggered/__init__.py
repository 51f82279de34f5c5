"""Staggered poses (Coleman, Bibliowicz, Singh & Gleicher 2008): extraction, representation, editing.

Public names: :func:`extract`, :func:`evaluate`, :func:`cull`, :func:`detect_contacts`,
:class:`StaggeredMotion` (``sm.pose_times (K,)``, ``sm.refinements (K, J)`` in seconds).
The editing tools (§5) are in ``editing.py`` (timing warnings: :func:`timing_warnings`, one plain sentence:
:func:`summarize_timing_warnings`; the per-joint time warp of the timing edits: :func:`warp_times`), the IK
constraint layer in ``constraints.py`` (:func:`keep_contacts`: the source's contacts carried through the
timing edits and held), one knot's timing in ``knots.py`` (:func:`refine`), IK posing of a staggered pose in
``ik.py`` (:func:`ik_pose`).
"""
from __future__ import annotations

from .constraints import (apply_contact_constraints, attenuation_weights, carry_contacts, contact_errors,
                          contact_positions, foot_skate, keep_contacts, two_bone_ik)
from .contacts import detect_contacts, end_effectors
from .editing import (OffsetBasis, TimingWarning, delete_pose, edit_pose, exaggerate, insert_pose, mean_pose,
                      pose_offset_basis, random_timing, retime, source_knot_times, succession, summarize_timing_warnings, timing_warnings, warp_times)
from .ik import IKPoseResult, ik_pose, solve_limb
from .knots import refine
from .extraction import PoseEvidence, cull, cull_keep, extract, locate_poses, pose_priorities
from .features import motion_trail_curvature
from .fitting import fit_staggered
from .representation import StaggeredMotion, evaluate, evaluate_arrays, knot_times

__all__ = ["StaggeredMotion", "extract", "evaluate", "cull", "cull_keep", "detect_contacts", "end_effectors",
           "locate_poses",
           "PoseEvidence", "pose_priorities", "motion_trail_curvature", "fit_staggered", "evaluate_arrays",
           "knot_times",
           "TimingWarning", "timing_warnings", "summarize_timing_warnings", "source_knot_times", "warp_times", "edit_pose", "exaggerate", "OffsetBasis", "pose_offset_basis", "retime", "succession", "random_timing",
           "insert_pose", "delete_pose", "mean_pose", "refine", "apply_contact_constraints", "two_bone_ik", "contact_positions",
           "contact_errors", "foot_skate", "attenuation_weights", "carry_contacts", "keep_contacts",
           "IKPoseResult", "ik_pose", "solve_limb"]
