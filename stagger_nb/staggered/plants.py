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
   the time warp of the joint that holds them (:func:`carry_contacts`); a foot's contacts of one step (heel,
   toe, toes) form one plant.
2. **Where.** The plant tracks the source's own foot: at edited frame ``t`` the foot takes the source's
   position and world orientation at source time ``σ(t)``, a monotone piecewise-linear map through the
   plant's carried contact ends (each contact's first and last edited frame map to its first and last source
   frame), so the source's heel-toe roll is kept and replayed on the edited timing. The whole plant is moved
   horizontally by one constant offset ``d``: the mean of where the edited body puts the foot, moved along
   the hip's travel if that lets the leg reach without lowering the pelvis. The height is the source's.
   With no timing edit ``σ`` is the identity, ``d`` the (zero) mean offset: the motion comes back unchanged.
3. **Blend.** Around each plant a raised-cosine weight (C1, ``blend`` seconds each side) moves the target
   from the edited foot to the plant: the source's approach / take-off through ``σ`` extended with slope 1,
   shifted by the plant's ``d``; between two plants of one limb the two targets are interpolated.
4. **Root.** Where a held leg cannot reach its target within ``reach`` of its length (or of the extension
   the edited pose already has, if larger), the root is lowered by the smallest smooth profile above that
   need (a max filter and a raised-cosine average, ``blend`` wide); legs in the air there keep their feet
   where the edit put them.
5. **IK.** Hip and knee are solved analytically: the knee turns about its hinge (the current bend plane,
   signed by the knee's hinge axis measured on the source, so a straight leg bends the way it bends) by the
   exact angle that gives the wanted hip-ankle distance, always on the forward-bent branch (no knee flip,
   never beyond full extension); the hip then aims the leg at the target by the shortest arc (no twist).
   The foot takes the target's world orientation; the joints below it take the source's local rotations.

Contacts are ``(joint_name, start_frame, stop_frame)``; up axis +Y (BVH); lengths in file units, every
tolerance relative to a bone or the body (the layer is invariant to a uniform scale of the clip).
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import maximum_filter1d

from ..core.kinematics import _fk_component_major
from ..core.motion import Motion
from ..core.rotations import (
    quat_angle,
    quat_between_vectors,
    quat_conj,
    quat_mul,
    quat_rotate,
    quat_to_rotvec,
    rotvec_to_quat,
    slerp,
)
from .contacts import chain_subset
from .limbs import Limb, _fk_joints, find_limb

__all__ = ["Limb", "find_limb", "PlantsResult", "hold_plants", "keep_contacts", "carry_contacts",
           "apply_contact_constraints", "contact_positions", "contact_errors", "foot_skate", "attenuation_weights"]


REACH = 0.98          # share of a leg's length a held leg may use (unless the edited pose already uses more)
_MAX_DROP = 0.028     # the root is lowered by at most this share of a leg (~2.5 cm of a 170 cm body)
# plant shifts tried along the hip's travel, in leg lengths: within a quarter leg of where the edit puts the foot
_SHIFT_STEPS = np.linspace(-0.25, 0.25, 21)
_SEGMENT = np.linspace(0.0, 1.0, 21)     # from where the edit puts the foot to the centre of the hip's path
_ID = np.array([0.0, 0.0, 0.0, 1.0])
_MAX_AIM = np.radians(30.0)     # the most the foot turns about its ankle to put the toe on its own plant
_MAX_PIVOT = np.radians(45.0)   # the most the foot turns about its toe (heel lift) beyond the source's
_MIN_SWING = 0.1      # seconds: plants of one limb closer than this are held as one
_COVER = 0.1          # seconds: plants also cover the source's own contact frames, less this at each end
_SOFT = 0.05         # share of a leg over which a fading target's reach limit is approached smoothly
_FADE_RATE = 90.0     # degrees per second: the most a fade out of (into) a plant turns a joint on top of the edit
_TOL = 1e-6          # lengths below this share of a leg are rounding (no need to lower the root, no shift)


# -- carrying contacts through the timing edit ----------------------------------------------------------

def _timeline(edited):
    """(start time, frame time, frame count) of ``evaluate(edited)`` or of a Motion, and the warp tables."""
    from .representation import StaggeredMotion, default_times
    if isinstance(edited, StaggeredMotion):
        from .timing import _warp_tables
        return float(edited.pose_times[0]), edited.frame_time, default_times(edited).size, _warp_tables(edited)
    if isinstance(edited, Motion):
        return 0.0, edited.frame_time, edited.num_frames, None
    raise ValueError(f"edited must be a StaggeredMotion or a Motion, got {type(edited).__name__}")


def _blend_and_share(blend, lower_root) -> tuple[float, float]:
    """``blend`` (seconds, >= 0) and ``lower_root`` (a bool or a share in [0, 1]) as floats, checked."""
    blend = float(blend)
    if not np.isfinite(blend) or blend < 0:
        raise ValueError(f"blend must be >= 0 seconds, got {blend!r}")
    share = float(lower_root)
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"lower_root must be a bool or a share in [0, 1], got {lower_root!r}")
    return blend, share


def _parse(skeleton, contacts, num_frames: int | None = None) -> list[tuple[int, int, int]]:
    out = []
    for item in contacts:
        try:
            name, a, b = item
            a, b = int(a), int(b)
        except (TypeError, ValueError):
            raise ValueError(f"contacts: each entry must be (joint_name, start_frame, stop_frame), "
                             f"got {item!r}") from None
        if isinstance(name, (int, np.integer)) and not isinstance(name, bool):
            if not 0 <= int(name) < skeleton.num_joints:
                raise ValueError(f"contacts: joint index {name} outside [0, {skeleton.num_joints})")
            j = int(name)
        else:
            try:
                j = skeleton.index(name)
            except KeyError:
                raise ValueError(f"contacts: unknown joint {name!r}") from None
        hi = num_frames if num_frames is not None else b
        if not 0 <= a < b <= hi:
            raise ValueError(f"contacts: frame range [{a}, {b}) of {name!r} is empty or outside [0, {hi})")
        out.append((j, a, b))
    return out


