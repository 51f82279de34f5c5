"""What the editors' views show, computed from a session and its model: the numbers behind every plot and
the ranges of the controls that depend on the clip, so ``widgets/`` only draws (no maths, no technique import).

Each function takes the session (and the model it updates or reads) and returns plain arrays for the
``stagger_nb.plotting`` figures; those that set model traits do so as a load (``model.loading()``), never as
a user's edit.
"""
from __future__ import annotations

import re

import numpy as np

from ...core.kinematics import skeleton_height
from ...core.motion import Motion
from ..session import joint_rotation_degrees

__all__ = ["ik_effectors", "stagger_state", "probability_view", "joint_curves_view", "place_ik_target",
           "warp_view", "warp_tables_to_warm", "warp_tables_first_changes", "warp_replays_first_changes"]

_TOE = re.compile(r"toe|heel", re.IGNORECASE)   # end effectors the IK menu leaves out (the foot above is there)


def ik_effectors(skeleton) -> list:
    """Names of the end effectors IK can move: every leaf of ``skeleton`` (``staggered.end_effectors``) but
    toes and heels (their foot is there)."""
    from ... import staggered
    names = list(skeleton.names)
    return [names[j] for j in staggered.end_effectors(skeleton) if not _TOE.search(names[j])]


def stagger_state(model, session):
    """``(sm, full)``: the last staggered state of the session's replay and the source's extraction; sets
    ``model.pose_times`` (the current poses) and ``model.candidate_times`` (the extracted ones) from them."""
    sm, full = session.staggered(), session.extraction()
    with model.loading(), model.hold_trait_notifications():
        model.candidate_times = [float(t) for t in full.pose_times]
        model.pose_times = [float(t) for t in sm.pose_times]
    return sm, full


def probability_view(session, sm, full) -> dict:
    """The pose-probability plot's data (Coleman et al. 2008, §4.1): ``times``/``probability`` (the signal over
    the source's frames, None when the extraction kept none), ``candidate_times``/``candidate_values`` (every
    extracted pose) and ``kept_times``/``kept_values`` (the poses after the cull; P interpolated at their
    times, which retimes may have moved off a frame)."""
    m = session.source
    prob = full.metadata.get("probability")
    times = None if prob is None else np.arange(m.num_frames) * m.frame_time
    kept = np.asarray(sm.pose_times, dtype=float)
    kept_values = np.interp(kept, times, prob) if prob is not None else sm.pose_probability
    return {"times": times, "probability": prob, "candidate_times": np.asarray(full.pose_times),
            "candidate_values": full.pose_probability, "kept_times": kept, "kept_values": kept_values}


def joint_curves_view(session, edited: Motion, joint: str, sm=None, source_degrees=None) -> dict:
    """One joint's curves: ``times`` and ``degrees`` (its rotation vector in the edited motion, (F, 3)),
    ``source_times`` and ``source_degrees`` (the source's; pass ``source_degrees`` to reuse them), and with a
    staggered state ``sm`` the ``pose_times`` t_k and this joint's refined ``knot_times`` t_k + r_kj (§4.2)."""
    m = session.source
    j = m.skeleton.index(joint)
    out = {"times": edited.times, "degrees": joint_rotation_degrees(edited, j), "source_times": m.times,
           "source_degrees": joint_rotation_degrees(m, j) if source_degrees is None else source_degrees,
           "pose_times": (), "knot_times": ()}
    if sm is not None:
        kept = np.asarray(sm.pose_times, dtype=float)
        out["pose_times"], out["knot_times"] = kept, kept + np.asarray(sm.refinements)[:, j]
    return out


def place_ik_target(model, session, edited: Motion | None = None) -> None:
    """Put the IK target sliders at the effector's place at the selected pose, without recording an edit (only
    when that pose and effector hold no IK edit yet), and let ``model.ik_range`` reach +- the pose's extent
    around it. Forward kinematics of the edited motion is computed once per motion (the session's cache)."""
    if not model.ik_joint or not model.pose_times or model.ik_entry() is not None:
        return
    edited = session.edited() if edited is None else edited
    pos = session.positions(edited)
    f = min(model.pose_frame(min(model.pose, len(model.pose_times) - 1)), len(pos) - 1)
    p = pos[f, edited.skeleton.index(model.ik_joint)]
    extent = float(np.ptp(pos[f], axis=0).max()) or 1.0
    model.show_ik_target(p, extent)


def reach_ik_targets(model, session) -> None:
    """Let the IK target sliders reach the source clip's box (every joint, every frame) +- the skeleton's height
    (``model.reach_ik``; the step near 1/200 of it: 1 cm on a 170 cm body), before the sliders are shown (the reach
    then need not grow when an effector or a pose is chosen). The height, not a frame's extent: a Bandai rig's
    still floor root makes a frame's extent metres wide."""
    pos = session.positions(session.source)
    if not pos.size:
        return
    model.reach_ik(pos.min(axis=(0, 1)), pos.max(axis=(0, 1)), skeleton_height(session.source) or 1.0)


