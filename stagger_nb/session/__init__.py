"""Edit sessions: a source motion plus an ordered list of JSON-serialisable operations.

An *op* is a plain dict such as ``{"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 2.0}``.
Replaying the ops in order on the source motion gives the edited motion; this is what makes a notebook's
edits reproducible (DESIGN.md, "session"). The state flowing through the ops is either a
:class:`~stagger_nb.core.Motion` or a staggered-pose representation (``staggered.StaggeredMotion``):

- staggered ops (``extract``, ``cull``, ``succession``, ``random_timing``, ``exaggerate``, ``edit_pose``)
  need a staggered representation; a Motion is extracted first (Coleman et al. 2008, §4), and that
  extraction, the expensive head, is cached per motion;
- motion ops (``edit_frame``, ``propagate``, ``guided_warp``, ``linear_warp``, ``resample``) need a Motion;
  a staggered state is evaluated first (§3).

Every prefix of the op list is memoised, so changing the last op (a slider move) replays only the tail.

Ops are validated on the way in (``add``/``set_ops``) and when a session file is loaded: an unknown op,
an unknown or missing field or a wrongly typed value raises ``ValueError`` naming the field
(e.g. ``ops[2].s``). Session files are JSON, never pickle; nothing in them is evaluated.

This module does not import ipywidgets; the widgets build on it.
"""
from __future__ import annotations

import copy
import hashlib
import json
import math
import os
import re
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_mul, quat_to_rotvec, rotvec_to_quat
from ..core.skeleton import Skeleton
from ..io._common import atomic_write_bytes
from ..io.bvh import read_bvh, write_bvh

__all__ = ["Session", "OpSpec", "OP_REGISTRY", "register_op", "validate_op", "apply_pose_deltas",
           "joint_rotation_degrees",
           "SESSION_FORMAT", "SESSION_VERSION"]

SESSION_FORMAT = "stagger_nb.session"
SESSION_VERSION = 1
_MEMO_SIZE = 48          # memoised op-list prefixes kept per session (a slider sweep touches a handful)
_EXTRACT_CACHE_SIZE = 4  # cached staggered extractions (one per distinct input motion)
_BASIS_CACHE_SIZE = 64   # magic-wand eigenbases: every position of a sigma slider (F x 50 floats each)
_CULL_CACHE_SIZE = 40    # cached cull results: every position of a 2.5 %-step slider on one extraction


# --------------------------------------------------------------------------------------------------
# field validators: each takes (value, field_name) and returns the normalised JSON value or raises
# --------------------------------------------------------------------------------------------------
def _fail(field: str, expected: str, value) -> None:
    raise ValueError(f"{field}: expected {expected}, got {value!r}")


def _number(value, field):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(field, "a finite number", value)
    try:
        v = float(value)  # an int beyond the float range (e.g. 10**400 in a file) overflows here
    except OverflowError:
        v = math.inf
    if not math.isfinite(v):
        _fail(field, "a finite number", value)
    return v


def _choice(*options):
    def f(value, field):
        if value not in options:
            _fail(field, " or ".join(repr(o) for o in options), value)
        return value
    return f


def _int_list(value, field):
    if not isinstance(value, (list, tuple)):
        _fail(field, "a list of integers", value)
    return [_nonneg_int(v, f"{field}[{i}]") for i, v in enumerate(value)]


def _pose_reference(value, field):
    if value in ("previous", "next", "mean"):
        return value
    if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
        return value
    _fail(field, '"previous", "next", "mean" or a pose index', value)


def _int(value, field):
    if isinstance(value, bool) or not isinstance(value, int):
        if isinstance(value, float) and value.is_integer():
            return int(value)
        _fail(field, "an integer", value)
    return int(value)


def _checked(base, ok, expected: str):
    """A validator: ``base`` (type check and conversion), then the range test ``ok``."""
    def f(value, field):
        v = base(value, field)
        if not ok(v):
            _fail(field, expected, value)
        return v
    return f


_nonneg = _checked(_number, lambda v: v >= 0, "a number >= 0")
_positive = _checked(_number, lambda v: v > 0, "a number > 0")
_percent = _checked(_number, lambda v: 0.0 < v <= 100.0, "a percentage in (0, 100]")
_nonneg_int = _checked(_int, lambda v: v >= 0, "an integer >= 0")


def _str(value, field):
    if not isinstance(value, str) or not value:
        _fail(field, "a non-empty string", value)
    return value


def _optional(check):
    def f(value, field):
        return None if value is None else check(value, field)
    return f


def _str_list(value, field):
    if not isinstance(value, (list, tuple)):
        _fail(field, "a list of joint names", value)
    return [_str(v, f"{field}[{i}]") for i, v in enumerate(value)]


def _deltas(value, field):
    """``{joint name: [rx, ry, rz]}`` rotation vectors in degrees."""
    if not isinstance(value, dict):
        _fail(field, "an object {joint name: [rx, ry, rz] degrees}", value)
    out = {}
    for k, v in value.items():
        _str(k, f"{field} key")
        if not isinstance(v, (list, tuple)) or len(v) != 3:
            _fail(f"{field}.{k}", "a list of 3 numbers (rotation vector, degrees)", v)
        out[k] = [_number(x, f"{field}.{k}[{i}]") for i, x in enumerate(v)]
    return out


