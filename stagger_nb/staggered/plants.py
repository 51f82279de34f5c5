"""The contact layer: plants held where the source holds them (issue 20).

After a staggered timing edit each joint replays the source on its own clock, so a foot that the source held
still slides: its leg's rotations and the pelvis no longer agree in time. This layer is the final IK
displacement of the staggered-poses paper (Coleman et al. 2008, §3: non-zero only while a constraint is
active, plus a smoothly attenuated window), built the way footskate clean-up meets plants (Kovar, Schreiner
& Gleicher 2002: plants met exactly by analytic leg IK, the root adjusted only as much as the plants need,
smoothly, every change blended in and out).

The steps, per limb (a leg or an arm found by :func:`find_limb`; every joint below its effector, e.g. toes
and heel, moves with it as one foot):

1. **Plants.** The source's contacts ``(joint, start, stop)`` (half-open source frames) are carried through
   the time warp of the pelvis, the joint the legs hang from (:func:`carry_contacts`, :mod:`.plants_carry`: the
   carry :func:`stagger_nb.quality.compare` measures with); a foot's contacts of one step (heel, toe, toes) form
   one plant.
2. **Where.** The plant tracks the source's own foot: at edited frame ``t`` the foot takes the source's
   position and world orientation at source time ``σ(t)``, the inverse time warp of the clock that carried the
   plant (the pelvis's) kept inside the plant's source frames, so the source's heel-toe roll is kept and replayed
   on the edited timing. The whole plant is moved horizontally by one constant offset ``d``: where the edited body
   puts the foot at the plant's first frame (against the source's foot there), so the hip reaches the plant as
   the edit placed the leg and the pelvis need not come down to reach the source's position; moved towards the
   hip's travel only if that lets the leg reach without lowering the pelvis. The height is the source's.
   With no timing edit ``σ`` is the identity and ``d`` zero: the motion comes back unchanged.
3. **Blend.** Around each plant a raised-cosine weight (C1, ``blend`` seconds each side) moves the target
   from the edited foot to the plant: the source's approach / take-off through ``σ`` extended with slope 1
   (a take-off into the air, no plant ahead, where the edit slowed the knee's clock against the hip's: at the
   knee's pace, at most 4 times slower, so the knee does not bend through the take-off within a few of its own
   frames), shifted by the plant's ``d``; between two plants of one limb the two targets are interpolated. A
   leg's fade is blended in world space (Kovar et al. 2002, §4) and its leg solved by IK for it (step 5); an
   arm's fade is the plant boundary's joint displacement, faded (Coleman et al. 2008, §3).
4. **Root.** Where a held leg cannot reach its target within ``reach`` of its length (or of the extension
   the edited pose already has, if larger), the root moves by the smallest displacement that brings every held
   leg of that frame within reach (the nearest point to the origin in the intersection of their reach balls,
   Dykstra's projections), lowered by at most 2.8 % of a leg (~2.5 cm of a 170 cm body), or 5 % (~4.4 cm,
   inside the issue's moderate pelvis bound) where with 2.8 % a foot would stop more than 0.5 % of a leg short
   of its plant, and moved aside by at most 15 % of a leg, then made smooth
   (a max filter and a raised-cosine average, ``blend`` wide). When the root is a static joint below the pelvis
   (Bandai's ``joint_Root`` on the floor) the pelvis moves instead. Legs in the air keep their feet where the
   edit put them.
5. **IK.** Hip and knee are solved analytically: the knee turns about its hinge (the current bend plane,
   signed by the knee's hinge axis measured on the source, so a straight leg bends the way it bends) by the
   exact angle that gives the wanted hip-ankle distance, always on the forward-bent branch (no knee flip,
   never beyond full extension); the hip then aims the leg at the target by the shortest arc (no twist).
   The foot takes the target's world orientation; the joints below it take the source's local rotations; an
   effector with no joint below it (a 19-joint rig's ankle or wrist) keeps the edit's local rotation (its plant
   is a position: held to the source's orientation it turned against the edited shin, and added detail).
   Legs in the air: no foot joint goes below the source's floor (a smooth lift away from the plants; in a fade
   what is still below: the ankle lifted to the floor, a toe below it by turning the foot toe-up about the ankle).
   This holds for every leg of the rig (:func:`rig_legs`), also one with no contact found (a run whose stance
   is shorter than ``detect_contacts``' minimum duration).
6. **Pops.** No corrected joint turns from one frame to the next faster than the source ever turns it plus
   2.5 degrees (or than the edit itself does there, plus 1): where a fade would, its IK displacement is ramped,
   outside the plant (the plants' own frames are kept unless a step inside is too fast by another 2.5 degrees).
   Inside a plant it is met before the IK (:mod:`.plants_rate`): a held knee bends no faster than the source
   turns it plus 1.25 degrees (the leg's reach lowered where the plant asks for more: the root comes down a few
   millimetres),
   and a held toe's heel lift changes by at most 2.5 degrees a frame (lifted a little more, and sooner), so the
   cap need not free a plant's first frames (which let the foot off its plant by 2-6 cm).

Modules: :mod:`.plants_carry` (contacts carried and grouped into plants), :mod:`.plants_hold` (targets, IK on
the plants, fades), :mod:`.plants_air` (the legs between plants, the floor), :mod:`.plants_sample` (sampling
helpers), :mod:`.plants_ik` (the analytic leg IK), :mod:`.plants_root` (reach, plant and root shifts),
:mod:`.plants_pops` (the pop cap), :mod:`.plants_rate` (the turn-rate allowance inside plants), :mod:`.plants_up`
(another up axis); this module: the public functions.

Contacts are ``(joint_name, start_frame, stop_frame)``; up axis +Y (BVH; another up axis, found by
:func:`~stagger_nb.core.body.up_axis`, is turned to +Y and back, :mod:`.plants_up`); lengths in file units, every
tolerance relative to a bone or the body (the layer is invariant to a uniform scale of the clip).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.motion import Motion
from .limbs import Limb, _fk_joints, find_limb
from .plants_carry import (
    _blend_and_share,
    _carried,
    _check_carry_by,
    _parse,
    _plants,
    _timeline,
    carry_clocks,
    carry_contacts,
)
from .plants_hold import _SOURCE_CACHE, _hold, _raised_cosine  # noqa: F401  (_SOURCE_CACHE: tests clear it)
from .plants_ik import _hinge_local  # noqa: F401  (read by tests)
from .plants_root import _MAX_DROP, REACH
from .plants_up import to_y_up, turned, turned_back, turned_source

__all__ = ["Limb", "find_limb", "rig_legs", "PlantsResult", "hold_plants", "keep_contacts", "carry_contacts",
           "apply_contact_constraints", "contact_positions", "contact_errors", "foot_skate", "attenuation_weights"]


_MIN_SWING = 0.1      # seconds: plants of one limb closer than this are held as one
_COVER = 0.1          # seconds: plants also cover the source's own contact frames, less this at each end

@dataclass(frozen=True)
class PlantsResult:
    """Result of :func:`hold_plants`.

    Attributes
    ----------
    motion : Motion
        The edited motion with its plants held.
    notes : tuple of str
        Plain sentences for the user (no legs found, plants out of reach); empty when all went as asked.
    drop : ndarray, shape (F,)
        How far the root was lowered on each frame, file units (>= 0).
    plants : int
        Number of plants held.
    """

    motion: Motion
    notes: tuple = ()
    drop: np.ndarray | None = None
    plants: int = 0


def hold_plants(edited, source: Motion, *, contacts=None, blend: float = 0.15, carry_by: str = "pelvis",
                lower_root: bool | float = True, reach: float = REACH, max_drop: float | None = None,
                source_positions: np.ndarray | None = None) -> PlantsResult:
    """The contact layer (see the module docstring): :func:`keep_contacts` with its notes and root profile.

    Parameters
    ----------
    edited : StaggeredMotion or Motion
        The edited staggered motion, or an evaluated Motion (its contacts keep their frames).
    source : Motion
        The motion the extraction came from.
    contacts : list of (joint_name, start_frame, stop_frame), optional
        The source's contacts, half-open source frames; default ``edited.contacts`` (found at extraction) or
        :func:`~stagger_nb.staggered.detect_contacts` of ``source``.
    blend : float, seconds
        Width of the fade on each side of a plant, and of the root profile's smoothing (>= 0).
    carry_by : {"pelvis", "parent", "joint", "span", "limb"}
        Whose time warp moves each contact (:func:`carry_contacts`); default the pelvis's, the joint the legs
        hang from (:mod:`.plants_carry` says why), the carry :func:`stagger_nb.quality.compare` measures with.
    lower_root : bool or float
        True (default): lower the root as much as the plants need; a number: at most that share of it
        (0 / False: never; the legs then stop at ``reach`` and the feet short of their plants).
    reach : float in (0, 1]
        Share of a leg's length a held leg may use unless the edited pose already uses more (default 0.98).
    source_positions : ndarray, shape (F_source, J, 3), optional
        ``forward_kinematics(source)[0]`` when the caller has it (rows of the limbs' joints are read).
    """
    from .contacts import detect_contacts
    from .evaluation import evaluate
    from .representation import StaggeredMotion
    if not isinstance(source, Motion):
        raise ValueError(f"source must be a Motion, got {type(source).__name__}")
    _check_carry_by(carry_by)
    blend, share = _blend_and_share(blend, lower_root)
    reach = float(reach)
    if not 0.0 < reach <= 1.0:
        raise ValueError(f"reach must be in (0, 1], got {reach!r}")
    timeline = _timeline(edited)
    is_sm = isinstance(edited, StaggeredMotion)
    if edited.skeleton.num_joints != source.num_joints or tuple(edited.skeleton.names) != tuple(source.skeleton.names):
        raise ValueError("edited and source must have the same skeleton")
    if contacts is None:
        contacts = list(edited.contacts) if is_sm and edited.contacts else detect_contacts(source)
    sk = source.skeleton
    parsed = _parse(sk, contacts, source.num_frames)
    motion = evaluate(edited) if is_sm else edited
    if source_positions is not None:
        sp = np.asarray(source_positions)
        if sp.shape != (source.num_frames, source.num_joints, 3):
            raise ValueError(f"source_positions: expected shape ({source.num_frames}, {source.num_joints}, 3) "
                             f"(forward_kinematics(source)[0]), got {sp.shape}")
    floor_legs = rig_legs(sk)
    if not parsed and not floor_legs:
        return PlantsResult(motion)
    limb_of, missing = {}, []
    for j in sorted({j for j, _, _ in parsed}):
        lim = find_limb(sk, j)
        if lim is None:
            missing.append(sk.names[j])
        else:
            limb_of[j] = lim
    notes = []
    if missing:
        notes.append(f"keep_contacts: no leg or arm found above {', '.join(missing)} (a two-bone limb below the "
                     f"root): {'their' if len(missing) > 1 else 'its'} contacts are not held")
    r = to_y_up(source)
    if r is None:
        return _layer(edited, motion, source, parsed, limb_of, timeline, tuple(notes), carry_by, blend, share,
                      _MAX_DROP if max_drop is None else max_drop, reach, floor_legs=floor_legs)
    # not +Y up (a Z-up export): held in a world turned +Y up, then turned back (plants_up)
    motion_y = turned(motion, r)
    res = _layer(edited, motion_y, turned_source(source, r), parsed, limb_of, timeline, tuple(notes), carry_by,
                 blend, share, _MAX_DROP if max_drop is None else max_drop, reach, floor_legs=floor_legs)
    return PlantsResult(turned_back(res.motion, motion_y, motion, r), res.notes, res.drop, res.plants)


def _layer(edited, motion, source, parsed, limb_of, timeline, notes, carry_by, blend, share, max_drop, reach,
           targets=None, shift_plants=True, above_floor=True, cap=True, floor_legs=()) -> PlantsResult:
    """Carry ``parsed`` contacts (those with a limb in ``limb_of``) and hold them (:func:`_hold`); the legs of
    ``floor_legs`` (:func:`rig_legs`) are also kept above the source's floor where no plant holds them."""
    keep = [i for i, c in enumerate(parsed) if c[0] in limb_of]
    carried = _carried(edited, [parsed[i] for i in keep], source.frame_time, carry_by, timeline, index=keep,
                       cover=_COVER) if keep else []
    if not carried and not floor_legs:
        return PlantsResult(motion, tuple(notes))
    # a foot cannot swing between two plants in less than _MIN_SWING: such plants are one
    plants = _plants(carried, limb_of, gap=int(np.ceil(_MIN_SWING / motion.frame_time)))
    limbs = {lim.eff: lim for lim in limb_of.values()}
    for lim in floor_legs:
        limbs.setdefault(lim.eff, lim)
    carried = [c[:7] + (limb_of[c[0]].eff, c[7]) for c in carried]
    # each joint's source time inside its plant: the inverse warp of the clock that carried it
    clock = {j: cs[0] for j, cs in zip(sorted({c[0] for c in carried} | set(limbs)),
                                       carry_clocks(motion.skeleton, sorted({c[0] for c in carried} | set(limbs)),
                                                    carry_by))}
    motion_out, drop, more = _hold(motion, source, limbs, plants, carried, timeline, blend, share, max_drop, reach,
                                   targets, shift_plants, above_floor, cap, clock)
    if motion.staggered is not None:       # held on the timing of the staggered motion it evaluates
        motion_out = motion_out._evaluated_from(motion.staggered)
    return PlantsResult(motion_out, tuple(notes) + tuple(more), drop, len(plants))


def rig_legs(skeleton) -> tuple:
    """The rig's legs (:class:`Limb` with ``leg``), one per foot: the limbs of the joints named like a foot part
    (foot/toe/ankle/heel, :func:`find_limb`); ``()`` on a rig without one. The layer keeps each above the
    source's floor even where no contact was found (a run whose stance is shorter than the contact detector's
    minimum duration: Bandai's 24-frame run cycle), like its legs between plants (Kovar et al. 2002, §4)."""
    from .contacts import _FINGER, _FOOT
    out = {}
    for j, name in enumerate(skeleton.names):
        if _FOOT.search(name) and not _FINGER.search(name):
            lim = find_limb(skeleton, j)
            if lim is not None and lim.leg:
                out.setdefault(lim.eff, lim)
    return tuple(out.values())


def keep_contacts(edited, source: Motion, *, contacts=None, blend: float = 0.15, carry_by: str = "pelvis",
                  lower_root: bool | float = True, reach: float = REACH,
                  source_positions: np.ndarray | None = None) -> Motion:
    """The constraint layer after staggered timing edits: the source's contacts carried through the edit and
    held (:func:`hold_plants`, whose notes this drops); returns the held Motion."""
    return hold_plants(edited, source, contacts=contacts, blend=blend, carry_by=carry_by, lower_root=lower_root,
                       reach=reach, source_positions=source_positions).motion


def apply_contact_constraints(motion: Motion, contacts, reference: Motion | None = None, blend: float = 0.15,
                              mode: str | None = None, *, targets=None, lower_root: bool | float = False,
                              toe_offsets=None, raise_unreachable: bool = False) -> Motion:
    """Hold ``contacts`` of ``motion`` at fixed targets with the contact layer's IK (no timing, no plant
    shift): each contact joint at the ``reference``'s position on the same frame (``mode="track"``, the
    default with a reference) or at its mean over the contact (``"mean"``, the default without: clean-up of
    the motion's own skate), or at ``targets`` (one ``(3,)`` or ``(stop - start, 3)`` per contact). Faded in
    and out over ``blend`` seconds like :func:`keep_contacts`; ``lower_root`` (a share in [0, 1]) lets the
    root come down for a leg that cannot reach. ``toe_offsets`` and ``raise_unreachable`` are accepted for
    compatibility and ignored (the layer keeps the source's heel-toe roll and turns the foot about the toe).
    No pop cap (targets are met exactly; :func:`keep_contacts` caps the pops).
    Contacts on a joint with no two-bone limb are a ValueError."""
    if mode is None:
        mode = "mean" if reference is None else "track"
    if mode not in ("mean", "track"):
        raise ValueError(f"mode must be 'mean' or 'track', got {mode!r}")
    if reference is None or targets is not None:
        reference = motion
    if not isinstance(motion, Motion) or not isinstance(reference, Motion):
        raise ValueError("motion and reference must be Motions")
    if reference.num_frames != motion.num_frames or reference.num_joints != motion.num_joints:
        raise ValueError("reference must have the same number of frames and joints as motion")
    blend, share = _blend_and_share(blend, lower_root)
    sk = motion.skeleton
    parsed = _parse(sk, contacts, motion.num_frames)
    if not parsed:
        return motion
    limb_of = {}
    for j in {j for j, _, _ in parsed}:
        lim = find_limb(sk, j)
        if lim is None:
            raise ValueError(f"contacts: joint {sk.names[j]!r} has no two-bone chain below the root")
        limb_of[j] = lim
    if targets is not None:
        if len(targets) != len(parsed):
            raise ValueError(f"targets: one per contact ({len(parsed)}), got {len(targets)}")
        given = []
        for (_j, a, b), t in zip(parsed, targets):
            t = np.asarray(t, dtype=float)
            if t.shape not in ((3,), (b - a, 3)) or not np.all(np.isfinite(t)):
                raise ValueError(f"targets: each must be 3 finite numbers or ({b - a}, 3), got shape {t.shape}")
            given.append(t)
    elif mode == "mean":
        given = contact_positions(reference, contacts, mode="mean")
    else:
        given = [None] * len(parsed)             # the reference at the same frame: the layer's own target
    return _layer(motion, motion, reference, parsed, limb_of, _timeline(motion), (), "joint", blend, share,
                  _MAX_DROP if share > 0 else 0.0, 1.0, targets=given, shift_plants=False, above_floor=False,
                  cap=False).motion


def contact_positions(reference: Motion, contacts, mode: str = "mean", positions=None) -> list[np.ndarray]:
    """Where each contact should stay: world positions ``(stop - start, 3)`` of the contact joint in
    ``reference``, per frame (``mode="track"``) or its mean over the contact repeated (``"mean"``)."""
    if mode not in ("mean", "track"):
        raise ValueError(f"mode must be 'mean' or 'track', got {mode!r}")
    parsed = _parse(reference.skeleton, contacts, reference.num_frames)
    p = _fk_joints(reference, {j for j, _, _ in parsed})[0] if positions is None else positions
    out = []
    for j, s, e in parsed:
        seg = p[s:e, j]
        out.append(np.broadcast_to(seg.mean(axis=0), seg.shape).copy() if mode == "mean" else seg.copy())
    return out


def contact_errors(motion: Motion, contacts, reference: Motion | None = None, mode: str = "mean") -> np.ndarray:
    """Largest distance ``(N,)`` (file units) of each contact joint from its :func:`contact_positions` target
    (from ``reference``, default ``motion``) over its frames."""
    reference = motion if reference is None else reference
    parsed = _parse(motion.skeleton, contacts, motion.num_frames)
    targets = contact_positions(reference, contacts, mode=mode)
    p = _fk_joints(motion, {j for j, _, _ in parsed})[0]
    return np.array([np.linalg.norm(p[s:e, j] - t, axis=-1).max() for (j, s, e), t in zip(parsed, targets)])


def foot_skate(motion: Motion, contacts, up_axis: int = 1) -> np.ndarray:
    """Horizontal path length ``(N,)`` (file units) of each contact joint over its frames (0: planted)."""
    parsed = _parse(motion.skeleton, contacts, motion.num_frames)
    p = _fk_joints(motion, {j for j, _, _ in parsed})[0]
    horiz = [k for k in range(3) if k != up_axis]
    return np.array([np.linalg.norm(np.diff(p[s:e, j][:, horiz], axis=0), axis=-1).sum() for j, s, e in parsed])


def attenuation_weights(active: np.ndarray, blend_frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smooth window around active frames: ``weight (F,)`` 1 on ``active`` frames, ``(1 + cos(pi d / (n + 1)))
    / 2`` at ``d <= n = blend_frames`` frames from the nearest active frame, 0 beyond (C1, as the layer's
    fades); ``left``, ``right`` ``(F,)``: the nearest active frame at or before / at or after each frame (-1
    where none)."""
    active = np.asarray(active, bool)
    F = active.shape[0]
    idx = np.arange(F)
    left = np.maximum.accumulate(np.where(active, idx, -1))
    right = np.minimum.accumulate(np.where(active, idx, F)[::-1])[::-1]
    right = np.where(right >= F, -1, right)
    wl = np.where(left >= 0, _raised_cosine(idx - left, blend_frames), 0.0)
    wr = np.where(right >= 0, _raised_cosine(right - idx, blend_frames), 0.0)
    weight = np.clip(wl + wr - wl * wr, 0.0, 1.0)
    weight[active] = 1.0
    return weight, left, right


