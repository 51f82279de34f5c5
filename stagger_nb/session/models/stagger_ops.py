"""The StaggerEditor's pure ``params <-> ops`` functions (Coleman et al. 2008): a :meth:`StaggerModel.params
<stagger_nb.session.models.StaggerModel.params>` dict to the editor's ops in canonical order and back, pose edits
written as targets ``base ⊕ nudge`` where the pose's value is known (§5.1, Fig. 6a/6b)."""
from __future__ import annotations

import copy

import numpy as np

from ...core.rotations import quat_conj, quat_mul, quat_to_rotvec, rotvec_to_quat

__all__ = ["STAGGER_OPS", "stagger_params_to_ops", "stagger_ops_to_params"]

STAGGER_OPS = ("cull", "edit_pose", "retime", "ik_pose", "exaggerate", "succession", "random_timing", "refine",
               "keep_contacts")
"""Ops the StaggerEditor writes, in the order it inserts them (staggered ops first, the constraint last)."""


def _names_note(names, field, value, known) -> str | None:
    if known and value not in known:
        return (f"{field}: the session names joint {value!r}, which this skeleton does not have; the op is kept "
                "unchanged")
    return None


def _target_of(base, nudge) -> list:
    """``base ⊕ nudge``: the quaternion (x, y, z, w) reached from ``base`` by the rotation vector ``nudge``
    (degrees), applied in the joint's local frame (``base * exp(nudge / 2)``)."""
    return [float(x) for x in quat_mul(base, rotvec_to_quat(np.radians(np.asarray(nudge, dtype=float))))]


def _nudge_of(base, target) -> list:
    """The nudge (rotation vector, degrees) taking ``base`` to ``target`` (``base⁻¹ target``), rounded to
    1e-9 degrees so a nudge written as a target reads back as itself."""
    r = np.degrees(quat_to_rotvec(quat_mul(quat_conj(np.asarray(base, dtype=float)), target)))
    return [round(float(c), 9) + 0.0 for c in r]


def stagger_params_to_ops(p: dict, bases: dict | None = None) -> list:
    """The StaggerEditor's ops for parameters ``p`` (a :meth:`StaggerModel.params` dict), in canonical order.

    ``bases`` (``StaggerModel.edit_bases``: ``{pose: {joint: [x, y, z, w]}}``) turns the nudges of those joints
    into ``targets`` (``base ⊕ nudge``, the value the user sees plus the nudge), so ``edit_mode`` chooses the
    knot that takes that value: the true pose at ``t_k`` (staggered, Fig. 6a) or the extreme value (Fig. 6b).
    Without a base a nudge is written as ``deltas`` (the same change to both knots: the modes then agree).

    ``propagate`` adds ``"propagate": true`` (and ``sigma`` when not 0) to the pose edits and IK targets, ``region``
    a ``"falloff": {"frame": region_frame, "sigma": ...}`` to the succession and the random timing (issue 24).

    Identity values write no op (percent = 100, s = 0, τ = 0, w_r = 0, an all-zero nudge); ``keep_contacts``
    writes ``{"op": "keep_contacts"}`` when on and any other staggered op is written. Optional fields are
    written only when they differ from the op's default (so the op list stays short and readable).
    """
    ops = []
    if p["cull_by"] == "percent" and p["percent"] < 100.0:
        ops.append({"op": "cull", "percent": float(p["percent"])})
    elif p["cull_by"] == "count" and p["count"] > 0:
        ops.append({"op": "cull", "count": int(p["count"])})
    elif p["cull_by"] == "keep" and p["keep"]:
        ops.append({"op": "cull", "keep": sorted(int(k) for k in p["keep"])})
    spread = {}
    if p.get("propagate"):      # the pose edits spread to every similar pose (Dean et al. 2018, §3.3)
        spread = {"propagate": True, **({"sigma": float(p["sigma"])} if p.get("sigma") else {})}
    region = {}
    if p.get("region"):         # the timing edits inside the region only
        region = {"falloff": {"frame": int(p["region_frame"]), "sigma": float(p["sigma"]) if p.get("sigma") else None}}
    for k in sorted(p["pose_edits"]):
        nudges = {j: [float(x) for x in v] for j, v in p["pose_edits"][k].items() if any(v)}
        known = (bases or {}).get(k, {})
        targets = {j: _target_of(known[j], v) for j, v in nudges.items() if j in known}
        deltas = {j: v for j, v in nudges.items() if j not in known}
        for field, value in (("targets", targets), ("deltas", deltas)):  # one op per kind (exactly one each)
            if value:
                op = {"op": "edit_pose", "pose": int(k), field: value}
                if p["edit_mode"] != "staggered":
                    op["mode"] = p["edit_mode"]
                ops.append({**op, **spread})
    for k in sorted(p["retimes"]):
        ops.append({"op": "retime", "pose": int(k), "time": float(p["retimes"][k])})
    for e in p["ik_targets"]:
        ops.append({"op": "ik_pose", "pose": int(e["pose"]), "joint": e["joint"],
                    "target": [float(x) for x in e["target"]], **spread})
    if p["w_r"] != 0.0:
        op = {"op": "exaggerate", "w_r": float(p["w_r"])}
        if p["w_r_reference"] != "previous":
            op["reference"] = p["w_r_reference"]
        ops.append(op)
    if p["s"] != 0.0:
        op = {"op": "succession", "root": p["root"], "s": float(p["s"]), "l": float(p["l"])}
        if p["joints"]:
            op["joints"] = list(p["joints"])
        ops.append({**op, **region})
    if p["tau"] > 0.0:
        op = {"op": "random_timing", "tau": float(p["tau"]), "seed": int(p["seed"])}
        if p["tau_joints"]:
            op["joints"] = list(p["tau_joints"])
        ops.append({**op, **region})
    for e in p.get("refines", ()):
        ops.append({"op": "refine", "pose": int(e["pose"]), "joint": e["joint"], "time": float(e["time"])})
    if p["keep_contacts"] and ops:
        ops.append({"op": "keep_contacts"})
    return ops