def _time_range(value, field):
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        _fail(field, "[start, stop]", value)
    a, b = (_number(x, f"{field}[{i}]") for i, x in enumerate(value))
    if b < a:
        _fail(field, "start <= stop", value)
    return [a, b]


def _frame_range(value, field):
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        _fail(field, "[start_frame, stop_frame]", value)
    a, b = (_nonneg_int(x, f"{field}[{i}]") for i, x in enumerate(value))
    if b <= a:
        _fail(field, "start_frame < stop_frame (half-open range)", value)
    return [a, b]


def _keytimes(value, field):
    """``[[input_seconds, output_seconds], ...]`` pairs."""
    if not isinstance(value, (list, tuple)):
        _fail(field, "a list of [input_time, output_time] pairs (seconds)", value)
    out = []
    for i, pair in enumerate(value):
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            _fail(f"{field}[{i}]", "[input_time, output_time] (seconds)", pair)
        out.append([_nonneg(pair[0], f"{field}[{i}][0]"), _nonneg(pair[1], f"{field}[{i}][1]")])
    return out


def _reference(value, field):
    """``"self"``, ``{"segment": [start_s, stop_s]}`` of the source, or ``{"path": "clip.bvh"}``."""
    if value == "self":
        return value
    if isinstance(value, dict) and len(value) == 1:
        if "segment" in value:
            return {"segment": _time_range(value["segment"], f"{field}.segment")}
        if "path" in value:
            return {"path": _str(value["path"], f"{field}.path")}
    _fail(field, '"self", {"segment": [start, stop]} or {"path": "file.bvh"}', value)


# --------------------------------------------------------------------------------------------------
# the op registry
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class OpSpec:
    """One registered operation.

    Attributes
    ----------
    name : str
        The ``"op"`` value.
    needs : str
        ``"staggered"`` or ``"motion"``: the state the op consumes (converted automatically).
    fields : dict[str, tuple[validator, default]]
        Field validators; ``default is _REQUIRED`` marks a required field.
    run : callable ``(state, params: dict, ctx: _Context) -> state``
    """

    name: str
    needs: str
    fields: dict
    run: Callable


_REQUIRED = object()
OP_REGISTRY: dict[str, OpSpec] = {}


def register_op(name: str, needs: str, fields: dict, run: Callable) -> OpSpec:
    """Register (or replace) an op. ``fields`` maps field names to ``(validator, default)``; use
    ``None`` as validator to accept any JSON value, and ``Session.REQUIRED`` as default for a required one."""
    if needs not in ("staggered", "motion"):
        raise ValueError(f"needs: expected 'staggered' or 'motion', got {needs!r}")
    spec = OpSpec(name, needs, dict(fields), run)
    OP_REGISTRY[name] = spec
    return spec


def validate_op(op: Any, where: str = "op") -> dict:
    """A normalised copy of ``op`` (defaults filled in) or ``ValueError`` naming the bad field."""
    if not isinstance(op, dict):
        _fail(where, 'an object like {"op": "succession", ...}', op)
    name = op.get("op")
    if not isinstance(name, str):
        _fail(f"{where}.op", "an op name", name)
    spec = OP_REGISTRY.get(name)
    if spec is None:
        raise ValueError(f"{where}.op: unknown op {name!r}; known ops are {', '.join(sorted(OP_REGISTRY))}")
    out = {"op": name}
    for key in op:
        if key != "op" and key not in spec.fields:
            raise ValueError(f"{where}.{key}: unknown field for op {name!r}; fields are "
                             f"{', '.join(spec.fields) or '(none)'}")
    for key, (check, default) in spec.fields.items():
        if key in op:
            v = op[key]
            out[key] = copy.deepcopy(v) if check is None else check(v, f"{where}.{key}")
        elif default is _REQUIRED:
            raise ValueError(f"{where}.{key}: required field of op {name!r} is missing")
        else:
            out[key] = copy.deepcopy(default)
    return out


def _joint(skeleton: Skeleton, name: str, field: str) -> int:
    try:
        return skeleton.index(name)
    except KeyError:
        raise ValueError(f"{field}: no joint named {name!r} in this skeleton") from None


def apply_pose_deltas(pose_quats: np.ndarray, skeleton: Skeleton, deltas: dict, field: str = "deltas") -> np.ndarray:
    """Rotate joints of one pose in their own frames: ``q_j <- q_j * exp(r_j)``.

    Parameters
    ----------
    pose_quats : (J, 4) local rotations (x, y, z, w)
    deltas : {joint name: [rx, ry, rz]} rotation vectors in **degrees**, in the joint's local frame

    Returns
    -------
    (J, 4) edited local rotations (a new array)
    """
    out = np.array(pose_quats, dtype=float)
    for name, rv in deltas.items():
        j = _joint(skeleton, name, f"{field}.{name}")
        out[j] = quat_mul(out[j], rotvec_to_quat(np.radians(np.asarray(rv, dtype=float))))
    return out


# -- runners ---------------------------------------------------------------------------------------
def _staggered():
    from .. import staggered  # late import: the technique packages load only when an op needs them
    return staggered


def _wand():
    from .. import wand
    return wand


def _timewarp():
    from .. import timewarp
    return timewarp


def _run_extract(st, p, ctx):
    return ctx.extract(st)


def _run_cull(sm, p, ctx):
    return ctx.cull(sm, p["percent"])