def warp_view(session) -> dict:
    """The warp plot's data (Hsu et al. 2007, Fig. 5): ``out_times`` (seconds of each output frame), ``warp``
    (input seconds shown at each, from the last warp op; the identity without one) and ``speed`` (its
    derivative, 1 = the original speed)."""
    from ... import timewarp
    edited = session.edited()
    ft = edited.frame_time
    warp = None
    names = [op.name for op in session.typed_ops]
    for i in range(len(names) - 1, -1, -1):
        if names[i] in ("guided_warp", "linear_warp", "guide_poses"):
            warp = session.warp_curve(i)
            break
    if warp is None:
        warp = edited.times
    return {"out_times": np.arange(len(warp)) * ft, "warp": warp, "speed": timewarp.warp_speed(warp, ft)}


def warp_tables_to_warm(binding, max_skip: int) -> dict | None:
    """The ``guided_warp`` op whose kNN tables a WarpEditor warms (``Session.warm(("warp_tables", [op]))``):
    the current warp at the skip slider's largest value ``max_skip`` (every smaller skip is sliced from its
    tables), or with no warp yet a compression to 0.9 of the source's duration (the first duration move's).
    None for a linear warp and for clips long enough to use approximate kNN (their tables are not sliced)."""
    from ...timewarp.guided import AUTO_APPROX_PAIRS
    session, model = binding.session, binding.model
    if session.source.num_frames ** 2 > AUTO_APPROX_PAIRS:
        return None
    ops = [o for o in binding.to_ops(model.params()) if o["op"] == "guided_warp"]
    if not ops and model.mode == "guided":
        ops = [o for o in binding.to_ops(dict(model.params(), reference="self", free_length=False,
                                              duration=0.9 * session.source.duration))
               if o["op"] == "guided_warp"]
    if not ops:
        return None
    return dict(ops[-1], skip=max(int(max_skip), int(ops[-1].get("skip", 8))))


def warp_tables_first_changes(binding, max_skip: int) -> list:
    """The ``guided_warp`` ops whose kNN tables a WarpEditor warms on open (one ``Session.warm(("warp_tables",
    ops))`` job, in this order) so that each first change replays only a DP (issue 26: the first free-length
    toggle took 0.96-4.5 s, backward 0.78-2.0 s, the first duration key 1.1-2.3 s CPU on CMU 01_01's 2,751
    frames): :func:`warp_tables_to_warm`'s op (the current warp, or the first compression), then the same op
    with free length toggled, with backward toggled, and with no warp yet a lengthening (1.1 x the source's
    duration: an expansion upsamples, another table). Ops that choose the same tables are listed once; ``[]``
    where :func:`warp_tables_to_warm` gives None."""
    from ..motion_runners import warp_table_key
    base = warp_tables_to_warm(binding, max_skip)
    if base is None:
        return []
    session, model = binding.session, binding.model
    D = session.source.duration
    fixed = {k: v for k, v in base.items() if k not in ("free_length", "duration")}
    free = dict(fixed, free_length=True)                     # free length chooses the duration itself
    timed = dict(fixed, free_length=False, duration=base.get("duration", model.duration))
    # backward and the lengthening at the skip the first toggle replays at: their tables may be approximate
    # kNN (an upsampled search), which a larger skip's tables do not serve (CMU 01_01: both rebuilt, 1.6-3.3 s)
    now = int(model.skip)
    ops = [base, timed if base.get("free_length") else free,
           dict(base if base.get("free_length") else dict(timed, duration=model.duration), skip=now,
                backward=not base.get("backward", False)),   # the toggle keeps the model's duration (no warp yet: D)
           dict(base, skip=now, backward=not base.get("backward", False))]   # ... or after the first duration key
    if not any(o["op"] == "guided_warp" for o in session.ops):
        ops.append(dict(fixed, skip=now, free_length=False, duration=1.1 * D))
    out, seen = [], set()
    for op in ops:
        try:
            key = warp_table_key(session.source, op) + (op["skip"],)
        except ValueError:
            continue   # an op the session cannot search: computed on demand and refused there
        if key not in seen:
            seen.add(key)
            out.append(op)
    return out


def warp_replays_first_changes(binding) -> list:
    """The op lists whose replay a WarpEditor warms after its tables (``Session.warm(("replay", lists))``): the
    session as the first backward toggle would leave it (``binding.ops_for``). With its tables warm that toggle
    still runs a DP, and at the clip's own length the search is upsampled (2x the frames, the same length has no
    other warp, §3.1) below the coarse-to-fine threshold: the exact DP over a band ~2,400 frames wide, 0.77 s CPU
    on CMU 01_01 (issue 26: <= 300 ms); replayed in the background it is a cache hit. ``[]`` where the toggle is
    inert (a linear warp, the staggered poses retimed) or changes no op."""
    model = binding.model
    if model.mode != "guided" or model.target == "poses":
        return []
    ops = binding.ops_for(backward=not model.backward)
    return [] if ops == binding.session.ops else [ops]