def stagger_ops_to_params(ops: list, base: dict, joint_names=(), bases: dict | None = None) -> tuple[dict, list]:
    """Parameters shown by a StaggerEditor for the session ``ops``: ``base`` (the model's current parameters)
    updated from the owned ops (the last of each singleton op wins). Returns ``(params, notes)``; ``notes`` are
    plain sentences (an op naming a joint this skeleton does not have: that field keeps its ``base`` value).
    ``edit_pose`` targets read back as nudges from ``bases`` (as in :func:`stagger_params_to_ops`)."""
    p = copy.deepcopy(base)
    notes: list = []
    known = set(joint_names)
    by = {o["op"]: o for o in ops if o["op"] in STAGGER_OPS}
    c = by.get("cull")
    p["percent"], p["count"], p["keep"] = 100.0, 0, []   # the fields of the other cull modes: their identity
    if c is None:
        pass
    elif c.get("percent") is not None:
        p["cull_by"], p["percent"] = "percent", float(c["percent"])
    elif c.get("count") is not None:
        p["cull_by"], p["count"] = "count", int(c["count"])
    elif c.get("keep") is not None:
        p["cull_by"], p["keep"] = "keep", [int(k) for k in c["keep"]]
    sc = by.get("succession")
    p["s"] = 0.0 if sc is None else float(sc["s"])
    if sc is not None:
        p["l"] = float(sc.get("l", 1.0))
        note = _names_note(joint_names, "succession.root", sc["root"], known)
        if note:
            notes.append(note)
        else:
            p["root"] = sc["root"]
        bad = [j for j in (sc.get("joints") or []) if known and j not in known]
        if bad:
            notes.append(f"succession.joints: {', '.join(map(repr, bad))} not in this skeleton; the op is kept "
                         "unchanged")
        else:
            p["joints"] = list(sc.get("joints") or [])
    rt = by.get("random_timing")
    p["tau"] = 0.0 if rt is None else float(rt["tau"])
    if rt is not None:
        p["seed"] = int(rt.get("seed", 0))
        bad = [j for j in (rt.get("joints") or []) if known and j not in known]
        if bad:
            notes.append(f"random_timing.joints: {', '.join(map(repr, bad))} not in this skeleton; the op is kept "
                         f"unchanged")
        else:
            p["tau_joints"] = list(rt.get("joints") or [])
    ex = by.get("exaggerate")
    p["w_r"] = 0.0 if ex is None else float(ex["w_r"])
    if ex is not None:
        p["w_r_reference"] = ex.get("reference", "previous")
    edits: dict = {}
    mode = None
    for o in ops:
        if o["op"] == "edit_pose":
            k = int(o["pose"])
            mine = edits.setdefault(k, {})
            mine.update({j: [float(x) for x in v] for j, v in (o.get("deltas") or {}).items()})
            kb = (bases or {}).get(k, {})
            for j, q in (o.get("targets") or {}).items():
                if j in kb:
                    mine[j] = _nudge_of(kb[j], q)
                else:
                    notes.append(f"edit_pose.targets: no starting value of joint {j!r} at pose {k} is known; "
                                 "the op is kept unchanged")
            if not mine:
                del edits[k]
            mode = o.get("mode", "staggered")
            for field in ("deltas", "targets"):
                for j in o.get(field) or {}:
                    if known and j not in known:
                        notes.append(f"edit_pose.{field}: joint {j!r} is not in this skeleton; the op is kept "
                                     "unchanged")
    p["pose_edits"] = edits
    if mode is not None:
        p["edit_mode"] = mode
    p["retimes"] = {int(o["pose"]): float(o["time"]) for o in ops if o["op"] == "retime"}
    p["ik_targets"] = [{"pose": int(o["pose"]), "joint": o["joint"], "target": [float(x) for x in o["target"]]}
                       for o in ops if o["op"] == "ik_pose"]
    p["refines"] = [{"pose": int(o["pose"]), "joint": o["joint"], "time": float(o["time"])}
                    for o in ops if o["op"] == "refine"]
    edits = [o for o in ops if o["op"] in ("edit_pose", "ik_pose")]
    if edits:
        p["propagate"] = bool(edits[-1].get("propagate", False))
        if p["propagate"]:
            p["sigma"] = float(edits[-1].get("sigma") or 0.0)
    timed = [o for o in ops if o["op"] in ("succession", "random_timing")]
    if timed:
        r = timed[-1].get("falloff")
        p["region"] = r is not None
        if r is not None:
            p["region_frame"] = int(r["frame"])
            p["sigma"] = float(r.get("sigma") or 0.0)
    others = [o for o in ops if o["op"] in STAGGER_OPS and o["op"] != "keep_contacts"]
    if "keep_contacts" in by:
        p["keep_contacts"] = True
    elif others:
        p["keep_contacts"] = False
    return p, notes