def _carried(edited, parsed, source_frame_time: float, carry_by: str, timeline=None, index=None, cover=None):
    """``[(joint, e0, e1, start, stop, a, b)]``: each contact's first and last source frame ``a``, ``b - 1``
    mapped to edited frames ``e0 <= e1`` (floats) through the warp of the joint that carries it, and the
    edited frames ``[start, stop)`` inside; contacts that keep no frame are left out."""
    from .timing import _warp_column
    t0, ft, F, tables = _timeline(edited) if timeline is None else timeline
    sk = edited.skeleton
    out = []
    for i, (j, a, b) in enumerate(parsed):
        times = np.array([a, b - 1], dtype=float) * source_frame_time
        if tables is not None:
            lim = find_limb(sk, j) if carry_by != "joint" else None
            if carry_by == "limb":
                clocks = [lim.upper if lim is not None else j]
            elif carry_by == "span":
                clocks = [j, lim.mid if lim is not None else j]
            else:
                clocks = [j]
            w = np.array([_warp_column(*tables, c, times) for c in clocks])
            times = np.array([w[:, 0].min(), w[:, 1].max()])
        e0, e1 = (times - t0) / ft
        start = max(int(np.ceil(e0 - 1e-6)), 0)
        stop = min(int(np.floor(e1 + 1e-6)) + 1, F)
        if cover is not None and tables is not None:
            # also the source's own frames less ``cover`` s at each end, where they are near (the edit moved the
            # contact by less than 2 ``cover``): a foot lands no more than that before its own timing says
            c0 = (a * source_frame_time + cover - t0) / ft
            c1 = ((b - 1) * source_frame_time - cover - t0) / ft
            near = 2 * cover / ft
            if c1 >= c0 and 0 < start - c0 <= near:
                start = max(int(np.ceil(c0 - 1e-6)), 0)
            if c1 >= c0 and 0 < c1 - (stop - 1) <= near:
                stop = min(int(np.floor(c1 + 1e-6)) + 1, F)
        if stop > start:
            out.append((j, float(e0), float(e1), start, stop, a, b, i if index is None else index[i]))
    return out


def carry_contacts(edited, contacts, source_frame_time: float, *,
                   carry_by: str = "joint") -> list[tuple[str, int, int]]:
    """Contacts of the source moved in time with the timing edit: ``(joint_name, start, stop)`` half-open
    frames of ``evaluate(edited)``.

    A contact's first and last source frames (times ``frame * source_frame_time``) are mapped through the
    time warp (:func:`~stagger_nb.staggered.editing.warp_times`) of the joint that carries it:
    ``carry_by="joint"`` (default) the contact joint's own, ``"limb"`` its limb's upper joint's (hip /
    shoulder), ``"span"`` from the earlier to the later of the contact joint's and its limb's middle joint's
    (knee / elbow). A Motion (no timing edit) keeps the frames. Contacts that keep no frame are dropped."""
    if carry_by not in ("joint", "limb", "span"):
        raise ValueError(f"carry_by must be 'joint', 'limb' or 'span', got {carry_by!r}")
    ft_s = float(source_frame_time)
    if not np.isfinite(ft_s) or ft_s <= 0:
        raise ValueError(f"source_frame_time must be > 0 seconds, got {source_frame_time!r}")
    timeline = _timeline(edited)
    sk = edited.skeleton
    return [(sk.names[c[0]], c[3], c[4]) for c in _carried(edited, _parse(sk, contacts), ft_s, carry_by, timeline)]


# -- plants -----------------------------------------------------------------------------------------------

def _plants(carried, limb_of, gap: int = 0) -> list[dict]:
    """The carried contacts grouped into plants: one limb's contacts whose edited frames overlap or touch, or
    whose source frames overlap (a foot's heel and toe contacts of one step), or less than ``gap`` frames apart.
    Each plant: ``eff`` (its limb's
    effector), edited frames ``[start, stop)`` and source frames ``[s_lo, s_hi]`` (first and last held)."""
    by: dict[int, list] = {}
    for c in carried:
        by.setdefault(limb_of[c[0]].eff, []).append(c)
    plants = []
    for eff, items in by.items():
        items.sort(key=lambda c: (c[3], c[5]))
        groups: list[list] = []
        for c in items:
            g = groups[-1] if groups else None
            if g is not None and (c[3] <= max(x[4] for x in g) + gap or c[5] < max(x[6] for x in g)):
                g.append(c)
            else:
                groups.append([c])
        plants += [dict(eff=eff, start=min(x[3] for x in g), stop=max(x[4] for x in g),
                        s_lo=float(min(x[5] for x in g)), s_hi=float(max(x[6] for x in g) - 1)) for g in groups]
    return plants


# -- forward kinematics on chains --------------------------------------------------------------------------

