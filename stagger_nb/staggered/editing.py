"""Geometric and temporal editing of staggered poses (Coleman et al. 2008, §5).

Every tool is a pure function ``StaggeredMotion -> StaggeredMotion`` whose parameters are JSON-serialisable
(joint names, numbers, lists), so an edit session can record ``{"op": "succession", "root": "LeftShoulder",
"s": 0.03, "l": 2.0}`` and replay it. Every tool takes an optional ``joints=`` subset (partial poses, §6).

Notation (as in :mod:`stagger_nb.staggered.representation`): K poses at times ``t_k``, J joints,
refinements ``r[k, i]``, knot times ``T[k, i] = t_k + r[k, i]``, extreme-value knots ``v[k, i]``, editing
knots ``v⁰[k, i]`` (the true pose at ``t_k``). For rotations ``a ⊕ b = a b`` (quaternion product, ``b`` in
the joint's local frame) and ``c ⊖ a = a⁻¹ c``; "``w`` times a rotation" is a rotation scale
``exp(w log q)`` (§5.1 footnote).

Geometric edits (§5.1) change the knots by a per-joint offset ``δ``: ``v̂ = v ⊕ δ`` and ``v̂⁰ = v⁰ ⊕ δ``
(the mutual constraint of the two knots, both directions of Figure 6a/b). The displacement maps of the two
segments around the pose are then re-measured so that the evaluated motion is the old one post-multiplied
by a smooth weight ``w(t) δ``: ``w = 1`` on the plateau between ``t_k`` and ``T[k, i]`` (so both knots get
exactly ``δ``), a raised-cosine ramp to 0 at the neighbouring poses' plateaus, 0 elsewhere. Because the old
displacement is kept inside the new one, high-frequency detail is carried through (§3, §5.1), and frames
outside the two segments around an edited pose do not change at all.

Temporal edits (§5.2) only change ``t_k`` / ``r[k, i]``: splines and displacement maps live on normalised
segment time, so they follow; editing knots are re-created at ``t_k`` by evaluation (Figure 6c). Refined
times that come closer to a neighbouring pose than to their own are reported as :class:`TimingWarning`
objects in ``sm.metadata["warnings"]`` (also available from :func:`timing_warnings`), never printed.
"""
from __future__ import annotations

import dataclasses
import re
import weakref
from dataclasses import dataclass

import numpy as np

from ..core.rotations import quat_conj, quat_exp, quat_hemisphere, quat_log, quat_mul, slerp
from .fitting import displacement_rotvecs
from . import _kernels as kern
from .representation import (StaggeredMotion, _rotations_at, bezier_cubic, knot_times, rotation_spline,
                             static_rotations, translation_source_times)

__all__ = ["TimingWarning", "timing_warnings", "summarize_timing_warnings", "timing_summary", "saturate_offsets",
           "TIMING_LIMIT", "body_part", "source_knot_times", "warp_times", "edit_pose", "exaggerate", "retime",
           "succession",
           "OffsetBasis", "pose_offset_basis",
           "random_timing", "insert_pose", "delete_pose", "mean_pose"]

_IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])
_TINY_ANGLE = 1e-15  # an offset with |log δ| below this (radians/2) is the identity: nothing to re-measure


# -- warnings ---------------------------------------------------------------------------------------------

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


# -- argument helpers ---------------------------------------------------------------------------------------

def _check(sm) -> None:
    if not isinstance(sm, StaggeredMotion):
        raise ValueError(f"sm must be a StaggeredMotion, got {type(sm).__name__}")


def _joint_mask(sm: StaggeredMotion, joints, default=None) -> np.ndarray:
    """(J,) bool mask of a joint subset given by names/indices; ``None`` -> ``default`` (all joints)."""
    J = sm.num_joints
    if joints is None:
        return np.ones(J, bool) if default is None else default
    if isinstance(joints, (str, int, np.integer)):
        joints = [joints]
    mask = np.zeros(J, bool)
    for j in joints:
        if isinstance(j, str):
            try:
                mask[sm.skeleton.index(j)] = True
            except KeyError as e:
                raise ValueError(f"joints: {e.args[0]}") from None
        else:
            if not 0 <= int(j) < J:
                raise ValueError(f"joints: index {j} outside [0, {J})")
            mask[int(j)] = True
    return mask


def _pose_mask(sm: StaggeredMotion, poses, interior_default: bool) -> np.ndarray:
    K = sm.num_poses
    if poses is None:
        mask = np.ones(K, bool)
        if interior_default:
            mask[[0, -1]] = False
        return mask
    if isinstance(poses, (int, np.integer)):
        poses = [poses]
    mask = np.zeros(K, bool)
    for k in poses:
        if not -K <= int(k) < K:
            raise ValueError(f"poses: index {k} outside [0, {K})")
        mask[int(k)] = True
    return mask


def _pose_index(sm: StaggeredMotion, k, name="k") -> int:
    K = sm.num_poses
    if not isinstance(k, (int, np.integer)) or not -K <= int(k) < K:
        raise ValueError(f"{name} must be a pose index in [0, {K}), got {k!r}")
    return int(k) % K


def _finite(x, name: str) -> float:
    try:
        x = float(x)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {x!r}") from None
    if not np.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return x