def _run_succession(sm, p, ctx):
    return _staggered().succession(sm, root=p["root"], s=p["s"], l=p["l"], joints=p["joints"])


def _run_random_timing(sm, p, ctx):
    return _staggered().random_timing(sm, joints=p["joints"], tau=p["tau"], seed=p["seed"])


def _run_exaggerate(sm, p, ctx):
    poses = list(range(sm.num_poses)) if p["poses"] is None else p["poses"]
    return _staggered().exaggerate(sm, poses, p["w_r"], reference=p["reference"], mode=p["mode"],
                                   joints=p["joints"])


def _run_edit_pose(sm, p, ctx):
    deltas = {name: np.radians(np.asarray(rv, dtype=float)) for name, rv in p["deltas"].items()}
    return _staggered().edit_pose(sm, p["pose"], deltas=deltas, mode=p["mode"])


def _run_edit_frame(m, p, ctx):
    f = p["frame"]
    if f >= m.num_frames:
        raise ValueError(f"frame: {f} is outside the motion's {m.num_frames} frames")
    q = np.array(m.local_quats)
    q[f] = apply_pose_deltas(q[f], m.skeleton, p["deltas"])
    return m.replace(local_quats=q)


def _run_propagate(m, p, ctx):
    f = p["frame"]
    if f >= m.num_frames:
        raise ValueError(f"frame: {f} is outside the motion's {m.num_frames} frames")
    edited = apply_pose_deltas(m.local_quats[f], m.skeleton, p["deltas"])
    fr = None if p["frame_range"] is None else tuple(p["frame_range"])
    return _wand().propagate(m, f, edited, frame_range=fr, basis=ctx.wand_basis(m, p["sigma"]))


_MAX_WARP_RATIO = 100  # output frames per input frame: far past the papers' 10x slow motion


def _warp_frames(m, duration):
    """Output frames of a warp to ``duration`` seconds at the input's frame time (at most
    ``_MAX_WARP_RATIO`` times the input's frames: an absurd duration must not allocate memory for it)."""
    n = duration / m.frame_time
    if n > _MAX_WARP_RATIO * m.num_frames:
        raise ValueError(f"duration: {duration:g} s is more than {_MAX_WARP_RATIO} times the input's "
                         f"{m.duration:g} s")
    return max(2, int(round(n)) + 1)


def _run_guided_warp(m, p, ctx):
    tw = _timewarp()
    n = _warp_frames(m, p["duration"])
    tables = ctx.warp_tables(m, p["reference"], p["skip"], tw.required_upsample(m.num_frames, n))
    out, warp = tw.guided_warp(m, tables.reference, n, skip=p["skip"], keytimes=p["keytimes"], tables=tables)
    ctx.remember_warp(m, p, warp)
    return out


def _run_linear_warp(m, p, ctx):
    out, warp = _timewarp().linear_warp(m, _warp_frames(m, p["duration"]), keytimes=p["keytimes"])
    ctx.remember_warp(m, p, warp)
    return out


def _run_resample(m, p, ctx):
    if m.duration / p["frame_time"] > _MAX_WARP_RATIO * m.num_frames:
        raise ValueError(f"frame_time: {p['frame_time']:g} s gives more than {_MAX_WARP_RATIO} times the "
                         f"input's {m.num_frames} frames")
    return m.resample(p["frame_time"])


register_op("extract", "motion", {}, _run_extract)
register_op("cull", "staggered", {"percent": (_percent, _REQUIRED)}, _run_cull)
register_op("succession", "staggered", {"root": (_str, _REQUIRED), "s": (_number, _REQUIRED),
                                        "l": (_positive, 1.0), "joints": (_optional(_str_list), None)},
            _run_succession)
register_op("random_timing", "staggered", {"tau": (_nonneg, _REQUIRED), "seed": (_nonneg_int, 0),
                                           "joints": (_optional(_str_list), None)}, _run_random_timing)
_MODE = _choice("staggered", "unstaggered")
register_op("exaggerate", "staggered", {"w_r": (_number, _REQUIRED), "poses": (_optional(_int_list), None),
                                        "reference": (_pose_reference, "previous"), "mode": (_MODE, "staggered"),
                                        "joints": (_optional(_str_list), None)}, _run_exaggerate)
register_op("edit_pose", "staggered", {"pose": (_nonneg_int, _REQUIRED), "deltas": (_deltas, _REQUIRED),
                                       "mode": (_MODE, "staggered")}, _run_edit_pose)
register_op("edit_frame", "motion", {"frame": (_nonneg_int, _REQUIRED), "deltas": (_deltas, _REQUIRED)},
            _run_edit_frame)
register_op("propagate", "motion", {"frame": (_nonneg_int, _REQUIRED), "deltas": (_deltas, _REQUIRED),
                                    "sigma": (_optional(_positive), None),
                                    "frame_range": (_optional(_frame_range), None)}, _run_propagate)
register_op("guided_warp", "motion", {"duration": (_positive, _REQUIRED), "skip": (_nonneg_int, 8),
                                      "keytimes": (_optional(_keytimes), None),
                                      "reference": (_reference, "self")}, _run_guided_warp)
register_op("linear_warp", "motion", {"duration": (_positive, _REQUIRED),
                                      "keytimes": (_optional(_keytimes), None)}, _run_linear_warp)
register_op("resample", "motion", {"frame_time": (_positive, _REQUIRED)}, _run_resample)


