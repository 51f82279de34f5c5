"""Typed session operations: one small frozen dataclass per op, with ``from_json`` / ``to_json``.

An op is stored in a session file as a JSON object such as
``{"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 2.0}``. :meth:`Op.from_json` turns such an
object into the op's dataclass (every field checked; defaults filled in) or raises ``ValueError`` whose
message starts with the field's path, e.g. ``ops[2].s: expected a finite number, got '0.1'``;
:meth:`Op.to_json` gives the normalised object back (``from_json(to_json(op)) == op``). Constructing a
dataclass directly checks its fields the same way. The values are immutable (lists become tuples, joint
deltas a tuple of ``(name, (rx, ry, rz))`` pairs), so an op is hashable and its canonical JSON
(:attr:`Op.key`) is computed once.

Each op says which state it consumes (``needs``): ``"staggered"`` (a
:class:`~stagger_nb.staggered.StaggeredMotion`; a Motion is extracted first, Coleman et al. 2008 §4) or
``"motion"`` (a Motion; a staggered state is evaluated first, §3). The runners are in :mod:`.runners`.

Ops (fields; ``?`` optional, ``=`` default):

======================  ================================================================================
extract                 (none)
cull                    exactly one of ``percent`` (0, 100], ``count`` (int >= 2), ``keep`` (pose indices)
succession              root, s, l=1.0, joints?, limit=1.5 (null: raw), falloff? {frame, sigma?, frame_range?}
                        (§5.2, succession)
random_timing           tau >= 0, seed=0, joints?, limit=1.5 (null: raw), falloff?   (§5.2, random timing)
exaggerate              w_r, poses?, reference="previous" (|"next"|"mean"|pose), mode="staggered", joints?,
                        propagate=false, sigma?, frame_range?
edit_pose               pose, deltas {joint: [rx, ry, rz] deg} | targets {joint: [x, y, z, w]},
                        mode="staggered"|"unstaggered", propagate=false, sigma?, frame_range?   (§5.1, Fig. 6a/6b)
retime                  pose, time (s)                               (§5.2, Fig. 6c)
refine                  pose, joint, time (s): one joint's knot at the refined time t_k + r[k, j]   (§3, §5.2)
insert_pose             time (s)                                     (§5.1)
delete_pose             pose                                         (§5.1)
keep_contacts           (none): constraint layer with the source's contacts carried through the timing edits
ik_pose                 pose, joint, target [x, y, z] (world units, at the pose's time), propagate=false,
                        sigma?, frame_range?
guide_poses             reference="self", keytimes?, duration? (s; default the reference's) | free_length=true,
                        skip=8, upsample?        (pose times by the guided warp, Hsu et al. 2007 on §5.2)
edit_frame              frame, deltas
propagate               frame | frames, deltas (one object, or a list with one per frame), sigma?,
                        frame_range? [start, stop), repetitions="keep"|"discard"   (Dean et al. 2018)
guided_warp             duration (s) | free_length=true, skip=8, keytimes?, reference="self", backward=false,
                        upsample?                                    (Hsu et al. 2007)
linear_warp             duration (s), keytimes?
resample                frame_time (s)
======================  ================================================================================

``propagate: true`` on a pose edit (edit_pose, exaggerate, ik_pose) spreads its change to every pose with the
magic wand's falloff (Dean et al. 2018, §3.3) of the edited pose's source frame (``sigma``, ``frame_range`` its
width and half-open source-frame range); ``falloff`` on a timing edit (succession, random_timing) scales each
pose's offsets by the falloff around source frame ``frame``.

One module per part: :mod:`.fields` (the field checks), :mod:`.base` (:class:`Op`, :data:`OPS`, the limits),
:mod:`.staggered` and :mod:`.motion` (the op dataclasses). This package imports no technique package: ops are
plain data.
"""
from __future__ import annotations

from .base import (  # noqa: F401
                   MAX_DEGREES,
                   MAX_EXPONENT,
                   MAX_SECONDS,
                   MAX_SKIP,
                   MAX_TAU,
                   MAX_TIMING_LIMIT,
                   MAX_WEIGHT,
                   MAX_WORLD,
                   OPS,
                   TIMING_LIMIT,
                   Op,
                   _spec,
                   canonical,
                   deltas,
                   limits,
                   op_from_json,
                   validate_op,
)

# the field checks, under their former module (ops.py before the split): stagger_nb.session.ops.number, ...
from .fields import *  # noqa: F403 (fields.__all__: what this package exported before the split)
from .fields import EXTRACT_OPTIONS, MAX_ITEMS, check_extract_options
from .motion import EditFrame, GuidedWarp, LinearWarp, Propagate, Resample
from .staggered import (
                   Cull,
                   DeletePose,
                   EditPose,
                   Exaggerate,
                   Extract,
                   GuidePoses,
                   IKPose,
                   InsertPose,
                   KeepContacts,
                   RandomTiming,
                   Refine,
                   Retime,
                   Succession,
)

__all__ = ["Op", "OPS", "op_from_json", "validate_op", "canonical", "check_extract_options", "EXTRACT_OPTIONS",
           "Extract", "Cull", "Succession", "RandomTiming", "Exaggerate", "EditPose", "Retime", "Refine", "InsertPose",
           "DeletePose", "KeepContacts", "IKPose", "GuidePoses", "EditFrame", "Propagate", "GuidedWarp",
           "LinearWarp", "Resample", "MAX_SKIP", "MAX_ITEMS", "MAX_SECONDS", "MAX_EXPONENT", "MAX_WEIGHT",
           "MAX_DEGREES", "MAX_WORLD", "MAX_TAU", "TIMING_LIMIT", "MAX_TIMING_LIMIT", "limits"]