def _rotation_table(sm: StaggeredMotion, spec, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint rotations from ``{joint: rotvec (3,) | quat (4,)}`` or an array ``(J, 3)``/``(J, 4)``.

    Returns ``quats (J, 4)`` (identity where absent) and the ``(J,)`` mask of given joints."""
    J = sm.num_joints
    q = np.tile(_IDENTITY, (J, 1))
    given = np.zeros(J, bool)
    if isinstance(spec, dict):
        items = spec.items()
    else:
        arr = np.asarray(spec, dtype=float)
        if arr.ndim != 2 or arr.shape[0] != J or arr.shape[1] not in (3, 4):
            raise ValueError(f"{name} must be a dict joint -> rotation or an array of shape ({J}, 3|4), got {arr.shape}")
        items = enumerate(arr)
    for j, v in items:
        try:
            jj = _joint_mask(sm, [j])
        except ValueError as e:
            raise ValueError(f"{name}: {e}") from None
        v = np.asarray(v, dtype=float).reshape(-1)
        if v.size == 3:
            v = quat_exp(0.5 * v)                 # rotation vector, radians
        elif v.size == 4 and np.linalg.norm(v) > 0:
            v = v / np.linalg.norm(v)             # quaternion (x, y, z, w)
        else:
            raise ValueError(f"{name}[{j!r}] must be a rotation vector (3 numbers) or a quaternion (4), got {v.tolist()}")
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{name}[{j!r}] must be finite")
        q[jj] = v
        given |= jj
    return q, given


# -- evaluation at per-sample (time, joint) pairs -------------------------------------------------------

def _segments(knots: np.ndarray, times: np.ndarray, cols: np.ndarray):
    """Segment and normalised time of each ``(times[n], cols[n])`` in the knot columns ``knots (K, C)``."""
    knots = np.maximum.accumulate(knots, axis=0)
    K, C = knots.shape
    # one searchsorted for all columns: shift column c by c * span so the flattened knots stay sorted
    lo = min(knots.min(), times.min())
    span = max(knots.max(), times.max()) - lo + 1.0
    flat = ((knots - lo) + np.arange(C) * span).T.reshape(-1)
    seg = np.searchsorted(flat, (times - lo) + cols * span, side="right") - 1 - cols * K
    np.clip(seg, 0, K - 2, out=seg)
    a, b = knots[seg, cols], knots[seg + 1, cols]
    L = b - a
    tn = np.where(L > 0, (times - a) / np.where(L > 0, L, 1.0), 1.0)
    return seg, np.clip(tn, 0.0, 1.0)


_PAIR_KERNEL_MIN = 4096   # samples from which the per-pair kernel pays for its per-pair set-up


def _displacement(table: np.ndarray, counts: np.ndarray, index: tuple, tn: np.ndarray) -> np.ndarray:
    """Same as :func:`~stagger_nb.staggered.representation.displacement_at` for the rows ``table[index]``,
    gathering only the two samples each point needs (not whole rows)."""
    n = counts[index]
    u = np.clip(tn, 0.0, 1.0) * (n - 1)
    m0 = np.minimum(np.floor(u).astype(np.int64), n - 2)
    a = (u - m0)[:, None]
    return table[index + (m0,)] * (1.0 - a) + table[index + (m0 + 1,)] * a


def _eval_rotations(sm: StaggeredMotion, times: np.ndarray, joints: np.ndarray, seg=None, tn=None) -> np.ndarray:
    """Local rotation ``(N, 4)`` of joint ``joints[n]`` at time ``times[n]`` (same formula as ``evaluate``);
    pass ``seg``/``tn`` when the segment and normalised time are already known.

    Many samples (a re-measured displacement grid) go through ``evaluate``'s own kernel, whose
    control-polygon arcs are computed once per (segment, joint) pair instead of once per sample (the same
    values to ~1e-16; 2-3x faster); a few (the K x J knots of :func:`_refresh`) through the small
    evaluator below."""
    if seg is None:
        seg, tn = _segments(knot_times(sm), times, joints)
    if seg.size > _PAIR_KERNEL_MIN:
        return np.array(_rotations_at(sm, seg * sm.num_joints + joints, np.clip(tn, 0.0, 1.0)).T)
    tg = sm.tangents[seg, joints]
    s = rotation_spline(sm.values[seg, joints], tg[:, 0], tg[:, 1], sm.values[seg + 1, joints], tn)
    d = _displacement(sm.displacements, sm.displacement_counts, (seg, joints), tn)
    return quat_mul(s, quat_exp(0.5 * d))


def _eval_root(sm: StaggeredMotion, times: np.ndarray) -> np.ndarray:
    """Root translation ``(N, 3)`` at ``times (N,)``."""
    seg, tn = _segments((sm.pose_times + sm.root_refinements)[:, None], times, np.zeros(times.size, np.int64))
    rt = sm.root_tangents[seg]
    p = bezier_cubic(sm.root_values[seg], rt[:, 0], rt[:, 1], sm.root_values[seg + 1], tn)
    return p + _displacement(sm.root_displacements, sm.root_displacement_counts, (seg,), tn)


# -- re-measuring displacement maps ---------------------------------------------------------------------

def _grid(a: np.ndarray, b: np.ndarray, counts: np.ndarray):
    """Uniform t' grids of P segments ``[a, b]``: sample's pair index, index within pair, t', time."""
    pair = np.repeat(np.arange(counts.size), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    m = np.arange(pair.size) - starts[pair]
    tn = m / (counts[pair] - 1.0)
    return pair, m, tn, a[pair] + tn * (b - a)[pair]


_OVERSAMPLE = 4  # grid refinement of re-measured maps whose ends are off the frame grid (interpolation error / 4)


def _counts_for(a, b, frame_time):
    """Samples of re-measured displacement maps on segments ``[a, b]``: one per source frame spanned (+1),
    so knots on frames put every grid point on a frame (exact there); segments with an end off the frame
    grid (after timing edits) get ``_OVERSAMPLE`` times more samples to keep the linear interpolation close."""
    fa, fb = a / frame_time, b / frame_time
    aligned = (np.abs(fa - np.rint(fa)) < 1e-6) & (np.abs(fb - np.rint(fb)) < 1e-6)
    per = np.where(aligned, 1, _OVERSAMPLE)
    return np.maximum(np.rint((b - a) / frame_time * per).astype(np.int64) + 1, 2)


def _measure_rotations(values, tangents, knots, seg, joint, counts, target_fn, grid=None):
    """Displacement rows ``(P, max(counts), 3)`` of the pairs ``(seg[p], joint[p])`` so that the spline of
    ``values``/``tangents`` plus the displacement equals ``target_fn(times, joints, pair, tn)`` on the grid
    (``grid``: :func:`_grid` of these pairs when the caller has it)."""
    if grid is None:
        knots = np.maximum.accumulate(knots, axis=0)
        grid = _grid(knots[seg, joint], knots[seg + 1, joint], counts)
    pair, m, tn, t = grid
    sp, jp = seg[pair], joint[pair]
    # the new spline on the grid, its control arcs computed once per pair (not per sample: same values)
    ctrl = [np.ascontiguousarray(x.T) for x in (values[seg, joint], tangents[seg, joint, 0],
                                                 tangents[seg, joint, 1], values[seg + 1, joint])]
    s = kern.spline_into(*ctrl, pair, tn, kern.WORK.get("ms_s", (4, tn.size))).T   # read before the next call
    v = target_fn(t, jp, pair, tn)
    d = displacement_rotvecs(s, v, pair)          # unwrapped along each grid, as at extraction
    rows = np.zeros((counts.size, int(counts.max()), 3))
    rows[pair, m] = d
    return rows


def _measure_root(root_values, root_tangents, root_knots, seg, counts, target_fn):
    pair, m, tn, t = _grid(root_knots[seg], root_knots[seg + 1], counts)
    sp = seg[pair]
    s = bezier_cubic(root_values[sp], root_tangents[sp, 0], root_tangents[sp, 1], root_values[sp + 1], tn)
    rows = np.zeros((counts.size, int(counts.max()), 3))
    rows[pair, m] = target_fn(t, pair, tn) - s
    return rows


def _put_rows(table: np.ndarray, index: tuple, rows: np.ndarray) -> np.ndarray:
    """Copy of a displacement table (sample axis -2: ``(K-1, J, M, 3)`` or ``(K-1, M, 3)``) with the rows at
    ``index`` replaced by ``rows (P, M', 3)``; the sample axis grows if ``M' > M``."""
    M = max(table.shape[-2], rows.shape[1])
    out = np.zeros(table.shape[:-2] + (M, 3))
    out[..., :table.shape[-2], :] = table
    out[index] = 0.0
    out[index + (slice(0, rows.shape[1]),)] = rows
    return out


def source_knot_times(sm: StaggeredMotion) -> np.ndarray:
    """Source time of every knot, shape (K, J + 1), seconds: columns ``0 .. J-1`` the joint rotations'
    knots, column ``J`` the root translation's.

    The per-control-variable time warp that the temporal edits (§5.2) applied is the piecewise-linear map
    ``source_knot_times(sm)[:, c] -> knots[:, c]`` (splines and displacement maps live on normalised segment
    time, so between two knots the edited motion replays the source segment linearly in time; see
    :func:`warp_times`). The editing tools record it in ``sm.metadata["source_knots"]`` at their first
    edit and carry it through retiming, succession, random timing and pose insertion/deletion (and a later
    :func:`~stagger_nb.staggered.cull`, which keeps a subset of the poses at their times: their rows are
    kept). An ``sm`` without the record (a fresh extraction), or whose poses no longer match it (retimed
    by something other than these tools), is taken as unedited: its own knots.
    """
    K, J = sm.num_poses, sm.num_joints
    rec = sm.metadata.get("source_knots")
    if rec is not None:
        rec = np.asarray(rec, dtype=float)
        at = np.asarray(sm.metadata.get("source_knots_pose_times", ()), dtype=float)
        if rec.shape == (K, J + 1) and (at.shape != (K,) or np.allclose(at, sm.pose_times, rtol=0, atol=1e-9)):
            return rec
        if at.shape == (rec.shape[0],) and rec.shape[1:] == (J + 1,):
            # poses culled since the record (cull keeps a subset of the poses at their times): keep their rows
            row = np.searchsorted(at, sm.pose_times)
            row = np.clip(row, 0, at.size - 1)
            if np.allclose(at[row], sm.pose_times, rtol=0, atol=1e-9):
                return rec[row]
    return np.concatenate([knot_times(sm), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)


def _current_knots(sm: StaggeredMotion) -> np.ndarray:
    """Knot times (K, J + 1) in the column layout of :func:`source_knot_times`."""
    return np.concatenate([knot_times(sm), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)


def warp_times(sm: StaggeredMotion, times, joint, *, inverse: bool = False) -> np.ndarray:
    """Map source times to edited times (or back, ``inverse=True``) through the time warp of one control
    variable: piecewise linear between its knots (§3: each segment is replayed on normalised time).

    Parameters
    ----------
    sm : StaggeredMotion
    times : array_like (N,), seconds
    joint : str or int
        Joint name or index (its rotation's knots), or ``"<root translation>"`` / ``sm.num_joints``.

    Returns
    -------
    (N,) seconds; times outside the first/last knot move with the nearest end knot (slope 1).
    """
    J = sm.num_joints
    if isinstance(joint, str):
        c = J if joint == "<root translation>" else _joint_mask(sm, [joint]).argmax()
    else:
        c = int(joint)
        if not 0 <= c <= J:
            raise ValueError(f"joint: index {joint} outside [0, {J}]")
    return _warp_column(*_warp_tables(sm), c, times, inverse)


def _warp_tables(sm: StaggeredMotion) -> tuple[np.ndarray, np.ndarray]:
    """``(S, T)``, both (K, J + 1): the source and current knot times of every control variable, made
    non-decreasing down each column (the breakpoints of :func:`warp_times`). Computed once, they serve
    any number of :func:`_warp_column` calls (one per contact in ``keep_contacts``)."""
    return np.maximum.accumulate(source_knot_times(sm), axis=0), np.maximum.accumulate(_current_knots(sm), axis=0)


def _warp_column(S: np.ndarray, T: np.ndarray, c: int, times, inverse: bool = False) -> np.ndarray:
    """:func:`warp_times` of column ``c`` from the tables of :func:`_warp_tables`."""
    x = np.asarray(times, dtype=float).reshape(-1)
    a, b = (T[:, c], S[:, c]) if inverse else (S[:, c], T[:, c])
    y = np.interp(x, a, b)
    y = np.where(x < a[0], b[0] + (x - a[0]), y)
    return np.where(x > a[-1], b[-1] + (x - a[-1]), y)


def _refresh(sm: StaggeredMotion, source_knots=None, extra=None, **fields) -> StaggeredMotion:
    """New StaggeredMotion with ``fields`` replaced, editing knots re-created at ``t_k`` by evaluation
    (Figure 6c; kept equal to the extreme knots where the refinement is 0), timing warnings attached
    as ``metadata["warnings"]`` and the source knot times (:func:`source_knot_times`) carried as
    ``metadata["source_knots"]`` (``source_knots`` overrides them when the poses change)."""
    if source_knots is None:
        source_knots = source_knot_times(sm)
    new = sm._with_fields(**fields)          # (arrays the edit did not change are shared, not copied)
    K, J = new.num_poses, new.num_joints
    # K x J samples through this module's small evaluator (evaluate_arrays keeps scratch buffers sized
    # for whole clips; alternating tiny calls with full evaluations would make it re-allocate them)
    q = _eval_rotations(new, np.repeat(new.pose_times, J), np.tile(np.arange(J), K)).reshape(K, J, 4)
    editing = np.where((new.refinements != 0)[..., None], q, new.values)
    editing.setflags(write=False)
    meta = {k: v for k, v in dict.items(new.metadata) if k != "warnings"}   # (a lazy entry is not computed)
    sk = np.array(source_knots, dtype=float)
    sk.setflags(write=False)
    meta["source_knots"] = sk
    meta["source_knots_pose_times"] = new.pose_times        # the rows' poses (a later cull keeps a subset)
    if extra:
        meta.update(extra)
    # the object was created above and is not shared yet: set the two derived fields in place (as
    # __post_init__ does) instead of validating and copying every array a second time
    object.__setattr__(new, "editing_knots", editing)
    fields = (new.pose_times, new.refinements, new.root_refinements, new.values, editing, new.root_values,
              new.frame_time, tuple(new.skeleton.names))
    object.__setattr__(new, "metadata", _LazyWarnings(meta, lambda: _timing_warnings(*fields)))
    return new


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

    def _fill(self) -> "_LazyWarnings":
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


# -- geometric editing (§5.1) ---------------------------------------------------------------------------

def _plateau_weights(knots: np.ndarray, tk: np.ndarray, k: np.ndarray, col: np.ndarray, t: np.ndarray,
                     side: np.ndarray) -> np.ndarray:
    """Weight ``(N,)`` of pose ``k`` at time ``t`` for control variable ``col`` of ``knots (K, C)`` on
    ``side`` (-1: t is before pose k's knot, in segment k-1; +1: after, in segment k): 1 on the plateau
    between ``t_k`` and ``T[k, col]``, a raised cosine down to 0 at the neighbouring pose's plateau edge."""
    T = np.maximum.accumulate(knots, axis=0)
    lo = np.minimum(tk[:, None], T)          # plateau [lo, hi] of every (pose, column)
    hi = np.maximum(tk[:, None], T)
    kn = np.clip(k + side, 0, T.shape[0] - 1)
    inner = np.where(side < 0, hi[kn, col], lo[kn, col])   # where the ramp reaches 0
    outer = np.where(side < 0, lo[k, col], hi[k, col])     # where the ramp reaches 1
    L = outer - inner
    u = np.where(np.abs(L) > 0, (t - inner) / np.where(np.abs(L) > 0, L, 1.0), 1.0)
    u = np.clip(u, 0.0, 1.0)
    w = 0.5 * (1.0 - np.cos(np.pi * u))
    on_plateau = (t >= lo[k, col]) & (t <= hi[k, col])
    return np.where(on_plateau, 1.0, w)


def _pair_plateau_weights(knots: np.ndarray, tk: np.ndarray, k: np.ndarray, col: np.ndarray, side: int,
                          t: np.ndarray, pair: np.ndarray) -> np.ndarray:
    """:func:`_plateau_weights` of samples ``t (N,)`` that belong to pairs ``(k[pair], col[pair])`` all on one
    ``side``: the plateau and ramp ends are found once per pair (P << N) and gathered, and the raised
    cosine ``(1 - cos(pi u)) / 2`` is taken as ``(1 - sin(pi/2 - pi u)) / 2`` by the kernels' polynomial
    sine (numpy's cos is scalar libm here; same values to ~1e-16)."""
    T = np.maximum.accumulate(knots, axis=0)
    lo = np.minimum(tk[:, None], T)
    hi = np.maximum(tk[:, None], T)
    kn = np.clip(k + side, 0, T.shape[0] - 1)
    inner = (hi[kn, col] if side < 0 else lo[kn, col])[pair]     # where the ramp reaches 0
    outer = (lo[k, col] if side < 0 else hi[k, col])[pair]       # where the ramp reaches 1
    L = outer - inner
    nz = np.abs(L) > 0
    u = np.where(nz, (t - inner) / np.where(nz, L, 1.0), 1.0)
    np.clip(u, 0.0, 1.0, out=u)
    x = np.pi / 2 - np.pi * u                                     # in [-pi/2, pi/2]
    w = kern.sin_poly(x, np.empty_like(x), np.empty_like(x))
    w = 0.5 * (1.0 - w)
    on_plateau = (t >= lo[k, col][pair]) & (t <= hi[k, col][pair])
    return np.where(on_plateau, 1.0, w)


@dataclass(frozen=True, eq=False)
class OffsetBasis:
    """What re-measuring every displacement map of one StaggeredMotion after knot offsets (§5.1) needs that
    does not depend on the offsets: the re-measuring grid of every (segment, joint) pair, the motion's
    rotations on it and the plateau weights of both ends. Built by :func:`pose_offset_basis`; pass it to
    :func:`exaggerate` (``basis=``) to skip that half of the work when the same motion is exaggerated again
    with another ``w_r`` (a slider). Arrays: ``seg, joint, counts (P,)``, the P pairs it covers: every
    (segment, joint) pair of the joints that move (P <= (K - 1) J; a static joint's rotation, one quaternion
    throughout, e.g. 6 of CMU's 31, is not exaggerated by a relative offset and keeps its map); ``pair,
    m, tn, t (N,)`` the grid (pair index, index in the pair, normalised and absolute time, seconds);
    ``old (4, N)`` the rotations (x, y, z, w rows); ``wl, wr (N,)`` the weights of the segment's first and
    second pose; ``knots (K, J)`` and ``pose_times (K,)`` of the motion it was built for (checked on use)."""

    knots: np.ndarray
    pose_times: np.ndarray
    seg: np.ndarray
    joint: np.ndarray
    counts: np.ndarray
    grid: tuple
    old: np.ndarray
    wl: np.ndarray
    wr: np.ndarray

    def fits(self, sm: StaggeredMotion) -> bool:
        """True when this basis was built for a motion with ``sm``'s knots and displacement grids."""
        return (self.knots.shape == (sm.num_poses, sm.num_joints) and np.array_equal(self.knots, knot_times(sm))
                and np.array_equal(self.pose_times, sm.pose_times)
                and np.array_equal(self.counts, sm.displacement_counts[self.seg, self.joint]))

    def restrict(self, pairs: np.ndarray) -> "OffsetBasis":
        """This basis on the subset ``pairs (P,) bool`` of its pairs (the grid gathered, pairs renumbered)."""
        if pairs.all():
            return self
        pair, m, tn, t = self.grid
        keep = pairs[pair]
        new_id = np.cumsum(pairs) - 1
        return OffsetBasis(self.knots, self.pose_times, self.seg[pairs], self.joint[pairs], self.counts[pairs],
                           (new_id[pair[keep]], m[keep], tn[keep], t[keep]), self.old[:, keep], self.wl[keep],
                           self.wr[keep])


_READ_TOL = 1e-9   # rad: a motion read at the grid's frames stands for sm's own rotations there within this


def _old_from_frames(sm: StaggeredMotion, reproduced, seg, joint, pair, tn, t) -> np.ndarray | None:
    """``sm``'s rotations ``(4, N)`` at the grid samples ``(pair, t)`` read from ``reproduced`` (a Motion that
    ``sm`` reproduces at its frames, frame f at ``f * frame_time`` seconds; ``tn`` the samples' normalised
    times in their pairs), or None when a sample is off its
    frames (after timing edits) or a check finds ``sm`` away from it: the middle sample of every pair and
    every 16th sample are evaluated and must agree within ``_READ_TOL`` (a geometric edit since, …)."""
    ft = reproduced.frame_time
    if abs(ft - sm.frame_time) > 1e-12 * ft or reproduced.num_joints != sm.num_joints:
        return None
    f = t / ft
    r = np.rint(f)
    if not (np.all(np.abs(f - r) < 1e-9) and r.min() >= 0 and r.max() <= reproduced.num_frames - 1):
        return None
    jp = joint[pair]
    old = np.ascontiguousarray(reproduced.local_quats[r.astype(np.int64), jp].T)
    starts = np.flatnonzero(np.r_[True, pair[1:] != pair[:-1]])
    mid = (starts + np.r_[starts[1:], pair.size]) // 2
    check = np.union1d(mid, np.arange(0, pair.size, 16))
    true = np.array(_rotations_at(sm, seg[pair[check]] * sm.num_joints + jp[check], tn[check]))
    r = quat_mul(quat_conj(true.T), old[:, check].T)          # angle by atan2 (a dot product's arccos cannot
    angle = 2.0 * np.arctan2(np.linalg.norm(r[:, :3], axis=1), np.abs(r[:, 3]))   # resolve 1e-9 rad)
    return old if angle.max() <= _READ_TOL else None


def pose_offset_basis(sm: StaggeredMotion, reproduced=None) -> OffsetBasis:
    """The offset-independent half of re-measuring every displacement map of ``sm`` (see
    :class:`OffsetBasis`): ``exaggerate(sm, ..., basis=pose_offset_basis(sm))`` equals ``exaggerate(sm, ...)``
    to rounding (~1e-16 rad). Cost: about one :func:`evaluate`; memory ~100 bytes
    per grid sample (``(F + K) J`` samples at extraction). Static joints (:func:`~.representation.
    static_rotations`) are left out: an edit that moves one re-measures without the basis.

    ``reproduced``: a Motion ``sm`` reproduces at its frames (frame f at ``f * frame_time`` seconds), e.g. the
    source of an extraction or of its cull (both exact at the frames by construction, §4.1.1: ~1e-14 rad);
    while ``sm``'s knots sit on frames (no timing edit yet) the rotations on the grid are read from it instead
    of evaluated (most of the cost), after a check that evaluates every pair's middle sample and every 16th
    sample (they must agree within 1e-9 rad, else ``sm`` is evaluated as without it). The result then equals
    the basis without it to ~1e-14 rad."""
    _check(sm)
    K, J = sm.num_poses, sm.num_joints
    moving = np.flatnonzero(~static_rotations(sm)[0])
    seg, joint = np.divmod(np.arange((K - 1) * moving.size), moving.size)
    joint = moving[joint]
    counts = sm.displacement_counts[seg, joint]
    knots = knot_times(sm)
    T = np.maximum.accumulate(knots, axis=0)
    grid = _grid(T[seg, joint], T[seg + 1, joint], counts)
    pair, _, tn, t = grid
    old = None if reproduced is None else _old_from_frames(sm, reproduced, seg, joint, pair, tn, t)
    if old is None:
        old = np.array(_rotations_at(sm, seg[pair] * J + joint[pair], tn))
    wl = _pair_plateau_weights(knots, sm.pose_times, seg, joint, 1, t, pair)
    wr = _pair_plateau_weights(knots, sm.pose_times, seg + 1, joint, -1, t, pair)
    for a in (knots, old, wl, wr) + tuple(grid):
        a.setflags(write=False)
    return OffsetBasis(knots, np.array(sm.pose_times), seg, joint, counts, grid, old, wl, wr)


def _apply_pose_offsets(sm: StaggeredMotion, deltas: np.ndarray, root_deltas: np.ndarray | None = None,
                        basis: OffsetBasis | None = None):
    """Apply knot offsets ``deltas (K, J, 4)`` (and root translation offsets ``(K, 3)``): ``v̂ = v ⊕ δ``,
    ``v̂⁰ = v⁰ ⊕ δ``, the adjacent Bézier handles move with their knot, and the displacement maps of the
    touched segments are re-measured so that ``v̂(t) = v(t) ⊕ w_k(t) δ_k ⊕ w_{k+1}(t) δ_{k+1}``."""
    K, J = sm.num_poses, sm.num_joints
    moved = np.linalg.norm(quat_log(quat_hemisphere(deltas)), axis=-1) > _TINY_ANGLE   # (K, J)
    rmoved = np.zeros(K, bool) if root_deltas is None else np.any(root_deltas != 0, axis=1)
    if not moved.any() and not rmoved.any():
        return sm
    fields = {}
    if moved.any():
        values = quat_mul(sm.values, deltas)
        tangents = np.array(sm.tangents)
        tangents[:, :, 0] = quat_mul(tangents[:, :, 0], deltas[:-1])   # handle next to v_k (segment k)
        tangents[:, :, 1] = quat_mul(tangents[:, :, 1], deltas[1:])    # handle next to v_{k+1}
        touched = moved[:-1] | moved[1:]                                # (K-1, J) segments to re-measure
        if basis is not None:
            covered = np.zeros_like(touched)
            covered[basis.seg, basis.joint] = True
            inside = touched[basis.seg, basis.joint]
            if (touched & ~covered).any() or inside.sum() < 0.5 * inside.size:
                basis = None              # a static joint moved, or few pairs: re-measure those without it
            else:
                basis = basis.restrict(inside)   # the touched pairs (the others keep their maps exactly)
        if basis is not None:
            seg, joint, counts, grid = basis.seg, basis.joint, basis.counts, basis.grid
        else:
            seg, joint = np.nonzero(touched)
            counts, grid = sm.displacement_counts[seg, joint], None
        logd = quat_log(quat_hemisphere(deltas))                        # (K, J, 3), half-angle axis
        knots = knot_times(sm)

        def target(t, jp, pair, tn):
            # component-first (4, N) arithmetic; the plateau ramps' ends are per (segment, joint) pair
            if basis is not None:
                old, wl, wr = basis.old, basis.wl, basis.wr
            else:
                old = _rotations_at(sm, seg[pair] * J + jp, tn)             # same knots and grid: no search
                wl = _pair_plateau_weights(knots, sm.pose_times, seg, joint, 1, t, pair)
                wr = _pair_plateau_weights(knots, sm.pose_times, seg + 1, joint, -1, t, pair)
            W, N = kern.WORK, t.size            # scratch reused move to move (no fresh page-faulted arrays)
            e, a, h, tmp = W.get("ex_e", (4, N)), W.get("ex_a", (4, N)), W.get("ex_h", N), W.get("ex_tmp", N)
            g = W.get("ex_g", (3, N))
            for end, w in ((seg, wl), (seg + 1, wr)):                  # ⊕ w_k δ_k, then ⊕ w_{k+1} δ_{k+1}
                kern.take_cols_into(np.ascontiguousarray(logd[end, joint].T), pair, g)
                g *= w
                kern.qexp_into(g, e, h, tmp)
                if end is seg:
                    kern.qmul_into(old, e, a, tmp)
            return kern.qmul_into(a, e, W.get("ex_v", (4, N)), tmp).T

        rows = _measure_rotations(values, tangents, knots, seg, joint, counts, target, grid)
        fields.update(values=values, tangents=tangents,
                      displacements=_put_rows(sm.displacements, (seg, joint), rows))
    if rmoved.any():
        rv = sm.root_values + root_deltas
        rt = np.array(sm.root_tangents)
        rt[:, 0] += root_deltas[:-1]
        rt[:, 1] += root_deltas[1:]
        seg = np.flatnonzero(rmoved[:-1] | rmoved[1:])
        counts = sm.root_displacement_counts[seg]
        rk = (sm.pose_times + sm.root_refinements)[:, None]   # the root translation's own knot column

        def rtarget(t, pair, tn):
            sp = seg[pair]
            z = np.zeros_like(sp)
            wl = _plateau_weights(rk, sm.pose_times, sp, z, t, np.ones_like(sp))
            wr = _plateau_weights(rk, sm.pose_times, sp + 1, z, t, -np.ones_like(sp))
            return _eval_root(sm, t) + wl[:, None] * root_deltas[sp] + wr[:, None] * root_deltas[sp + 1]

        rows = _measure_root(rv, rt, np.maximum.accumulate(rk[:, 0]), seg, counts, rtarget)
        fields.update(root_values=rv, root_tangents=rt, root_displacements=_put_rows(sm.root_displacements, (seg,), rows))
    return _refresh(sm, **fields)


def edit_pose(sm: StaggeredMotion, k: int, deltas=None, *, target=None, mode: str = "staggered",
              joints=None, root_offset=None) -> StaggeredMotion:
    """Geometric pose edit of pose ``k`` (§5.1, Figure 6a/b).

    Parameters
    ----------
    sm : StaggeredMotion
    k : int
        Pose index in ``[0, K)``.
    deltas : dict joint name -> rotation, or ndarray (J, 3) / (J, 4), optional
        Per-joint change ``δ``: a rotation vector ``[x, y, z]`` (axis * angle, radians, in the joint's
        local frame) or a quaternion ``[x, y, z, w]``. Applied as ``v̂ = v ⊕ δ`` and ``v̂⁰ = v⁰ ⊕ δ``.
    target : dict joint name -> quaternion (x, y, z, w), or ndarray (J, 4), optional
        New value of the edited knot instead of ``deltas``: the true pose at ``t_k`` (``mode="staggered"``,
        ``δ = target ⊖ v⁰ = v⁰⁻¹ target``) or the non-staggered pose (``mode="unstaggered"``,
        ``δ = target ⊖ v = v⁻¹ target``).
    mode : {"staggered", "unstaggered"}
        Which knot the user edits: the editing knot at the staggered pose time (§5.1, first approach) or
        the extreme value of the non-staggered pose (second approach). The other follows by the same change.
    joints : list of joint names, optional
        Partial pose: only these joints are edited (default: every joint named in ``deltas``/``target``).
    root_offset : [dx, dy, dz], optional
        Change of the root translation knot (file units), with the same plateau treatment.

    Returns
    -------
    StaggeredMotion; motion outside ``(T[k-1, i], T[k+1, i])`` is unchanged for every joint ``i``.
    """
    _check(sm)
    k = _pose_index(sm, k)
    if mode not in ("staggered", "unstaggered"):
        raise ValueError(f"mode must be 'staggered' or 'unstaggered', got {mode!r}")
    if (deltas is None) == (target is None) and root_offset is None:
        raise ValueError("give exactly one of deltas= or target= (or only root_offset=)")
    if deltas is not None and target is not None:
        raise ValueError("give exactly one of deltas= or target=")
    J = sm.num_joints
    d = np.tile(_IDENTITY, (J, 1))
    if deltas is not None:
        d, given = _rotation_table(sm, deltas, "deltas")
    elif target is not None:
        tq, given = _rotation_table(sm, target, "target")
        base = sm.editing_knots[k] if mode == "staggered" else sm.values[k]
        d = np.where(given[:, None], quat_mul(quat_conj(base), tq), _IDENTITY)
    mask = _joint_mask(sm, joints)
    d = np.where(mask[:, None], d, _IDENTITY)
    full = np.tile(_IDENTITY, (sm.num_poses, J, 1))
    full[k] = d
    rd = None
    if root_offset is not None:
        ro = np.asarray(root_offset, dtype=float).reshape(-1)
        if ro.shape != (3,) or not np.all(np.isfinite(ro)):
            raise ValueError(f"root_offset must be 3 finite numbers, got {root_offset!r}")
        rd = np.zeros((sm.num_poses, 3))
        rd[k] = ro
    return _apply_pose_offsets(sm, full, rd)


def mean_pose(quats: np.ndarray) -> np.ndarray:
    """Per-joint mean rotation of ``quats (K, J, 4)`` -> ``(J, 4)``: the principal eigenvector of
    ``Σ q qᵀ`` (sign-invariant, Markley et al. 2007)."""
    q = np.asarray(quats, dtype=float)
    M = np.einsum("kja,kjb->jab", q, q)
    _, vecs = np.linalg.eigh(M)
    return quat_hemisphere(vecs[..., -1])


def exaggerate(sm: StaggeredMotion, k, w_r: float, *, reference="previous", mode: str = "staggered",
               joints=None, basis: OffsetBasis | None = None) -> StaggeredMotion:
    """Relative exaggeration ``v̂ = v ⊕ w_r (v ⊖ vʳ)`` of pose(s) ``k`` (§5.1).

    Parameters
    ----------
    k : int or list of int
        Pose(s) to exaggerate; several poses are offset together (each against its own reference).
    w_r : float
        Weight of the offset: 0 is the identity, 1 doubles the rotation from the reference, -1 collapses
        onto it. The rotation is scaled (``exp(w_r log(vʳ⁻¹ v))``), not multiplied component-wise.
    reference : "previous" | "next" | "mean" | int | dict joint -> quaternion
        The relative pose ``vʳ``: a neighbouring pose (local exaggeration; the first/last pose uses its
        only neighbour), the mean of all poses (global exaggeration), a pose index, or explicit values.
    mode : {"staggered", "unstaggered"}
        Values that are scaled: editing knots (the true pose at ``t_k``) or extreme values (the
        non-staggered pose); the other knot follows by the same change.
    joints : list of joint names, optional
        Partial pose (default all joints).
    basis : OffsetBasis, optional
        :func:`pose_offset_basis` of ``sm`` (cache it per ``sm``: it does not depend on ``k``, ``w_r``,
        ``reference``, ``mode`` or ``joints``); used when the edit moves at least half of the (segment, joint)
        pairs (e.g. every pose), where it saves a quarter to a third of the work; the same result to rounding. A basis of another motion is a ValueError.
    """
    _check(sm)
    w_r = _finite(w_r, "w_r")
    if basis is not None and (not isinstance(basis, OffsetBasis) or not basis.fits(sm)):
        raise ValueError("basis: not a pose_offset_basis of this StaggeredMotion (build it with "
                         "pose_offset_basis(sm) for the sm you exaggerate)")
    if mode not in ("staggered", "unstaggered"):
        raise ValueError(f"mode must be 'staggered' or 'unstaggered', got {mode!r}")
    ks = [k] if isinstance(k, (int, np.integer)) else list(k)
    ks = [_pose_index(sm, kk) for kk in ks]
    vals = sm.editing_knots if mode == "staggered" else sm.values
    K, J = sm.num_poses, sm.num_joints
    mask = _joint_mask(sm, joints)
    full = np.tile(_IDENTITY, (K, J, 1))
    mean = mean_pose(vals) if isinstance(reference, str) and reference == "mean" else None
    for kk in ks:
        if isinstance(reference, str):
            if reference == "previous":
                ref = vals[kk - 1] if kk > 0 else vals[kk + 1]
            elif reference == "next":
                ref = vals[kk + 1] if kk < K - 1 else vals[kk - 1]
            elif reference == "mean":
                ref = mean
            else:
                raise ValueError(f"reference must be 'previous', 'next', 'mean', a pose index or a pose, got {reference!r}")
        elif isinstance(reference, (int, np.integer)):
            ref = vals[_pose_index(sm, reference, "reference")]
        else:
            rq, given = _rotation_table(sm, reference, "reference")
            ref = np.where(given[:, None], rq, vals[kk])    # joints without a reference value: no change
        off = quat_hemisphere(quat_mul(quat_conj(ref), vals[kk]))           # v ⊖ vʳ
        delta = quat_exp(w_r * quat_log(off))                                # rotation scale
        full[kk] = np.where(mask[:, None], delta, _IDENTITY)
    return _apply_pose_offsets(sm, full, basis=basis)


# -- temporal editing (§5.2) ----------------------------------------------------------------------------

_END_FLOOR = 0.25   # an end segment keeps at least this share of half its pose spacing (x8 squeeze at most)


def inside_ends(knots: np.ndarray, pose_times: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """Knot times ``knots (K, C)`` seconds with the ``moved (K, C)`` interior knots kept inside the clip's ends.

    The first and last staggered poses are the clip's first and last frames (§4.1: "We force the first and last
    frame of the motion to have poses, as this is necessary to fully reconstruct the motion"), so their knots
    bound every control variable. A timing edit (§5.2) that moves an interior knot of column ``c`` past
    ``U = knots[-1, c] - h`` (``h`` half the last pose spacing ``t_{K-1} - t_{K-2}``) is eased towards the end:

        T -> U + (1 - f) h (1 - exp(-(T - U) / ((1 - f) h))),   f = 0.25

    identity up to ``U`` (where every knot of an unedited extraction sits: a refinement is closer to its own
    pose than to the neighbours), C1 there, increasing, and below ``knots[-1, c] - f h``: the last segment
    keeps at least ``f h`` seconds (its motion plays at most 8x faster than over the pose spacing) instead of
    being squeezed into a frame or two, and the last pose's knot stays the last (the clip's last frame shows
    the last pose). The first segment mirrors it (``L = knots[0, c] + (t_1 - t_0) / 2``). Knots that are not
    ``moved`` and the end rows are returned as they are. ``K < 3``: no interior knots.
    """
    out = np.array(knots, dtype=float)
    K = out.shape[0]
    if K < 3:
        return out
    inner, mv = out[1:-1], np.asarray(moved, bool)[1:-1]
    for h, edge, sign in ((0.5 * (pose_times[-1] - pose_times[-2]), out[-1], 1.0),
                          (0.5 * (pose_times[1] - pose_times[0]), out[0], -1.0)):
        room = (1.0 - _END_FLOOR) * h
        start = edge - sign * h                                   # U (last segment) or L (first)
        x = sign * (inner - start)                                # depth into the end zone (s), > 0 inside
        eased = start + sign * room * -np.expm1(-np.maximum(x, 0.0) / room)
        inner[...] = np.where(mv & (x > 0), eased, inner)
    return out


#: Default ``limit`` of :func:`succession` and :func:`random_timing`: no segment of a joint's curve plays more
#: than this many times faster than in the source, its fastest segments at most 1.1 times
#: (see :func:`saturate_offsets`; ``session.ops.TIMING_LIMIT`` declares the same default for the ops).
TIMING_LIMIT = 1.5
_IDENTITY_SHARE = 0.5  # a segment keeping at least this share of its room above its floor keeps its raw length
_NOTICEABLE = 0.1      # a joint's typical offset cut by more than this share (and half a frame): "limited noticeably"


def _check_limit(limit) -> float | None:
    if limit is None:
        return None
    if isinstance(limit, (bool, np.bool_)):
        raise ValueError(f"limit must be a number > 1 or None (the paper's raw offsets), got {limit!r}")
    limit = _finite(limit, "limit")
    if not limit > 1:
        raise ValueError(f"limit must be > 1 (the largest speed-up of a segment) or None, got {limit}")
    return limit


_FAST_FLOOR = 0.9      # the fastest segment of a joint keeps at least this share of its length (a 1.1x speed-up)


def saturate_offsets(knots, offsets, limit: float = TIMING_LIMIT, *, source_knots=None,
                     floors=None) -> np.ndarray:
    """Timing offsets ``offsets (K, C)`` (seconds) saturated smoothly so that no segment between two knots
    of a column shrinks below its floor: the edited knots ``knots + result`` stay strictly increasing, and
    no segment plays more than ``1 / floor`` times faster than in the source.

    Per column, with ``S_k`` a segment's length in the source (``source_knots``; default ``knots``) and
    ``x`` its edited length (the raw offsets added exactly), the length is soft-floored at ``a S_k``
    (``a`` = ``floors[k, c]``, default ``1 / limit``): with ``u = (x / S_k - a) / (1 - a)``, ``u`` is kept
    where ``u >= 1/2`` (every stretch, and compressions to ``a + (1 - a) / 2`` of the length, stay exact) and
    becomes ``exp(2 u - 1) / 2`` below (C1 there, > 0, tending to 0: the segment tends to, never reaches,
    ``a S_k``). The time a floored segment keeps in excess is given back by its neighbours, from their room
    above their own floors, passed on from segment to segment until it is absorbed: by the segments before
    it when its first knot moved later (a delay: the segment the delay stretched gives it back first), after
    it when its last knot moved earlier (a lead), in proportion when both; what reaches a column's end goes
    back the other way. The column's first and last knots stay where the raw offsets put them. So a pose's
    delay is cut locally (by the segment it stretched), a succession's uniform delay stays uniform through
    the clip and the joint catches up over its last segments (eased ends), random offsets are cut where they
    would squeeze a segment. Smooth (C1) in the offsets; columns without offsets stay exactly as they are,
    and so do columns whose knots are out of order (nothing to measure a speed-up against: their raw offsets).

    Parameters
    ----------
    knots : ndarray (K, C), seconds
        Knot times before the edit (``t_k + r[k, c]``).
    offsets : ndarray (K, C), seconds
    limit : float > 1
        Largest speed-up of a segment where ``floors`` is not given.
    source_knots : ndarray (K, C), seconds, optional
        The knots the floors refer to (before any timing edit: successive edits then cannot compound their
        speed-ups); default ``knots``.
    floors : ndarray (K - 1, C) in (0, 1), optional
        Per-segment floor ``a`` (e.g. higher where a joint moves fast: :func:`succession` uses the segment's
        speed); default ``1 / limit``.

    Returns
    -------
    ndarray (K, C), seconds: the offsets to add.
    """
    T = np.asarray(knots, dtype=float)
    o = np.asarray(offsets, dtype=float)
    limit = _check_limit(limit)
    out = np.array(o)
    if T.shape[0] < 2:
        return out
    Ts = T if source_knots is None else np.asarray(source_knots, dtype=float)
    D, S = np.diff(T, axis=0), np.diff(Ts, axis=0)
    cols = np.flatnonzero(np.any(o != 0, axis=0) & np.all(D > 0, axis=0) & np.all(S > 0, axis=0))
    if not cols.size:
        return out
    T, o, D, S = T[:, cols], o[:, cols], D[:, cols], S[:, cols]
    if floors is None:
        a = np.full(D.shape, 1.0 / limit)
    else:
        a = np.clip(np.asarray(floors, dtype=float)[:, cols], 1e-6, 1.0 - 1e-6)
    Tn = T + o

    def floor(x, k):          # segment k's soft-floored length for a wanted length x
        u = (x / S[k] - a[k]) / (1.0 - a[k])
        c = _IDENTITY_SHARE
        u = np.where(u >= c, u, c * np.exp(np.minimum(u - c, 0.0) / c))
        return S[k] * (a[k] + (1.0 - a[k]) * u)

    x = np.diff(Tn, axis=0)
    n = x.shape[0]
    Dp = np.stack([floor(x[k], k) for k in range(n)]) if n else x
    excess = Dp - x                                   # >= 0: what each floored segment keeps
    # a segment squeezed by its first knot moving later gives its excess back before it (the segments that
    # delay stretched), one squeezed by its last knot moving earlier after it; both: in proportion
    wb, wf = np.maximum(o[:-1], 0.0), np.maximum(-o[1:], 0.0)
    tot = wb + wf
    back = excess * np.where(tot > 0, wb / np.where(tot > 0, tot, 1.0), 0.5)
    fwd = excess - back
    carry = np.zeros(cols.size)
    want = x.copy()                                   # each segment's length before its floor
    passes = ((range(n - 1, -1, -1), back), (range(n), fwd), (range(n - 1, -1, -1), None))
    for order, own in passes:
        for k in order:
            want[k] = want[k] - carry
            d = floor(want[k], k)
            carry = carry - (Dp[k] - d) + (own[k] if own is not None else 0.0)   # what it could not absorb
            Dp[k] = d
    if np.any(carry > 1e-12):                        # every segment at its floor: share the rest by room
        room = Dp - a * S
        R = room.sum(axis=0)
        lam = np.where(R > 0, np.clip(1.0 - carry / np.where(R > 0, R, 1.0), 0.0, 1.0), 1.0)
        Dp = np.where(carry > 1e-12, a * S + room * lam, Dp)
    new = Tn[:1] + np.concatenate([np.zeros((1, cols.size)), np.cumsum(Dp, axis=0)])
    new[-1] = Tn[-1]
    # knots the saturation left where the raw offsets put them (to the cumulative sum's rounding) keep the
    # raw offsets exactly: an edit that squeezes nothing is the paper's formula, bit for bit
    same = np.abs(new - Tn) <= 1e-12 * (1.0 + np.abs(Tn))
    out[:, cols] = np.where(same, o, new - T)
    return out


_PATHS: dict = {}     # id(displacement table) -> (weak reference to it, its paths): timing edits share tables


def _map_paths(table: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Path length of each displacement map ``table (..., M, 3)`` over its ``counts (...)`` valid samples
    (radians, or file units for the root translation); cached per table (timing edits do not copy it)."""
    hit = _PATHS.get(id(table))
    if hit is not None and hit[0]() is table:
        return hit[1]
    M = table.shape[-2]
    if M < 2:
        out = np.zeros(table.shape[:-2])
    else:
        d = np.diff(table, axis=-2)
        step = np.sqrt(np.einsum("...i,...i->...", d, d))
        out = np.where(np.arange(M - 1) < (counts[..., None] - 1), step, 0.0).sum(axis=-1)
    if len(_PATHS) > 64:
        _PATHS.clear()
    _PATHS[id(table)] = (weakref.ref(table), out)
    return out


def _segment_floors(sm: StaggeredMotion, source: np.ndarray, limit: float) -> np.ndarray:
    """Per-segment floors ``(K - 1, J + 1)`` for :func:`saturate_offsets` (columns: the joints' rotations, then
    the root translation): ``a = clip(v / v_max, 1 / limit, 0.9)`` with ``v`` a segment's mean speed in
    the source's timing (the angle between its knots plus the path of its displacement map, over its source
    length; distances for the root translation) and ``v_max`` the column's fastest segment. A joint may play
    a slow segment up to ``limit`` times faster (never faster than its fastest segment plays in the source),
    its fastest ones at most 1.1 times (its frame-to-frame rotation then grows by at most a tenth where it
    is largest: no pop); static joints up to ``limit`` times."""
    S = np.maximum(np.diff(source, axis=0), 1e-12)                       # (K-1, J+1) source lengths
    v = sm.values
    dots = np.abs(np.einsum("kjc,kjc->kj", v[:-1], v[1:]))
    ang = 2.0 * np.arccos(np.clip(dots, -1.0, 1.0)) + _map_paths(sm.displacements, sm.displacement_counts)
    rp = (np.linalg.norm(np.diff(sm.root_values, axis=0), axis=-1)
          + _map_paths(sm.root_displacements, sm.root_displacement_counts))
    speed = np.concatenate([ang, rp[:, None]], axis=1) / S
    top = speed.max(axis=0)
    rel = np.where(top > 0, speed / np.where(top > 0, top, 1.0), 0.0)
    return np.clip(rel, 1.0 / limit, _FAST_FLOOR)


def _with_timing(sm: StaggeredMotion, dr: np.ndarray, joint_mask: np.ndarray, ease_ends: bool = False,
                 limit: float | None = None, op: str = "") -> StaggeredMotion:
    """Add refinement offsets ``dr (K, J)`` (exactly with ``limit=None``; else soft-clipped by
    :func:`saturate_offsets`, the knots noticeably limited recorded in ``metadata["timing_limits"]`` for
    :func:`timing_summary`; with ``ease_ends``, interior knots that would reach the clip's ends are eased,
    :func:`inside_ends`); the root translation follows the root rotation if joint 0 is selected (both are the
    root's timing)."""
    if not np.any(dr):
        return sm
    t = sm.pose_times
    moved = dr != 0
    ease = _eased if ease_ends else (lambda r, t, moved: r)
    asked = dr
    root_moves = bool(joint_mask[0] and np.any(asked[:, 0]))
    dr0 = asked[:, 0]
    extra = None
    if limit is not None:
        # the joints' rotations and the root translation (column J) in one call
        J = sm.num_joints
        knots = np.concatenate([t[:, None] + sm.refinements, (t + sm.root_refinements)[:, None]], axis=1)
        wanted = np.concatenate([dr, (dr0 if root_moves else np.zeros_like(dr0))[:, None]], axis=1)
        src = source_knot_times(sm)
        ok = src.shape == knots.shape
        kept = saturate_offsets(knots, wanted, limit, source_knots=src if ok else None,
                                floors=_segment_floors(sm, src, limit) if ok else None)
        dr, dr0 = kept[:, :J], kept[:, J]
        # per joint, the typical (mean) offset over the moved knots, asked and kept: a delay that is kept
        # through the clip and eased only over its last segments is not "limited"
        cols = np.flatnonzero(moved.any(axis=0))
        n = moved[:, cols].sum(axis=0)
        want = np.where(moved, np.abs(asked), 0.0)[:, cols].sum(axis=0) / n
        got = np.where(moved, np.abs(dr), 0.0)[:, cols].sum(axis=0) / n
        hit = want - got > np.maximum(_NOTICEABLE * want, 0.5 * sm.frame_time)
        if hit.any():
            names = sm.skeleton.names
            sign = np.sign(asked[np.argmax(moved, axis=0), np.arange(J)]) if op == "succession" else np.ones(J)
            rows = tuple({"op": op, "joint": names[c], "asked": float(sign[c] * w), "applied": float(g)}
                         for c, w, g in zip(cols[hit], want[hit], got[hit]))
            extra = {"timing_limits": tuple(sm.metadata.get("timing_limits") or ()) + rows}
    fields = dict(refinements=ease(sm.refinements + dr, t, moved))
    if root_moves:
        fields["root_refinements"] = ease((sm.root_refinements + dr0)[:, None], t, moved[:, :1])[:, 0]
    return _refresh(sm, extra=extra, **fields)


def _eased(r: np.ndarray, t: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """Refinements ``r (K, C)`` whose knots :func:`inside_ends` eases, the others exactly as given."""
    T = t[:, None] + r
    E = inside_ends(T, t, moved)
    return np.where(E != T, E - t[:, None], r)


def succession(sm: StaggeredMotion, root="LeftShoulder", s: float = 0.03, l: float = 2.0, *, joints=None,
               poses=None, ease_ends: bool = False, limit: float | None = TIMING_LIMIT) -> StaggeredMotion:
    """Succession timing (§5.2, after Neff & Fiume 2003): ``r̂[k, i] = r[k, i] + s d(i)^l``.

    By default the offsets ``s d(i)^l`` are saturated smoothly against the neighbouring knots
    (:func:`saturate_offsets` with ``limit``): at any slider value every joint's knots stay in time order
    and no segment plays more than ``limit`` times faster (no collapse, no pop), small offsets are kept
    exactly; the knots that were limited noticeably are recorded for :func:`timing_summary` (one plain
    sentence). ``limit=None`` is the paper's
    formula exactly (a large ``s`` can then bring a knot next to, or past, a neighbour's: the segment plays in
    a frame or two, and :func:`timing_warnings` says so). With ``ease_ends=True`` knots within half a pose
    spacing of the clip's first/last pose are eased (:func:`inside_ends`: the last pose stays the clip's last
    frame, its segment keeps >= 1/8 of the spacing; saturated knots never reach that zone).

    Parameters
    ----------
    root : str or int
        The user-selected joint; ``d(i)`` is the number of bones between it and joint ``i``.
    s : float
        Base timing offset, seconds per unit depth (negative: the extremities lead).
    l : float
        Non-linearity (> 0): 1 is Neff–Fiume's linear succession, larger is looser / cartoony.
    joints : list of joint names, optional
        Joints to stagger; default: ``root`` and its descendants (the limb below the chosen joint).
    poses : list of int, optional
        Poses to stagger; default all interior poses (the first and last poses anchor the clip ends).
    ease_ends : bool
        Ease knots near the clip's ends (:func:`inside_ends`) instead of the exact formula there.
    limit : float > 1 or None
        Largest speed-up of any segment of a joint's curve (default :data:`TIMING_LIMIT`); None: raw offsets.
    """
    _check(sm)
    limit = _check_limit(limit)
    s, l = _finite(s, "s"), _finite(l, "l")
    if l <= 0:
        raise ValueError(f"l must be > 0, got {l}")
    if not isinstance(root, (str, int, np.integer)) or isinstance(root, (bool, np.bool_)):
        raise ValueError(f"root must be a joint name or index, got {root!r}")
    try:
        r = sm.skeleton.index(root) if isinstance(root, str) else int(root)
    except KeyError as e:
        raise ValueError(f"root: {e.args[0]}") from None
    if not 0 <= r < sm.num_joints:
        raise ValueError(f"root: index {root} outside [0, {sm.num_joints})")
    d = sm.skeleton.tree_distance(r).astype(float)
    sub = np.zeros(sm.num_joints, bool)
    sub[r] = True
    for j in range(r + 1, sm.num_joints):   # parents precede children
        sub[j] = sub[sm.skeleton.parents[j]]
    jm = _joint_mask(sm, joints, default=sub)
    pm = _pose_mask(sm, poses, interior_default=True)
    dr = np.where(pm[:, None] & jm[None, :], s * d[None, :] ** l, 0.0)
    return _with_timing(sm, dr, jm, bool(ease_ends), limit, "succession")


#: Largest random timing offset (seconds): an hour, far beyond any take's pose spacing; numpy's uniform
#: overflows near 1e308.
MAX_TAU = 3600.0


def random_timing(sm: StaggeredMotion, joints=None, tau: float = 0.05, seed: int = 0, *,
                  poses=None, ease_ends: bool = False, limit: float | None = TIMING_LIMIT) -> StaggeredMotion:
    """Random timing offsets (§5.2): ``r̂[k, i] = r[k, i] + U(-τ, τ)`` for the chosen joints (``ease_ends``
    and ``limit``: as in :func:`succession`; by default the offsets are saturated against the neighbouring
    poses, ``limit=None`` adds them exactly).

    The offsets are drawn for the whole ``(K, J)`` table from ``numpy.random.default_rng(seed)`` and then
    masked, so a given seed gives each (pose, joint) the same offset whatever subset is selected.

    Parameters
    ----------
    joints : list of joint names, optional (default all joints)
    tau : float
        Bound of the offsets, seconds (>= 0).
    seed : int
    poses : list of int, optional; default all interior poses.
    ease_ends : bool
        Ease knots near the clip's ends (:func:`inside_ends`) instead of the exact offsets there.
    limit : float > 1 or None
        Largest speed-up of any segment of a joint's curve (default :data:`TIMING_LIMIT`); None: raw offsets.
    """
    _check(sm)
    limit = _check_limit(limit)
    tau = _finite(tau, "tau")
    if not 0 <= tau <= MAX_TAU:  # numpy's uniform(-1e308, 1e308) overflows
        raise ValueError(f"tau must be in [0, {MAX_TAU:g}] seconds, got {tau}")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, (bool, np.bool_)) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    jm = _joint_mask(sm, joints)
    pm = _pose_mask(sm, poses, interior_default=True)
    u = np.random.default_rng(int(seed)).uniform(-tau, tau, size=(sm.num_poses, sm.num_joints))
    return _with_timing(sm, np.where(pm[:, None] & jm[None, :], u, 0.0), jm, bool(ease_ends), limit, "random_timing")


def retime(sm: StaggeredMotion, pose_times) -> StaggeredMotion:
    """Retime staggered poses as units (§5.2): new ``t_k``; refinements, splines and displacement maps are
    relative to it and follow.

    Parameters
    ----------
    pose_times : list of K seconds, or dict {pose index: seconds} (JSON keys may be strings)
        New times; must stay strictly increasing.
    """
    _check(sm)
    t = np.array(sm.pose_times)
    if isinstance(pose_times, dict):
        for k, v in pose_times.items():
            t[_pose_index(sm, int(k), "pose_times key")] = _finite(v, f"pose_times[{k}]")
    else:
        new = np.asarray(pose_times, dtype=float).reshape(-1)
        if new.shape != t.shape or not np.all(np.isfinite(new)):
            raise ValueError(f"pose_times must hold {t.size} finite seconds, got {np.shape(pose_times)}")
        t = new
    if not np.all(np.diff(t) > 0):
        raise ValueError("pose_times must be strictly increasing")
    if np.array_equal(t, sm.pose_times):
        return sm
    return _refresh(sm, pose_times=t)


# -- pose insertion and deletion (§5.1, last paragraph) ------------------------------------------------------

def _split_rotation_bezier(c0, c1, c2, c3, u):
    """de Casteljau split by slerp at ``u``: control polygons of the left and right parts."""
    a, b, c = slerp(c0, c1, u), slerp(c1, c2, u), slerp(c2, c3, u)
    d, e = slerp(a, b, u), slerp(b, c, u)
    return (a, d), (e, c)


def insert_pose(sm: StaggeredMotion, t: float) -> StaggeredMotion:
    """Insert a pose at time ``t`` (seconds, strictly between two poses) without changing the motion.

    Each control variable gets its new knot at ``t`` (zero refinement) when its refined knots of the two
    neighbouring poses straddle ``t``; otherwise (timing edits moved them past ``t``, e.g. a succession down
    a long limb) at the same relative place in its own segment, ``T[k] + u (T[k+1] - T[k])`` with
    ``u = (t - t_k) / (t_{k+1} - t_k)`` (a refinement that follows the neighbours' staggering). The knot takes
    the current value there, the editing knot the current value at ``t``; each segment is split with the de
    Casteljau construction and the two new displacement maps are re-measured so the evaluated motion is
    preserved on their sample grids ("we update the displacement map to preserve the global transition
    values", §5.1). Raises ``ValueError`` where a joint's knots of the two poses are out of order.
    """
    _check(sm)
    t = _finite(t, "t")
    pt = sm.pose_times
    if not pt[0] < t < pt[-1] or np.any(np.isclose(pt, t, rtol=0, atol=1e-9)):
        raise ValueError(f"t must lie strictly between two poses in ({pt[0]}, {pt[-1]}), got {t}")
    k = int(np.searchsorted(pt, t)) - 1      # new pose goes between k and k + 1
    K, J = sm.num_poses, sm.num_joints
    T = knot_times(sm)
    bad = ~(T[k] < T[k + 1])
    if bad.any():
        raise ValueError(f"cannot insert a pose at t = {t} s: the refined knots of poses {k} and {k + 1} are out of "
                         f"order for joints {[sm.skeleton.names[i] for i in np.flatnonzero(bad)]}")
    rk = sm.pose_times + sm.root_refinements
    if not rk[k] < rk[k + 1]:
        raise ValueError(f"cannot insert a pose at t = {t} s: the root translation knots of poses {k} and {k + 1} "
                         "are out of order")
    u_pose = (t - pt[k]) / (pt[k + 1] - pt[k])
    T_new = np.where((T[k] < t) & (t < T[k + 1]), t, T[k] + u_pose * (T[k + 1] - T[k]))     # (J,)
    rk_new = t if rk[k] < t < rk[k + 1] else rk[k] + u_pose * (rk[k + 1] - rk[k])
    cols = np.arange(J)
    v_t = _eval_rotations(sm, T_new, cols)                  # the new extreme values (at the new knots)
    v0_t = _eval_rotations(sm, np.full(J, t), cols)         # the pose at t (editing knots)
    p_t = _eval_root(sm, np.array([rk_new]))[0]
    u = (T_new - T[k]) / (T[k + 1] - T[k])                  # (J,) where each joint's spline is split
    tg = sm.tangents[k]
    (l1, l2), (r1, r2) = _split_rotation_bezier(sm.values[k], tg[:, 0], tg[:, 1], sm.values[k + 1], u)
    values = np.insert(sm.values, k + 1, v_t, axis=0)
    tangents = np.concatenate([sm.tangents[:k], np.stack([l1, l2], 1)[None], np.stack([r1, r2], 1)[None],
                               sm.tangents[k + 1:]])
    refinements = np.insert(sm.refinements, k + 1, T_new - t, axis=0)
    pose_times = np.insert(sm.pose_times, k + 1, t)
    knots = pose_times[:, None] + refinements
    seg = np.repeat([k, k + 1], J)
    joint = np.tile(cols, 2)
    counts = _counts_for(knots[seg, joint], knots[seg + 1, joint], sm.frame_time)
    rows = _measure_rotations(values, tangents, knots, seg, joint, counts,
                              lambda tt, jp, pair, tn: _eval_rotations(sm, tt, jp))
    disp = np.insert(sm.displacements, k + 1, 0.0, axis=0)
    dcounts = np.insert(sm.displacement_counts, k + 1, 2, axis=0)
    dcounts[seg, joint] = counts
    disp = _put_rows(disp, (seg, joint), rows)

    ua = (rk_new - rk[k]) / (rk[k + 1] - rk[k])
    p0, (p1, p2), p3 = sm.root_values[k], sm.root_tangents[k], sm.root_values[k + 1]
    a, b, c = p0 + ua * (p1 - p0), p1 + ua * (p2 - p1), p2 + ua * (p3 - p2)
    d, e = a + ua * (b - a), b + ua * (c - b)
    root_values = np.insert(sm.root_values, k + 1, p_t, axis=0)
    root_tangents = np.concatenate([sm.root_tangents[:k], [[a, d]], [[e, c]], sm.root_tangents[k + 1:]])
    root_ref = np.insert(sm.root_refinements, k + 1, rk_new - t)
    rknots = pose_times + root_ref
    rseg = np.array([k, k + 1])
    rcounts = _counts_for(rknots[rseg], rknots[rseg + 1], sm.frame_time)
    rrows = _measure_root(root_values, root_tangents, rknots, rseg, rcounts,
                          lambda tt, pair, tn: _eval_root(sm, tt))
    rd = _put_rows(np.insert(sm.root_displacements, k + 1, 0.0, axis=0), (rseg,), rrows)
    rdc = np.insert(sm.root_displacement_counts, k + 1, 2)
    rdc[rseg] = rcounts
    prob = np.insert(sm.pose_probability, k + 1, 0.0)
    tt = sm.translation_times
    if tt is not None:           # animated translations keep their source time at the new knot
        tt = np.insert(tt, k + 1, translation_source_times(sm, [rk_new])[0])
    src = source_knot_times(sm)          # the new knots' source times: through each variable's warp
    new_src = [warp_times(sm, [x], c, inverse=True)[0] for c, x in enumerate(np.append(T_new, rk_new))]
    return _refresh(sm, source_knots=np.insert(src, k + 1, new_src, axis=0), translation_times=tt, pose_times=pose_times, refinements=refinements, values=values, tangents=tangents,
                    displacements=disp, displacement_counts=dcounts, root_values=root_values,
                    root_refinements=root_ref, root_tangents=root_tangents, root_displacements=rd,
                    root_displacement_counts=rdc, editing_knots=np.insert(sm.editing_knots, k + 1, v0_t, axis=0),
                    pose_probability=prob)


def delete_pose(sm: StaggeredMotion, k: int) -> StaggeredMotion:
    """Delete interior pose ``k`` without changing the motion: the two segments around it merge into one
    whose Bézier keeps the outer handles, and whose displacement map is re-measured from the current motion
    (§5.1, last paragraph). The first and last poses cannot be deleted (they bound the clip)."""
    _check(sm)
    k = _pose_index(sm, k)
    K, J = sm.num_poses, sm.num_joints
    if k in (0, K - 1):
        raise ValueError(f"k: the first and last poses bound the motion and cannot be deleted (got {k})")
    if K <= 2:
        raise ValueError("cannot delete a pose of a 2-pose motion")
    cols = np.arange(J)
    values = np.delete(sm.values, k, axis=0)
    tangents = np.delete(sm.tangents, k, axis=0)
    tangents[k - 1, :, 0] = sm.tangents[k - 1, :, 0]
    tangents[k - 1, :, 1] = sm.tangents[k, :, 1]
    refinements = np.delete(sm.refinements, k, axis=0)
    pose_times = np.delete(sm.pose_times, k)
    knots = np.maximum.accumulate(pose_times[:, None] + refinements, axis=0)
    seg = np.full(J, k - 1)
    counts = _counts_for(knots[seg, cols], knots[seg + 1, cols], sm.frame_time)
    rows = _measure_rotations(values, tangents, knots, seg, cols, counts,
                              lambda tt, jp, pair, tn: _eval_rotations(sm, tt, jp))
    disp = _put_rows(np.delete(sm.displacements, k, axis=0), (seg, cols), rows)
    dcounts = np.delete(sm.displacement_counts, k, axis=0)
    dcounts[k - 1] = counts

    root_values = np.delete(sm.root_values, k, axis=0)
    root_tangents = np.delete(sm.root_tangents, k, axis=0)
    root_tangents[k - 1] = [sm.root_tangents[k - 1, 0], sm.root_tangents[k, 1]]
    root_ref = np.delete(sm.root_refinements, k)
    rknots = np.maximum.accumulate(pose_times + root_ref)
    rseg = np.array([k - 1])
    rcounts = _counts_for(rknots[rseg], rknots[rseg + 1], sm.frame_time)
    rrows = _measure_root(root_values, root_tangents, rknots, rseg, rcounts,
                          lambda tt, pair, tn: _eval_root(sm, tt))
    rd = _put_rows(np.delete(sm.root_displacements, k, axis=0), (rseg,), rrows)
    rdc = np.delete(sm.root_displacement_counts, k)
    rdc[rseg] = rcounts
    tt = None if sm.translation_times is None else np.delete(sm.translation_times, k)
    return _refresh(sm, source_knots=np.delete(source_knot_times(sm), k, axis=0), pose_times=pose_times, refinements=refinements, values=values, tangents=tangents,
                    displacements=disp, displacement_counts=dcounts, root_values=root_values,
                    root_refinements=root_ref, root_tangents=root_tangents, root_displacements=rd,
                    root_displacement_counts=rdc, editing_knots=np.delete(sm.editing_knots, k, axis=0),
                    translation_times=tt,
                    pose_probability=np.delete(sm.pose_probability, k))