# --------------------------------------------------------------------------------------------------
# motion <-> JSON (for sessions without a source file)
# --------------------------------------------------------------------------------------------------
def _motion_to_json(m: Motion) -> dict:
    sk = m.skeleton
    return {"names": list(sk.names), "parents": sk.parents.tolist(), "offsets": sk.offsets.tolist(),
            "channels": [list(c) for c in sk.channels],
            "end_sites": {str(k): v.tolist() for k, v in sk.end_sites.items()},
            "frame_time": m.frame_time, "root_positions": m.root_positions.tolist(),
            "local_quats": m.local_quats.tolist(),
            "local_translations": None if m.local_translations is None else m.local_translations.tolist()}


_MOTION_FIELDS = ("names", "parents", "offsets", "channels", "end_sites", "frame_time", "root_positions",
                  "local_quats", "local_translations")
_CHANNEL_RE = re.compile(r"[XYZ](position|rotation)\Z", re.IGNORECASE)


def _float_array(value, field, shape_tail: tuple) -> np.ndarray:
    """``value`` (nested JSON lists of numbers) as a float array of shape ``(N,) + shape_tail``."""
    try:
        a = np.asarray(value)
    except ValueError:  # ragged nesting
        a = None
    if a is None or a.dtype.kind not in "iuf" or a.ndim != 1 + len(shape_tail) or a.shape[1:] != shape_tail:
        _fail(field, f"an array of numbers of shape (N, {', '.join(map(str, shape_tail))})",
              type(value).__name__ if a is None or a.size > 8 else value)
    a = a.astype(float)
    if not np.all(np.isfinite(a)):
        _fail(field, "finite numbers", "a non-finite value")
    return a


def _motion_from_json(d: Any, field: str) -> Motion:
    if not isinstance(d, dict):
        _fail(field, "an embedded motion object", d)
    for k in d:
        if k not in _MOTION_FIELDS:
            raise ValueError(f"{field}.{k}: unknown field of an embedded motion")
    for k in _MOTION_FIELDS[:-1]:
        if k not in d:
            raise ValueError(f"{field}.{k}: missing")
    names = tuple(_str_list(d["names"], f"{field}.names"))
    J = len(names)
    parents = d["parents"]
    if not isinstance(parents, list) or len(parents) != J:
        _fail(f"{field}.parents", f"a list of {J} parent indices", parents)
    parents = np.array([_int(v, f"{field}.parents[{i}]") for i, v in enumerate(parents)], dtype=np.int64)
    channels = d["channels"]
    if not isinstance(channels, list) or len(channels) != J:
        _fail(f"{field}.channels", f"a list of {J} channel lists", channels)
    for i, c in enumerate(channels):
        if not isinstance(c, list) or not all(isinstance(x, str) and _CHANNEL_RE.match(x) for x in c):
            _fail(f"{field}.channels[{i}]", 'a list like ["Zrotation", "Xrotation", "Yrotation"]', c)
    ends = d["end_sites"]
    if not isinstance(ends, dict):
        _fail(f"{field}.end_sites", "an object {joint index: [x, y, z]}", ends)
    end_sites = {}
    for k, v in ends.items():
        if not (isinstance(k, str) and k.isdigit() and int(k) < J):
            _fail(f"{field}.end_sites", f"joint indices below {J} as keys", k)
        end_sites[int(k)] = _float_array([v], f"{field}.end_sites.{k}", (3,))[0]
    frame_time = _positive(d["frame_time"], f"{field}.frame_time")
    offsets = _float_array(d["offsets"], f"{field}.offsets", (3,))
    root = _float_array(d["root_positions"], f"{field}.root_positions", (3,))
    q = _float_array(d["local_quats"], f"{field}.local_quats", (J, 4))
    lt = d.get("local_translations")
    lt = None if lt is None else _float_array(lt, f"{field}.local_translations", (J, 3))
    try:
        sk = Skeleton(names, parents, offsets, tuple(tuple(c) for c in channels), end_sites)
        m = Motion(sk, frame_time, root, q, lt)
    except ValueError as e:  # shapes that disagree, a parent after its child: the message names them
        raise ValueError(f"{field}: {e}") from None
    # Motion() re-normalises the quaternions; the stored ones were already normalised by a Motion, so
    # keep the stored bits exactly (re-normalising can flip the last bit) -> bit-for-bit replay.
    if q.shape == m.local_quats.shape and np.allclose(q, m.local_quats, rtol=0, atol=1e-12):
        q = q.copy()
        q.setflags(write=False)
        object.__setattr__(m, "local_quats", q)
    return m


# --------------------------------------------------------------------------------------------------
# view data (the widgets draw these; they do no math themselves)
# --------------------------------------------------------------------------------------------------
def joint_rotation_degrees(motion: Motion, joint) -> np.ndarray:
    """Local rotation of ``joint`` (name or index) over time as a rotation vector, shape (F, 3), degrees."""
    j = motion.skeleton.index(joint) if isinstance(joint, str) else int(joint)
    return np.degrees(quat_to_rotvec(motion.local_quats[:, j]))