def _sample(arr: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``arr (F, ...)`` positions at fractional frames ``f (n,)`` (linear; clamped to the clip)."""
    f = np.clip(f, 0, arr.shape[0] - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, arr.shape[0] - 1)
    w = (f - i0).reshape((-1,) + (1,) * (arr.ndim - 1))
    return arr[i0] * (1 - w) + arr[i1] * w


def _sample_quats(arr: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``arr (F, ..., 4)`` unit quaternions at fractional frames ``f (n,)`` (slerp; clamped)."""
    f = np.clip(f, 0, arr.shape[0] - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, arr.shape[0] - 1)
    w = (f - i0).reshape((-1,) + (1,) * (arr.ndim - 2))
    return slerp(arr[i0], arr[i1], np.broadcast_to(w, arr[i0].shape[:-1]))


def _raised_cosine(d: np.ndarray, n: int) -> np.ndarray:
    """C1 fade ``(1 + cos(pi d / (n + 1))) / 2`` for ``0 <= d <= n`` frames, 0 beyond."""
    d = np.asarray(d, dtype=float)
    return np.where((d >= 0) & (d <= n), 0.5 * (1.0 + np.cos(np.pi * np.minimum(d, n + 1) / (n + 1))), 0.0)


def _envelope(need: np.ndarray, n: int) -> np.ndarray:
    """Smallest-ish smooth profile ``>= need (F,)``: a max filter ``2n + 1`` frames wide, then a normalised
    raised-cosine average of the same width (an average of values >= need[x] stays >= need[x])."""
    if not np.any(need > 0):
        return np.zeros_like(need)
    w = max(int(n), 1)
    peak = maximum_filter1d(np.maximum(need, 0.0), 2 * w + 1, mode="nearest")
    kernel = 0.5 * (1.0 + np.cos(np.pi * np.arange(-w, w + 1) / (w + 1)))
    kernel /= kernel.sum()
    return np.convolve(np.pad(peak, w, mode="edge"), kernel, mode="valid")


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _vertical_need(hip: np.ndarray, target: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """How far ``(n,)`` the hip ``(n, 3)`` must come down (file units; <= 0: no need) for ``target (n, 3)``
    to lie within ``reach (n,)`` of it; a target horizontally beyond reach gets the drop to its height plus
    the horizontal excess (a penalty that keeps growing)."""
    dx = hip[:, 0] - target[:, 0]
    dz = hip[:, 2] - target[:, 2]
    h2 = dx * dx + dz * dz
    dy = hip[:, 1] - target[:, 1]
    room = reach * reach - h2
    return np.where(room >= 0, dy - np.sqrt(np.maximum(room, 0.0)), dy + np.sqrt(h2) - reach)


def _choose_shifts(hip, base, reach, pid, d0, lengths) -> np.ndarray:
    """One horizontal shift ``(P, 3)`` per plant, for held targets ``base + shift`` (samples ``(n, 3)``
    sorted by plant ``pid (n,)``) that the hip ``hip (n, 3)`` reaches within ``reach (n,)``.

    Candidates: the segment from ``d0`` (where the edit puts the foot, on average) to the shift that centres
    the hip's path over the plant (the middle of its horizontal extent), then around that centre along the
    hip's travel (within a quarter leg, ``lengths (P,)``). The first that needs no lowering, in that order
    (the nearest to ``d0``), else the one needing the least."""
    out = np.array(d0, dtype=float)
    out[:, 1] = 0.0
    if not pid.size:
        return out
    ids, starts = np.unique(pid, return_index=True)
    ends = np.r_[starts[1:], pid.size] - 1
    rel = (hip - base)[:, [0, 2]]                                                   # (n, 2)
    lo, hi = np.minimum.reduceat(rel, starts, axis=0), np.maximum.reduceat(rel, starts, axis=0)
    centre = 0.5 * (lo + hi)                                                        # (p, 2)
    u = rel[ends] - rel[starts]
    un = np.hypot(u[:, 0], u[:, 1])
    u = np.where((un > 1e-9 * lengths[ids])[:, None], u / np.maximum(un, 1e-300)[:, None], 0.0)
    d = out[ids][:, [0, 2]]
    cand = np.concatenate([d[None] + _SEGMENT[:, None, None] * (centre - d)[None],
                           centre[None] + (_SHIFT_STEPS[:, None] * lengths[ids])[:, :, None] * u[None]])   # (C, p, 2)
    of = np.searchsorted(ids, pid)
    diff = rel[None] - cand[:, of]                                                  # (C, n, 2)
    h2 = np.einsum("cnk,cnk->cn", diff, diff)
    room = reach * reach - h2
    dy = (hip - base)[:, 1]
    need = np.where(room >= 0, dy - np.sqrt(np.maximum(room, 0.0)), dy + np.sqrt(h2) - reach)
    worst = np.maximum.reduceat(need, starts, axis=1)                               # (C, p)
    ok = worst <= _TOL * lengths[ids]                                               # rounding is no need
    k = np.where(ok.any(axis=0), np.argmax(ok, axis=0), np.argmin(worst, axis=0))
    best = cand[k, np.arange(ids.size)]
    out[ids, 0], out[ids, 2] = best[:, 0], best[:, 1]
    return out


# -- IK ----------------------------------------------------------------------------------------------------

def _leg_ik(a, b, c, t, hinge, d_max, soft=None):
    """Analytic two-bone IK, vectorised over rows.

    The middle joint turns about its hinge axis ``hinge`` (world, unit; the knee's bend axis measured on the
    source, so the knee bends the way it bends and never flips sideways or backwards) by the exact angle that
    puts the effector at the wanted distance from the upper joint; the upper joint then aims the limb at the
    target by the shortest arc (no twist). Of the two angles that give the distance, the forward-bent one,
    except where the current pose is bent backwards about the hinge and the target asks for no more bend
    than it has (then the one nearer the current pose: an unedited pose is left as it is).

    Parameters
    ----------
    a, b, c, t : ndarray, shape (n, 3)
        Upper joint, middle joint, effector, target (world).
    hinge : ndarray, shape (n, 3)
        The middle joint's hinge axis (world, unit), oriented so a positive turn bends the limb.
    d_max : ndarray, shape (n,)
        Largest upper-effector distance allowed (below the two bones' length).
    soft : ndarray, shape (n,), optional
        Where given (> 0), distances beyond ``d_max - soft`` approach ``d_max`` exponentially (a C1 soft limit,
        used while fading in and out of a plant so a far target straightens the leg gradually).

    Returns
    -------
    r_up, r_mid : ndarray, shape (n, 4)
        World rotations to pre-multiply: the upper joint's world rotation by ``r_up``, the middle joint's by
        ``r_up * r_mid`` (``r_mid`` about the middle joint, ``r_up`` about the upper joint).
    """
    x, y = b - a, c - b
    lx, ly = np.linalg.norm(x, axis=-1), np.linalg.norm(y, axis=-1)
    k = _unit(hinge)
    d = np.linalg.norm(t - a, axis=-1)
    if soft is not None:      # soft reach: C1 approach of d_max over the last ``soft`` of it (no knee snap)
        knee = d_max - soft
        over = (soft > 0) & (d > knee)
        d = np.where(over, knee + soft * -np.expm1(-(d - knee) / np.where(soft > 0, soft, 1.0)), d)
    d = np.clip(d, np.abs(lx - ly) * (1 + 1e-9) + 1e-12, d_max)
    # rotating y about k by theta: x . R y = A + B cos(theta) + C sin(theta)
    ypar = np.einsum("ni,ni->n", y, k)[:, None] * k
    yperp = y - ypar
    A = np.einsum("ni,ni->n", x, ypar)
    B = np.einsum("ni,ni->n", x, yperp)
    C = np.einsum("ni,ni->n", x, np.cross(k, yperp))
    D = 0.5 * (d * d - lx * lx - ly * ly)
    rho = np.hypot(B, C)
    phi = np.arctan2(C, B)                     # the straightest the hinge allows; < 0 for a forward bend
    delta = np.arccos(np.clip((D - A) / np.maximum(rho, 1e-300), -1.0, 1.0))
    back = (phi > 0) & (delta <= phi + 1e-6)   # bent backwards now, and asked for no more bend than that
    theta = np.where(back, phi - delta, phi + delta)
    theta = np.arctan2(np.sin(theta), np.cos(theta))
    r_mid = rotvec_to_quat(k * theta[:, None])
    c1 = b + quat_rotate(r_mid, y)
    r_up = quat_between_vectors(c1 - a, t - a)
    return r_up, r_mid


def _capped(q: np.ndarray, limit: float) -> np.ndarray:
    """Rotations ``q (n, 4)`` with their angle cut to ``limit`` radians (the axis kept)."""
    v = quat_to_rotvec(q)
    a = np.linalg.norm(v, axis=-1, keepdims=True)
    return rotvec_to_quat(v * np.minimum(1.0, limit / np.maximum(a, 1e-300)))


def _pivot(off: np.ndarray, to_hip: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Toe -> ankle vectors ``off (n, 3)`` turned (length kept) towards ``to_hip (n, 3)`` (toe -> hip) by the
    least angle that brings the ankle within ``reach (n,)`` of the hip (fully towards it if even that is not
    enough); rows already in reach are returned as they are."""
    f = np.linalg.norm(off, axis=-1)
    D = np.linalg.norm(to_hip, axis=-1)
    u = to_hip / np.maximum(D, 1e-300)[:, None]
    cos0 = np.einsum("ni,ni->n", off, u) / np.maximum(f, 1e-300)
    need = np.clip((D * D + f * f - reach * reach) / np.maximum(2.0 * D * f, 1e-300), -1.0, 1.0)
    turn = cos0 < need
    if not turn.any():
        return off
    w = off - (cos0 * f)[:, None] * u
    w = _unit(w)
    sin = np.sqrt(1.0 - need * need)
    return np.where(turn[:, None], f[:, None] * (need[:, None] * u + sin[:, None] * w), off)


def _hinge_local(src_pos, src_wq, limb: Limb) -> np.ndarray:
    """The middle joint's hinge axis in the upper joint's frame ``(3,)``, measured on the source: the mean
    bend-plane normal (``(b - a) x (c - b)``, weighted by the bend) over the clip; where the source never
    bends the limb, an axis normal to the upper bone."""
    a, b, c = src_pos[:, limb.upper], src_pos[:, limb.mid], src_pos[:, limb.eff]
    n = np.cross(b - a, c - b)
    local = quat_rotate(quat_conj(src_wq[:, limb.upper]), n).sum(axis=0)
    size = np.linalg.norm(local)
    bone = quat_rotate(quat_conj(src_wq[0, limb.upper]), b[0] - a[0])
    scale = float(np.linalg.norm(b - a, axis=-1).mean() * np.linalg.norm(c - b, axis=-1).mean())
    if size > 1e-3 * scale * max(len(a), 1):
        return local / size
    other = np.array([1.0, 0.0, 0.0]) if abs(_unit(bone)[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    return _unit(np.cross(bone, other))


# -- the layer ---------------------------------------------------------------------------------------------

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


def hold_plants(edited, source: Motion, *, contacts=None, blend: float = 0.15, carry_by: str = "joint",
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
    carry_by : {"joint", "span", "limb"}
        Whose time warp moves each contact (:func:`carry_contacts`); default the contact joint's own.
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
    if carry_by not in ("joint", "limb", "span"):
        raise ValueError(f"carry_by must be 'joint', 'limb' or 'span', got {carry_by!r}")
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
    if not parsed:
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
    return _layer(edited, motion, source, parsed, limb_of, timeline, tuple(notes), carry_by, blend, share,
                  _MAX_DROP if max_drop is None else max_drop, reach)


def _layer(edited, motion, source, parsed, limb_of, timeline, notes, carry_by, blend, share, max_drop, reach,
           targets=None, shift_plants=True, above_floor=True) -> PlantsResult:
    """Carry ``parsed`` contacts (those with a limb in ``limb_of``) and hold them (:func:`_hold`)."""
    keep = [i for i, c in enumerate(parsed) if c[0] in limb_of]
    carried = _carried(edited, [parsed[i] for i in keep], source.frame_time, carry_by, timeline, index=keep,
                       cover=_COVER)
    if not carried:
        return PlantsResult(motion, tuple(notes))
    # a foot cannot swing between two plants in less than _MIN_SWING: such plants are one
    plants = _plants(carried, limb_of, gap=int(np.ceil(_MIN_SWING / motion.frame_time)))
    limbs = {lim.eff: lim for lim in limb_of.values()}
    carried = [c[:7] + (limb_of[c[0]].eff, c[7]) for c in carried]
    motion_out, drop, more = _hold(motion, source, limbs, plants, carried, timeline, blend, share, max_drop, reach,
                                   targets, shift_plants, above_floor)
    return PlantsResult(motion_out, tuple(notes) + tuple(more), drop, len(plants))


def _hold(motion: Motion, source: Motion, limbs: dict, plants: list, carried: list, timeline, blend: float,
          share: float, max_drop: float, reach: float, targets=None, shift_plants: bool = True,
          above_floor: bool = True):
    """The layer on the evaluated ``motion``: ``(held motion, root drop (F,), notes)``."""
    sk = motion.skeleton
    F = motion.num_frames
    ft, ft_s = motion.frame_time, source.frame_time
    t0, tables = timeline[0], timeline[3]
    nb = int(round(blend / ft))
    nc = max(1, nb)                                         # fade of one contact's correction inside a plant
    legs = [lim for lim in limbs.values() if lim.leg]
    joints = set()
    for lim in limbs.values():
        joints |= {lim.upper, lim.mid, lim.eff, int(sk.parents[lim.mid]), int(sk.parents[lim.eff])}
    pos, wq = _fk_joints(motion, joints)
    spos, swq, src_share, hinges, floor = _source_tables(source, limbs)
    slq = source.local_quats
    length = {e: _length(pos, lim) for e, lim in limbs.items()}              # (F,) per limb
    # -- each plant's frames: the source time sigma (the effector's own inverse warp, kept inside the plant's
    # source frames) and the source foot there --------------------------------------------------------------
    P = len(plants)
    sizes = np.array([p["stop"] - p["start"] for p in plants])
    in_fr = np.concatenate([np.arange(p["start"], p["stop"]) for p in plants])
    in_pid = np.repeat(np.arange(P), sizes)
    effs = np.array([p["eff"] for p in plants])
    e_of, u_of = effs[in_pid], np.array([limbs[e].upper for e in effs])[in_pid]
    in_sig = np.empty(in_fr.size)
    for e in limbs:
        sel = e_of == e
        in_sig[sel] = _source_frames(tables, t0, ft, ft_s, e, in_fr[sel])
    s_lo, s_hi = np.array([p["s_lo"] for p in plants]), np.array([p["s_hi"] for p in plants])
    in_sig = np.clip(in_sig, s_lo[in_pid], s_hi[in_pid])
    base = _sample_rows(spos, in_sig, e_of)                                  # (n, 3) source foot at sigma
    hip, cur = pos[in_fr, u_of], pos[in_fr, e_of]
    L_in = np.concatenate([length[p["eff"]][p["start"]:p["stop"]] for p in plants])
    s_in = np.empty(in_fr.size)
    for e in limbs:
        sel = e_of == e
        s_in[sel] = _sample(src_share[e], in_sig[sel])
    R_in = _reach(reach, L_in, np.linalg.norm(cur - hip, axis=-1), s_in)
    d0 = np.zeros((P, 3))
    np.add.at(d0, in_pid, cur - base)
    d0 /= sizes[:, None]
    lengths = np.array([float(np.median(length[e])) for e in effs])
    shift = _choose_shifts(hip, base, R_in, in_pid, d0, lengths) if shift_plants else np.zeros((P, 3))
    contacts_of: dict[int, list] = {}
    for c in carried:
        contacts_of.setdefault(c[7], []).append(c)
    rows = []
    need = np.zeros(F)
    f_all = np.arange(F)
    for eff, lim in limbs.items():
        sel = np.flatnonzero(e_of == eff)
        if not sel.size:
            continue
        fr, sig, pid = in_fr[sel], in_sig[sel], in_pid[sel]
        d = shift[pid]
        # the plant's own frames: the source foot at sigma, shifted, each contact joint then put where the
        # source has it at that joint's own time (w_j^-1), faded (C1) over nc frames inside the plant
        p_ref = _sample(spos[:, eff], sig) + d
        q_ref = _sample_quats(swq[:, eff], sig)
        n = fr.size
        da, wa = np.zeros((n, 3)), np.zeros(n)
        dt_sum, pt_sum, wt_sum, wt = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.zeros(n)
        lo = np.array([plants[i]["start"] for i in pid])
        hi = np.array([plants[i]["stop"] for i in pid])
        at_sig = {}
        for j, _e0, _e1, A, B, a, b, _, ci in contacts_of.get(eff, ()):
            kA, kB = np.searchsorted(fr, [A, B])
            if kB <= kA:
                continue
            own = fr[kA:kB]
            if j not in at_sig:
                at_sig[j] = _sample(spos[:, j], sig)
            if targets is not None and targets[ci] is not None:     # given: where the joint must be
                delta = np.broadcast_to(targets[ci], (B - A, 3)) - at_sig[j][kA:kB] - d[kA:kB]
            else:
                ts = np.clip(_source_frames(tables, t0, ft, ft_s, j, own), a, b - 1)
                delta = _sample(spos[:, j], ts) - at_sig[j][kA:kB]
            k0, k1 = np.searchsorted(fr, [A - nc, B + nc])
            seg = np.arange(k0, k1)
            seg = seg[(lo[seg] <= A) & (hi[seg] >= B)]         # this contact's plant only
            f_seg = fr[seg]
            dist = np.where(f_seg < A, A - f_seg, np.where(f_seg >= B, f_seg - (B - 1), 0))
            om = _raised_cosine(dist, nc)
            dseg = delta[np.clip(np.searchsorted(own, f_seg), 0, own.size - 1)]
            if j == eff:
                take = om > wa[seg]
                wa[seg] = np.where(take, om, wa[seg])
                da[seg] = np.where(take[:, None], dseg, da[seg])
            else:
                dt_sum[seg] += om[:, None] * dseg
                pt_sum[seg] += om[:, None] * (at_sig[j][seg] + d[seg])
                wt_sum[seg] += om
                wt[seg] = np.maximum(wt[seg], om)
        has_t = wt_sum > 0
        dt = np.where(has_t[:, None], dt_sum / np.where(has_t, wt_sum, 1.0)[:, None], 0.0)
        pt = np.where(has_t[:, None], pt_sum / np.where(has_t, wt_sum, 1.0)[:, None], p_ref)
        ankle = p_ref + wa[:, None] * da + ((1 - wa) * wt)[:, None] * dt
        both = (wa * wt) > 0
        if both.any():
            # heel and toe held at once, each at its own joint's time: the toe aimed at its plant by turning
            # the foot about the ankle, and what the rigid foot's length cannot fit shared by the two
            toe_t = pt[both] + dt[both]
            v = toe_t - ankle[both]
            foot = np.linalg.norm(pt[both] - p_ref[both], axis=-1)
            gap = (np.linalg.norm(v, axis=-1) - foot) * 0.5 * (wa * wt)[both]
            ankle[both] += gap[:, None] * _unit(v)
            turn = _capped(quat_between_vectors(pt[both] - p_ref[both], toe_t - ankle[both]), _MAX_AIM)
            q_ref[both] = quat_mul(slerp(np.broadcast_to(_ID, turn.shape), turn, (wa * wt)[both]), q_ref[both])
        e_cur = pos[fr, eff]
        h = pos[fr, lim.upper]
        R = _reach(reach, length[eff][fr], np.linalg.norm(e_cur - h, axis=-1), _sample(src_share[eff], sig))
        toe_only = (wt * (1 - wa)) > 0
        if toe_only.any():
            # only the toe held (heel-off): where the leg cannot reach the ankle, the foot turns further about
            # the toe towards the hip (the heel lifts more), by the least angle that brings the ankle in reach
            k = np.flatnonzero(toe_only)
            toe_t = pt[k] + dt[k]
            off = ankle[k] - toe_t
            turn = _capped(quat_between_vectors(off, _pivot(off, h[k] - toe_t, R[k])), _MAX_PIVOT)
            turn = slerp(np.broadcast_to(_ID, turn.shape), turn, (wt * (1 - wa))[k])
            ankle[k] = toe_t + quat_rotate(turn, off)
            q_ref[k] = quat_mul(turn, q_ref[k])
        np.maximum.at(need, fr, _vertical_need(h, ankle, R) - _TOL * length[eff][fr])
        foot_q = [_sample_quats(slq[:, k], sig) for k in lim.foot]
        rows.append(dict(lim=lim, fr=fr, g=ankle, R=R, q=q_ref, foot=foot_q, sig=sig))
    notes = []
    drop = np.zeros(F)
    if share > 0 and max_drop > 0 and np.any(need > 0):
        cap = max_drop * float(min(lengths))
        drop = _envelope(np.minimum(need, cap), nb) * share
        short = int(np.sum(need > drop + 1e-3 * float(min(lengths))))
        if short:
            notes.append(f"keep_contacts: on {short} frame{'s' if short > 1 else ''} a held leg cannot reach its "
                         f"plant with the pelvis at most {100 * max_drop * share:.1f} % of a leg lower: the foot "
                         f"stops short of the plant there")
    rp = motion.root_positions
    lowered = pos
    if np.any(drop > 0):
        rp = np.array(rp)
        rp[:, 1] -= drop
        lowered = pos.copy()
        lowered[..., 1] -= drop[:, None]
    lq = motion.local_quats
    out = np.array(lq)
    # the plants' own frames: exact IK
    for r in rows:
        lim, fr = r["lim"], r["fr"]
        a_new, m_new, e_new = _solve(sk, lim, fr, lowered, wq, lq, r["g"], r["q"], r["R"], hinges[lim.eff])
        out[fr, lim.upper], out[fr, lim.mid], out[fr, lim.eff] = a_new, m_new, e_new
        for k, fq in zip(lim.foot, r["foot"]):
            out[fr, k] = fq
    # around them: the boundary solution's displacement (each joint's rotation against the edit's), faded
    # out with a C1 raised cosine (Coleman et al. §3) over a window long enough that the fade turns no joint
    # faster than _FADE_RATE on top of the edit; between two plants the two displacements are interpolated
    fade_w = {}
    for r in rows:
        lim, fr = r["lim"], r["fr"]
        inside = np.zeros(F, bool)
        inside[fr] = True
        starts = np.flatnonzero(inside & ~np.r_[False, inside[:-1]])
        ends = np.flatnonzero(inside & ~np.r_[inside[1:], False])
        bnd = np.r_[starts, ends]
        ch = np.array([lim.upper, lim.mid, lim.eff] + list(lim.foot))
        disp = quat_mul(quat_conj(lq[bnd][:, ch]), out[bnd][:, ch])                    # (boundaries, C, 4)
        # ... and its rate there (per frame, towards the outside: from the plant's second frame to its first,
        # from its second-last to its last), carried on, damped, so the fade starts with the plant's slope (C1)
        inner = np.r_[np.minimum(starts + 1, F - 1), np.maximum(ends - 1, 0)]
        inner = np.where(inside[inner], inner, bnd)
        rate = quat_to_rotvec(quat_mul(quat_conj(quat_mul(quat_conj(lq[inner][:, ch]), out[inner][:, ch])), disp))
        size = quat_angle(disp)                                                         # (boundaries, C) radians
        angle = size.max(axis=1)
        width = np.clip(np.ceil(angle * np.pi / (2 * np.radians(_FADE_RATE) * ft)) - 1, nb, 4 * nb).astype(np.int64)
        w_start, w_end = width[:starts.size], width[starts.size:]
        li = np.searchsorted(ends, f_all, side="right") - 1
        ri = np.searchsorted(starts, f_all, side="right")
        li_, ri_ = np.maximum(li, 0), np.minimum(ri, starts.size - 1)
        has_l, has_r = (li >= 0) & ~inside, (ri < starts.size) & ~inside
        dl = np.where(has_l, f_all - ends[li_], 0)
        dr = np.where(has_r, starts[ri_] - f_all, 0)
        wl = np.where(has_l, _raised_cosine(dl, w_end[li_]), 0.0)
        wr = np.where(has_r, _raised_cosine(dr, w_start[ri_]), 0.0)
        win = np.flatnonzero((wl > 0) | (wr > 0))
        if not win.size:
            continue
        wl_, wr_ = wl[win], wr[win]
        # the right plant's share: its weight over its distance against the left's (1 next to the right plant,
        # 0 next to the left one, and continuous where either fade begins)
        ql, qr = wl_ / np.maximum(dl[win], 1), wr_ / np.maximum(dr[win], 1)
        al = qr / (ql + qr)
        w = wl_ + wr_ - wl_ * wr_
        kl, kr = starts.size + li_[win], ri_[win]
        fade_w[lim.eff] = (win, w)
        tau_l = np.maximum(w_end[li_[win]], 1) / 3.0
        tau_r = np.maximum(w_start[ri_[win]], 1) / 3.0
        s_l = (tau_l * -np.expm1(-dl[win] / tau_l))[:, None]          # ~ frames out, levelling off
        s_r = (tau_r * -np.expm1(-dr[win] / tau_r))[:, None]
        # the carried-on rate turns the displacement by at most its own size, and never past 0.9 pi (a turn
        # beyond half a revolution would flip to the other way round)
        size = np.minimum(size, np.maximum(0.9 * np.pi - size, 0.0))
        r_l, r_r = rate[kl], rate[kr]                                                   # (n, C, 3)
        r_l = r_l * np.minimum(1.0, size[kl] / np.maximum(np.linalg.norm(r_l, axis=-1) * tau_l[:, None],
                                                          1e-300))[..., None]
        r_r = r_r * np.minimum(1.0, size[kr] / np.maximum(np.linalg.norm(r_r, axis=-1) * tau_r[:, None],
                                                          1e-300))[..., None]
        d_l = quat_mul(disp[kl], rotvec_to_quat(r_l * s_l[..., None]))
        d_r = quat_mul(disp[kr], rotvec_to_quat(r_r * s_r[..., None]))
        shape = d_l.shape[:-1]
        dd = slerp(d_l, d_r, np.broadcast_to(al[:, None], shape))
        dd = slerp(np.broadcast_to(_ID, dd.shape), dd, np.broadcast_to(w[:, None], shape))
        out[win[:, None], ch[None, :]] = quat_mul(lq[win][:, ch], dd)
        _no_hyperextension(sk, motion, lim, win, out, lq, pos, wq, hinges[lim.eff])
    # legs in the air: where the root is lowered they keep their feet where the edit (in a fade: the faded pose
    # on the lowered root, plus the part of the drop the fade has let go of) puts them; and no foot joint goes
    # below the source's floor (the lowest any source joint goes), lifted by a smooth profile, let go of
    # towards the plants (whose own frames sit on the ground)
    if legs:
        held = {r["lim"].eff: r["fr"] for r in rows}
        leg_joints = {x for lim in legs for x in (lim.upper, lim.mid, lim.eff, int(sk.parents[lim.mid]),
                                                   int(sk.parents[lim.eff])) + lim.foot}
        p_u, w_u = _fk_joints(motion, leg_joints, local_quats=out)       # the root not lowered
        for lim in legs:
            free = np.ones(F, bool)
            if lim.eff in held:
                free[held[lim.eff]] = False
            wf = np.zeros(F)
            if lim.eff in fade_w:
                wf[fade_w[lim.eff][0]] = fade_w[lim.eff][1]
            down = wf * drop                                  # how far the foot goes down with the root
            low = np.min(p_u[:, [lim.eff] + list(lim.foot), 1], axis=1) - down
            deficit = np.where(free, np.maximum(floor - low, 0.0), 0.0)
            lift = np.zeros(F)
            if above_floor and np.any(deficit > _TOL * float(np.median(length[lim.eff]))):
                lift = _envelope(deficit, nb) * (1.0 - wf)
                lift[~free] = 0.0
            tiny = _TOL * length[lim.eff]                    # (F,): below this, neither moves the foot
            fr = np.flatnonzero(free & ((drop > tiny) | (lift > tiny)))
            if not fr.size:
                continue
            p3 = p_u[fr][:, [lim.upper, lim.mid, lim.eff]]
            p3[..., 1] -= drop[fr, None]
            tgt = p_u[fr, lim.eff].copy()
            tgt[:, 1] += lift[fr] - down[fr]
            a_new, m_new, e_new = _solve_rows(sk, lim, fr, p3, w_u, out, tgt, w_u[fr, lim.eff],
                                              length[lim.eff][fr] * (1 - 1e-9), hinges[lim.eff])
            out[fr, lim.upper], out[fr, lim.mid], out[fr, lim.eff] = a_new, m_new, e_new
    return Motion._trusted(sk, motion.frame_time, rp, out, motion.local_translations), drop, notes


def _solve(sk, lim: Limb, fr, pos, wq, lq, target, q_target, reach, hinge_local, soft=None):
    """New local rotations ``(upper, mid, eff)`` on frames ``fr`` putting the effector at ``target (n, 3)``
    with world rotation ``q_target (n, 4)`` (positions ``pos`` already lowered with the root)."""
    p3 = pos[fr][:, [lim.upper, lim.mid, lim.eff]]
    return _solve_rows(sk, lim, fr, p3, wq, lq, target, q_target, reach, hinge_local, soft)


def _solve_rows(sk, lim: Limb, fr, p3, wq, lq, target, q_target, reach, hinge_local, soft=None):
    """:func:`_solve` from the chain's positions ``p3 (n, 3, 3)`` (upper, mid, eff) and the world rotations
    ``wq (F, J, 4)`` / local rotations ``lq (F, J, 4)`` of the pose being changed."""
    pm, pe = int(sk.parents[lim.mid]), int(sk.parents[lim.eff])
    upw = wq[fr, lim.upper]
    hinge = quat_rotate(upw, hinge_local)
    r_up, r_mid = _leg_ik(p3[:, 0], p3[:, 1], p3[:, 2], target, hinge, reach, soft)
    a_new = quat_mul(lq[fr, lim.upper], quat_mul(quat_conj(upw), quat_mul(r_up, upw)))
    m_new = quat_mul(quat_conj(wq[fr, pm]), quat_mul(r_mid, wq[fr, lim.mid]))
    e_new = quat_mul(quat_conj(quat_mul(quat_mul(r_up, r_mid), wq[fr, pe])), q_target)
    return a_new, m_new, e_new


def _no_hyperextension(sk, motion: Motion, lim: Limb, fr, out, lq, pos, wq, hinge_local) -> None:
    """Where a fade has bent the middle joint backwards about its hinge beyond what the edit itself does
    (its displacement composed with the edit's own straightening), turn it back to that (in place on
    ``out (F, J, 4)``, frames ``fr``; ``pos`` / ``wq``: the edit's world positions and rotations)."""
    pm = int(sk.parents[lim.mid])

    def flex(p, w, rows):
        x = p[rows, lim.mid] - p[rows, lim.upper]
        y = p[rows, lim.eff] - p[rows, lim.mid]
        k = quat_rotate(w[rows, lim.upper], hinge_local)
        return np.arctan2(np.einsum("ni,ni->n", np.cross(x, y), k), np.einsum("ni,ni->n", x, y)), k

    # only where the edit's own bend is smaller than the fade's turn of the knee can the sum bend backwards
    f_e, _ = flex(pos, wq, fr)
    turned = quat_angle(lq[fr, lim.mid], out[fr, lim.mid]) + quat_angle(lq[fr, lim.upper], out[fr, lim.upper])
    maybe = f_e < turned + 1e-6
    if not maybe.any():
        return
    fr, f_e = fr[maybe], f_e[maybe]
    p_o, w_o = _fk_rows(motion, {lim.upper, lim.mid, lim.eff, pm}, fr, out)
    f_o, k = flex(p_o, w_o, slice(None))
    excess = np.minimum(f_e, 0.0) - f_o                  # > 0: more backwards than the edit
    bad = excess > 1e-9
    if not bad.any():
        return
    turn = rotvec_to_quat(k[bad] * excess[bad, None])
    out[fr[bad], lim.mid] = quat_mul(quat_conj(w_o[bad, pm]), quat_mul(turn, w_o[bad, lim.mid]))


def _fk_rows(motion: Motion, joints, frames, local_quats):
    """World positions ``(n, J, 3)`` and rotations ``(n, J, 4)`` of ``joints`` (and ancestors; NaN elsewhere)
    on ``frames (n,)`` only, with the local rotations ``local_quats (F, J, 4)``."""
    sub, sub_par, _ = chain_subset(motion.skeleton.parents, joints)
    n = len(frames)
    Q = np.ascontiguousarray(local_quats[frames][:, sub].transpose(2, 1, 0))                   # (4, s, n)
    lt = motion.local_translations
    T = (motion.skeleton.offsets[sub].T[:, :, None] if lt is None
         else np.ascontiguousarray(lt[frames][:, sub].transpose(2, 1, 0)))
    W, P = _fk_component_major(Q, T, np.ascontiguousarray(motion.root_positions[frames].T), sub_par)
    pos = np.full((n, motion.num_joints, 3), np.nan)
    wq = np.full((n, motion.num_joints, 4), np.nan)
    pos[:, sub] = P.transpose(2, 1, 0)
    wq[:, sub] = W.transpose(2, 1, 0)
    return pos, wq


_SOURCE_CACHE = weakref.WeakKeyDictionary()


def _source_tables(source: Motion, limbs: dict):
    """What the layer reads of the source, once per (source, limbs) (a slider's replays share it): world
    positions and rotations of the limbs' and feet's chains, the share of each limb's length it uses per
    frame, each limb's hinge axis, and the floor (the lowest height of the feet's joints)."""
    key = tuple(sorted((lim.upper, lim.mid, lim.eff) + lim.foot for lim in limbs.values()))
    per = _SOURCE_CACHE.setdefault(source, {})
    if key not in per:
        joints = {x for lim in limbs.values() for x in (lim.upper, lim.mid, lim.eff) + lim.foot}
        spos, swq = _fk_joints(source, joints)
        share = {e: np.linalg.norm(spos[:, e] - spos[:, lim.upper], axis=-1) / _length(spos, lim)
                 for e, lim in limbs.items()}
        hinges = {e: _hinge_local(spos, swq, lim) for e, lim in limbs.items()}
        feet = [x for lim in limbs.values() if lim.leg for x in (lim.eff,) + lim.foot]
        floor = float(np.min(spos[:, feet, 1])) if feet else -np.inf
        if len(per) > 8:
            per.clear()
        per[key] = (spos, swq, share, hinges, floor)
    return per[key]


def _source_frames(tables, t0: float, ft: float, ft_s: float, joint: int, frames: np.ndarray) -> np.ndarray:
    """Source frames (floats) of edited ``frames`` through ``joint``'s inverse time warp (identity without
    warp ``tables``)."""
    te = t0 + np.asarray(frames, dtype=float) * ft
    if tables is not None:
        from .timing import _warp_column
        te = _warp_column(*tables, joint, te, inverse=True)
    return te / ft_s


def _length(pos, lim: Limb) -> np.ndarray:
    """The limb's two bones' length on every frame ``(F,)`` (file units; animated translations may change it)."""
    return (np.linalg.norm(pos[:, lim.mid] - pos[:, lim.upper], axis=-1)
            + np.linalg.norm(pos[:, lim.eff] - pos[:, lim.mid], axis=-1))


def _reach(reach: float, length: np.ndarray, extension: np.ndarray, source_share: np.ndarray) -> np.ndarray:
    """Largest upper-effector distance a held limb may use ``(n,)``: ``reach`` of its ``length``, or the
    ``extension`` the edited pose already has, or the share of its length the source used at the plant's
    source time (``source_share``), whichever is more; never the full length."""
    return np.minimum(np.maximum(np.maximum(reach, source_share) * length, extension), length * (1 - 1e-9))


def _sample_rows(arr, f, cols):
    """``arr (F, J, 3)`` at fractional frames ``f (n,)`` and joints ``cols (n,)`` (linear; clamped)."""
    f = np.clip(f, 0, arr.shape[0] - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, arr.shape[0] - 1)
    w = (f - i0).reshape((-1,) + (1,) * (arr.ndim - 2))
    return arr[i0, cols] * (1 - w) + arr[i1, cols] * w


def keep_contacts(edited, source: Motion, *, contacts=None, blend: float = 0.15, carry_by: str = "joint",
                  lower_root: bool | float = True, reach: float = REACH,
                  source_positions: np.ndarray | None = None) -> Motion:
    """The constraint layer after staggered timing edits: the source's contacts carried through the edit and
    held (:func:`hold_plants`, whose notes this drops); returns the held Motion."""
    return hold_plants(edited, source, contacts=contacts, blend=blend, carry_by=carry_by, lower_root=lower_root,
                       reach=reach, source_positions=source_positions).motion


# -- the older names, over the new layer -------------------------------------------------------------------

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
                  _MAX_DROP if share > 0 else 0.0, 1.0, targets=given, shift_plants=False, above_floor=False).motion


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