def _sha256(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _check_extract_options(options) -> dict:
    """A copy of ``options`` (keyword arguments of ``staggered.extract`` / ``locate_poses``, JSON values),
    or ValueError naming the bad key."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        _fail("extract_options", "an object", options)
    options = dict(options)
    if options:
        import inspect
        from ..staggered import extraction
        known = {name for f in (extraction.extract, extraction.locate_poses)
                 for name, p in inspect.signature(f).parameters.items() if p.kind is p.KEYWORD_ONLY}
        for k in options:
            if k not in known:
                raise ValueError(f"extract_options.{k}: unknown option; options are {', '.join(sorted(known))}")
        try:
            _canonical(options)
        except (TypeError, ValueError) as e:
            raise ValueError(f"extract_options: not JSON values ({e})") from None
    return options


def _canonical(ops) -> str:
    return json.dumps(ops, sort_keys=True, separators=(",", ":"), allow_nan=False)


# --------------------------------------------------------------------------------------------------
# the session
# --------------------------------------------------------------------------------------------------
class _Context:
    """What runners may ask of the session: cached expensive heads (the staggered extraction, the
    magic wand's pose graph and per-sigma eigenbases) and resolved references."""

    def __init__(self, session: "Session"):
        self._s = session
        self._per_motion: dict[str, OrderedDict] = {"extract": OrderedDict(), "graph": OrderedDict(),
                                                    "basis": OrderedDict(), "warp": OrderedDict(),
                                                    "cull": OrderedDict()}
        self._lock = threading.Lock()  # guards the stores: the caches may be warmed from a background thread
        self._pending: dict = {}  # (kind, key) -> Event of an entry being computed by some thread
        self._references: dict = {}
        self._warps: dict = {}

    def _cached(self, kind: str, motion, key, make: Callable, size: int = _EXTRACT_CACHE_SIZE):
        """``make()`` once per (kind, motion, key), kept in a small LRU store.

        Thread-safe: the stores are touched under ``_lock`` only, and ``make()`` runs outside it, so a
        background warm-up computing one entry never blocks the foreground from reading another (a
        slider move racing the warm-up). Two threads asking for the same missing entry compute it once:
        the second waits for the first's result (and computes it itself if the first failed)."""
        store = self._per_motion[kind]
        k = (id(motion), key)
        while True:
            with self._lock:
                hit = store.get(k)
                if hit is not None and hit[0] is motion:
                    store.move_to_end(k)
                    return hit[1]
                pending = self._pending.get((kind, k))
                if pending is None:
                    pending = self._pending[(kind, k)] = threading.Event()
                    break
            pending.wait()  # another thread is computing this very entry
        try:
            self._s._busy(kind, True)
            try:
                value = make()
            finally:
                self._s._busy(kind, False)
            with self._lock:
                store[k] = (motion, value)
                while len(store) > size:
                    store.popitem(last=False)
            return value
        finally:
            with self._lock:
                del self._pending[(kind, k)]
            pending.set()

    def extract(self, motion: Motion):
        """``staggered.extract(motion, **extract_options)``, once per motion."""
        def make():
            try:
                return _staggered().extract(motion, **self._s.extract_options)
            except (TypeError, ArithmeticError) as e:  # the keys are checked already: a bad value
                raise ValueError(f"extract_options: {type(e).__name__}: {e}") from None
        return self._cached("extract", motion, None, make)

    def cull(self, sm, percent: float):
        """``staggered.cull(sm, percent)`` (a refit of the splines, the slow step of the cull slider), once
        per (representation, percent)."""
        return self._cached("cull", sm, float(percent), lambda: _staggered().cull(sm, percent=float(percent)),
                            size=_CULL_CACHE_SIZE)

    def wand_basis(self, motion: Motion, sigma: float | None):
        """The magic wand's Green's eigenbasis of ``motion`` for ``sigma``: the sigma-independent pose
        graph is built once per motion, the basis once per (motion, sigma) (Dean et al. 2018, §3.1-3.2)."""
        graph = self._cached("graph", motion, None, lambda: _wand().pose_graph(motion))
        return self._cached("basis", motion, None if sigma is None else float(sigma),
                            lambda: graph.basis(sigma), size=_BASIS_CACHE_SIZE)

    def wand_graph(self, motion: Motion):
        return self._cached("graph", motion, None, lambda: _wand().pose_graph(motion))

    def warp_tables(self, motion: Motion, reference, skip: int, upsample: int):
        """Guided time warping's precomputed kNN score tables (Hsu et al. 2007, §3.2), once per
        (input, reference, skip, upsampling)."""
        ref = self.reference(reference, motion)
        return self._cached("warp", motion, (_canonical(reference), int(skip), int(upsample)),
                            lambda: _timewarp().prepare_warp(motion, ref, int(skip), int(upsample)))

    def remember_warp(self, motion: Motion, params: dict, warp: np.ndarray) -> None:
        self._warps[(id(motion), _canonical(params))] = warp
        while len(self._warps) > _MEMO_SIZE:
            self._warps.pop(next(iter(self._warps)))

    def reference(self, ref, motion: Motion) -> Motion:
        if ref == "self":
            return self._s.source
        key = _canonical(ref)
        if key not in self._references:
            if "segment" in ref:
                a, b = ref["segment"]
                src = self._s.source
                start = int(round(a / src.frame_time))
                stop = min(src.num_frames, int(round(b / src.frame_time)) + 1)
                if stop - start < 3:
                    raise ValueError(f"reference.segment: [{a}, {b}] s holds fewer than 3 frames")
                self._references[key] = src.slice(start, stop)
            else:
                self._references[key] = read_bvh(ref["path"])
        return self._references[key]


class Session:
    """A source motion plus an ordered list of ops; :meth:`edited` replays them.

    Parameters
    ----------
    source : Motion
        The unedited motion (never modified).
    ops : list of op dicts, optional
        Validated with :func:`validate_op`.
    source_path : str, optional
        The file ``source`` was read from; saved sessions refer to it (with its SHA-256) instead of
        embedding the motion, and :meth:`export_bvh` refuses to overwrite it.
    extract_options : dict, optional
        Keyword arguments for ``staggered.extract`` (JSON values; saved with the session).

    Notes
    -----
    Each op list change (``add``, ``set_ops``, ``replace``, ``remove``, ``clear``) is one undo step.
    Listeners registered with :meth:`observe` are called as ``listener(session)`` after every change.
    """

    REQUIRED = _REQUIRED

    def __init__(self, source: Motion, ops=None, source_path=None, extract_options=None):
        if not isinstance(source, Motion):
            raise ValueError(f"source: expected a Motion, got {type(source).__name__}")
        self.source = source
        self.source_path = None if source_path is None else os.path.abspath(os.fspath(source_path))
        self.extract_options = _check_extract_options(extract_options)
        self._ops = self._validated(ops or [], "ops")
        self._undo: list = []
        self._redo: list = []
        self._memo: OrderedDict = OrderedDict()
        self._ctx = _Context(self)
        self._listeners: list = []
        self._busy_listeners: list = []
        self._curve_cache: dict = {}

    @classmethod
    def from_bvh(cls, path, ops=None, **kwargs) -> "Session":
        """Read ``path`` as the source motion (remembering the path)."""
        return cls(read_bvh(path), ops, source_path=path, **kwargs)

    # -- ops ---------------------------------------------------------------------------------------
    @staticmethod
    def _validated(ops, where) -> list:
        if not isinstance(ops, (list, tuple)):
            _fail(where, "a list of op objects", ops)
        return [validate_op(op, f"{where}[{i}]") for i, op in enumerate(ops)]

    @property
    def ops(self) -> list:
        """A deep copy of the current op list."""
        return copy.deepcopy(self._ops)

    def __len__(self) -> int:
        return len(self._ops)

    def _commit(self, new_ops: list) -> bool:
        if _canonical(new_ops) == _canonical(self._ops):
            return False
        self._undo.append(self._ops)
        self._redo.clear()
        self._ops = new_ops
        self._notify()
        return True

    def set_ops(self, ops) -> bool:
        """Replace the whole op list (one undo step); returns False when nothing changed."""
        return self._commit(self._validated(ops, "ops"))

    def add(self, op: dict) -> bool:
        """Append one op."""
        return self._commit(self._ops + [validate_op(op, f"ops[{len(self._ops)}]")])

    def replace(self, index: int, op: dict) -> bool:
        """Replace op ``index`` (negative indices count from the end)."""
        n = len(self._ops)
        if not -n <= index < n:
            raise ValueError(f"index: {index} is outside the {n} ops")
        new = list(self._ops)
        new[index] = validate_op(op, f"ops[{index % n}]")
        return self._commit(new)

    def remove(self, index: int) -> bool:
        n = len(self._ops)
        if not -n <= index < n:
            raise ValueError(f"index: {index} is outside the {n} ops")
        new = list(self._ops)
        del new[index]
        return self._commit(new)

    def clear(self) -> bool:
        return self._commit([])

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    def undo(self) -> bool:
        """Go back one change; returns False when there is nothing to undo."""
        if not self._undo:
            return False
        self._redo.append(self._ops)
        self._ops = self._undo.pop()
        self._notify()
        return True

    def redo(self) -> bool:
        if not self._redo:
            return False
        self._undo.append(self._ops)
        self._ops = self._redo.pop()
        self._notify()
        return True

    def observe(self, listener: Callable) -> None:
        """Call ``listener(session)`` after every change of the op list."""
        self._listeners.append(listener)

    def observe_busy(self, listener: Callable) -> None:
        """Call ``listener(kind, started)`` around expensive cached computations (``"extract"``,
        ``"graph"``, ``"basis"``, ``"reference"``), e.g. to show a progress bar."""
        self._busy_listeners.append(listener)

    def _busy(self, kind: str, started: bool) -> None:
        for f in list(self._busy_listeners):
            f(kind, started)

    def _notify(self):
        for f in list(self._listeners):
            f(self)

    # -- replay ------------------------------------------------------------------------------------
    def _convert(self, state, needs: str):
        is_motion = isinstance(state, Motion)
        if needs == "motion":
            return state if is_motion else _staggered().evaluate(state)
        return self._ctx.extract(state) if is_motion else state

    def states(self, progress: Callable | None = None) -> list:
        """The state after each op (``len(ops)`` items; Motion or StaggeredMotion), memoised by prefix.

        ``progress(done, total, label)`` is called before each op that is actually computed.
        """
        states, state = [], self.source
        todo = []
        for i in range(len(self._ops)):
            key = _canonical(self._ops[: i + 1])
            hit = self._memo.get(key)
            if hit is None:
                todo.append((i, key))
            states.append((key, hit))
        # find the last memoised prefix; recompute from there
        start = 0
        for i in range(len(states) - 1, -1, -1):
            if states[i][1] is not None:
                start = i + 1
                state = states[i][1]
                break
        out = [s for _, s in states[:start]]
        total = len(self._ops) - start
        for n, i in enumerate(range(start, len(self._ops))):
            op = self._ops[i]
            spec = OP_REGISTRY[op["op"]]
            if progress is not None:
                progress(n, total, op["op"])
            try:
                state = spec.run(self._convert(state, spec.needs), op, self._ctx)
            except ValueError as e:
                raise ValueError(f"ops[{i}] ({op['op']}): {e}") from None
            except ArithmeticError as e:  # e.g. a parameter so extreme that the technique divides by 0
                raise ValueError(f"ops[{i}] ({op['op']}): {type(e).__name__}: {e}") from None
            key = states[i][0]
            self._memo[key] = state
            out.append(state)
        if progress is not None and total:
            progress(total, total, "done")
        for key, _ in states:
            if key in self._memo:
                self._memo.move_to_end(key)
        while len(self._memo) > _MEMO_SIZE:
            self._memo.popitem(last=False)
        return out

    def edited(self, progress: Callable | None = None) -> Motion:
        """The source motion with every op applied (a Motion; staggered states are evaluated)."""
        if not self._ops:
            return self.source
        key = "motion:" + _canonical(self._ops)
        hit = self._memo.get(key)
        if hit is not None:
            self._memo.move_to_end(key)
            return hit
        last = self.states(progress)[-1]
        try:
            m = self._convert(last, "motion")
        except (ValueError, ArithmeticError) as e:  # evaluating the last staggered state
            n = len(self._ops) - 1
            raise ValueError(f"ops[{n}] ({self._ops[n]['op']}): evaluating the result: {e}") from None
        self._memo[key] = m
        return m

    def staggered(self, progress: Callable | None = None):
        """The last staggered representation of the replay (after the last staggered op), or the
        extraction of the source when no op is staggered."""
        for st in reversed(self.states(progress)):
            if not isinstance(st, Motion):
                return st
        return self._ctx.extract(self.source)

    def extraction(self):
        """The (cached) staggered extraction of the source motion."""
        return self._ctx.extract(self.source)

    def precompute_cull(self, percents, stop: Callable | None = None) -> int:
        """Compute and cache ``cull`` of the source's extraction for each of ``percents`` (e.g. every
        position of a slider, from a background thread); stops early when ``stop()`` is true.
        Returns how many were computed or already cached."""
        n = 0
        sm = self.extraction()
        for pc in percents:
            if stop is not None and stop():
                break
            self._ctx.cull(sm, _percent(float(pc), "percents[]"))
            n += 1
        return n

    def warp_curve(self, index: int = -1):
        """The time warp computed by the warp op at ``index``: (N,) input seconds of each output frame
        (None when that op is not a warp)."""
        states = self.states()
        n = len(self._ops)
        if not -n <= index < n:
            raise ValueError(f"index: {index} is outside the {n} ops")
        i = index % n
        op = self._ops[i]
        if op["op"] not in ("guided_warp", "linear_warp"):
            return None
        prev = self.source if i == 0 else states[i - 1]
        prev = self._convert(prev, "motion")
        return self._ctx._warps.get((id(prev), _canonical(op)))

    def precompute_wand_bases(self, sigmas, stop: Callable | None = None, motion: Motion | None = None) -> int:
        """Compute and cache the magic-wand eigenbasis for each of ``sigmas`` (e.g. every position of a σ
        slider, from a background thread); stops early when ``stop()`` is true. Returns how many."""
        n = 0
        for sg in sigmas:
            if stop is not None and stop():
                break
            self.wand_basis(_positive(float(sg), "sigmas[]"), motion)
            n += 1
        return n

    def use_reference(self, path: str, motion: Motion) -> dict:
        """Resolve the op reference ``{"path": path}`` to ``motion`` in this session (e.g. an in-memory clip
        under a name like ``"<memory:name>"``) instead of reading the file; returns that reference.
        A saved session keeps only the path: a new process reads the file."""
        if not isinstance(motion, Motion):
            raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
        ref = {"path": _str(path, "path")}
        self._ctx._references[_canonical(ref)] = motion
        return ref

    def wand_basis(self, sigma: float | None = None, motion: Motion | None = None):
        """The (cached) magic-wand eigenbasis of ``motion`` (default: the source) for ``sigma``."""
        return self._ctx.wand_basis(self.source if motion is None else motion, sigma)

    def wand_graph(self, motion: Motion | None = None):
        """The (cached) sigma-independent pose graph of ``motion`` (default: the source)."""
        return self._ctx.wand_graph(self.source if motion is None else motion)

    def falloff_curves(self, frame: int, sigma: float | None = None, frame_range=None, compare=(),
                       spline_extent: float | None = None, motion: Motion | None = None) -> dict:
        """Falloff weights around ``frame`` (1 there, 0 far away), each (F,), for the views.

        ``"green"``: the magic wand's Green's-function falloff (Dean et al. 2018, §3.3) with the cached
        basis; ``compare`` may add ``"isomap"`` and ``"diffusion"`` (``1 - normalised distance``, Fig. 3)
        and ``"spline"`` (a generic smoothstep falloff of ``spline_extent`` frames, Fig. 6).
        """
        m = self.source if motion is None else motion
        wand = _wand()
        fr = None if frame_range is None else tuple(frame_range)
        out = {"green": wand.greens_falloff(self._ctx.wand_basis(m, sigma), int(frame), fr)}
        for name in compare:
            key = (name, id(m), int(frame), None if sigma is None else float(sigma), fr)
            hit = self._curve_cache.get(key)
            if hit is None:
                if name == "isomap":
                    hit = 1.0 - wand.normalize_distance(wand.isomap_distance(m, int(frame)), fr)
                elif name == "diffusion":
                    hit = 1.0 - wand.normalize_distance(wand.diffusion_distance(m, int(frame), sigma=sigma), fr)
                elif name == "spline":
                    extent = spline_extent or max(2.0, m.num_frames / 10)
                    hit = wand.spline_falloff(m.num_frames, int(frame), extent)
                else:
                    raise ValueError(f"compare: unknown curve {name!r}; use 'isomap', 'diffusion', 'spline'")
                self._curve_cache[key] = hit
                while len(self._curve_cache) > 16:
                    self._curve_cache.pop(next(iter(self._curve_cache)))
            out[name] = hit
        return out

    # -- files -------------------------------------------------------------------------------------
    def to_json(self, embed_source: bool | None = None) -> dict:
        """The session as a JSON-ready dict. The source is referenced by path (+ SHA-256) when the
        session has one, otherwise embedded (``embed_source=True`` forces embedding)."""
        if embed_source is None:
            embed_source = self.source_path is None
        if embed_source:
            source = {"motion": _motion_to_json(self.source)}
        else:
            if self.source_path is None:
                raise ValueError("embed_source: False needs a session with a source_path")
            source = {"path": self.source_path, "sha256": _sha256(self.source_path)}
        return {"format": SESSION_FORMAT, "version": SESSION_VERSION, "source": source,
                "extract_options": copy.deepcopy(self.extract_options), "ops": self.ops}

    def save(self, path, embed_source: bool | None = None) -> None:
        """Write the session as JSON, atomically (temporary file + rename)."""
        text = json.dumps(self.to_json(embed_source), indent=1, allow_nan=False)
        atomic_write_bytes(path, text.encode("utf-8"))

    @classmethod
    def from_json(cls, data: Any, source: Motion | None = None) -> "Session":
        """Validate ``data`` (a parsed session file) and build the session. ``source`` overrides the
        stored source (for a moved file)."""
        if not isinstance(data, dict):
            _fail("session", "a JSON object", data)
        for k in data:
            if k not in ("format", "version", "source", "extract_options", "ops"):
                raise ValueError(f"{k}: unknown field in a session file")
        if data.get("format") != SESSION_FORMAT:
            _fail("format", repr(SESSION_FORMAT), data.get("format"))
        if data.get("version") != SESSION_VERSION:
            _fail("version", str(SESSION_VERSION), data.get("version"))
        opts = data.get("extract_options", {})
        if not isinstance(opts, dict):
            _fail("extract_options", "an object", opts)
        ops = cls._validated(data.get("ops"), "ops")
        src = data.get("source")
        path = None
        if source is None:
            if not isinstance(src, dict):
                _fail("source", '{"path": ..., "sha256": ...} or {"motion": {...}}', src)
            if "path" in src:
                path = _str(src["path"], "source.path")
                if not os.path.isfile(path):
                    raise ValueError(f"source.path: {path} does not exist (pass source= to load anyway)")
                digest = src.get("sha256")
                if digest is not None and _str(digest, "source.sha256") != _sha256(path):
                    raise ValueError(f"source.sha256: {path} changed since the session was saved")
                try:
                    source = read_bvh(path)
                except ValueError as e:  # BVHError: names the file and line
                    raise ValueError(f"source.path: {e}") from None
            elif "motion" in src:
                source = _motion_from_json(src["motion"], "source.motion")
            else:
                _fail("source", '{"path": ...} or {"motion": {...}}', src)
        elif isinstance(src, dict) and "path" in src:
            path = src["path"] if isinstance(src["path"], str) else None
        return cls(source, ops, source_path=path, extract_options=opts)

    @classmethod
    def load(cls, path, source: Motion | None = None) -> "Session":
        """Read a session file written by :meth:`save` (validated; ValueError names the bad field)."""
        with open(os.fspath(path), "rb") as f:
            raw = f.read()
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise ValueError(f"session: {path} is not UTF-8 JSON text (byte {e.start})") from None

        def no_constants(c):
            raise ValueError(f"session: {c} is not allowed in a session file")

        try:
            data = json.loads(text, parse_constant=no_constants)
        except json.JSONDecodeError as e:
            raise ValueError(f"session: {path} is not valid JSON ({e})") from None
        except RecursionError:
            raise ValueError(f"session: {path} nests JSON too deeply for a session file") from None
        return cls.from_json(data, source=source)

    def export_bvh(self, path) -> None:
        """Write the edited motion as BVH, atomically; refuses to overwrite the source file."""
        path = os.fspath(path)
        if self.source_path is not None and os.path.exists(path) and (
                os.path.realpath(path) == os.path.realpath(self.source_path)
                or os.path.samefile(path, self.source_path)):
            raise ValueError(f"path: {path} is the session's source file; export to another file")
        write_bvh(self.edited(), path)

    def __repr__(self) -> str:
        src = os.path.basename(self.source_path) if self.source_path else repr(self.source)
        return f"Session({src}, {len(self._ops)} ops: {', '.join(o['op'] for o in self._ops) or '-'})"
