"""Keeping an editor's model and a :class:`~stagger_nb.session.Session` in step, both directions
(:class:`ModelBinding`); the editor's ops go into the session's list by :func:`~.merge.merge_ops`.
"""
from __future__ import annotations

import contextlib
import copy
import itertools
import json
import time
import weakref
from collections.abc import Callable

import traitlets as T

from ..ops import OPS
from ..replay import ReplayError
from ._base import _canon, _Model
from .merge import _edit_prefix, _stagger_home, _wand_home, _wand_input_frames, _warp_home, merge_ops
from .messages import plain_message
from .stagger import STAGGER_OPS, StaggerModel, stagger_ops_to_params, stagger_params_to_ops
from .wand import WAND_OPS, WandModel, wand_ops_to_params, wand_params_to_ops
from .warp import WARP_OPS, WarpModel, warp_ops_to_params, warp_params_to_ops

#: the quality report's figures about the feet (``SummaryItem.figure``): one out of bounds while the contact layer is
#: off gets :data:`CONTACTS_HINT` as the model's ``hint`` (the layer is off by default, and a user seeing "right foot
#: slides 68 cm" after a timing edit should learn that the editor can hold the feet)
FOOT_FIGURES = frozenset({"foot_travel", "foot_travel_vs_baseline", "foot_height", "floor", "plant", "contacts"})
CONTACTS_HINT = "the feet leave their contacts: tick \u201ckeep foot contacts\u201d (contacts tab) to hold them"

__all__ = ["ModelBinding", "merge_ops"]


class ModelBinding:
    """Keeps ``model`` and ``session`` in step, both ways.

    - A change of an op trait (``op=True``) writes the session's op list (:func:`merge_ops`, one undo step via
      ``session.set_ops``) once its replay has succeeded (``session.check_ops``: the states it computes are
      the ones the views then read). A list that would not replay, or that the session refuses, is not
      written: the model's op traits go back to what they were, ``model.message`` holds the plain sentence
      (:func:`~.messages.plain_message`) and the trait assignment raises ``traitlets.TraitError`` with it. An
      op list that fails already, at the same op, before the change is not this change's doing: it is written.
    - A change of the session's op list (undo/redo, load, code) sets the model's op traits from it; the model
      then equals what the ops say (undo restores every parameter).
    - One gesture is one undo step: changes from the same control (``model.set_control``) of a slider-like
      trait (a number, a range, an edit table) with less than :attr:`gesture_rest` seconds between the end of
      one and the next (a drag, a burst of arrow keys, however many of its values reach the kernel) extend one
      step (``Session.set_ops(gesture=)``). Toggles, choices, picks and changes made by code are a step each.

    Parameters
    ----------
    model : StaggerModel, WandModel or WarpModel
    session : Session
    references : dict, optional
        WarpModel only: ``{name: op reference JSON}`` of the extra reference clips.
    """

    #: seconds of rest that end a gesture (see the class docstring)
    gesture_rest = 1.0
    #: op traits set by picks and choices, never merged into a gesture (each change is its own undo step)
    _NOT_GESTURES = frozenset({"keep", "joints", "tau_joints", "keytimes"})
    _gesture_ids = itertools.count()

    def __init__(self, model: _Model, session, references: dict | None = None):
        self.model = model
        self._gesture = None   # (control trait, token, time the last change from it ended)
        self.session = session
        self.references = dict(references or {})
        if isinstance(model, StaggerModel):
            self.owned, self._home = STAGGER_OPS, _stagger_home
            from .views import ik_effectors
            model.source_duration = float(session.source.duration)
            model.ik_effectors = ik_effectors(session.source.skeleton)
        elif isinstance(model, WandModel):
            self.owned, self._home = WAND_OPS, _wand_home
            model.frame_time = float(session.source.frame_time)
        elif isinstance(model, WarpModel):
            self.owned, self._home = WARP_OPS, _warp_home
            model.source_duration = float(session.source.duration)
            model.frame_time = float(session.source.frame_time)
            model.reference_options = ["self", "segment"] + [n for n in self.references if n not in ("self", "segment")]
        else:
            raise ValueError(f"model: expected a StaggerModel, WandModel or WarpModel, got {type(model).__name__}")
        model.joint_names = list(session.source.skeleton.names)
        self._loading = False
        self._bases_prefix = None  # the op prefix model.edit_bases were recorded for
        self._notes: list = []
        self._error = ""
        self._last = model.params()
        self.pull()
        model.observe(self._on_model, names=model.trait_names(op=True))
        self._listener = _weak_listener(self._on_session, session)   # the session does not keep us alive
        session.observe(self._listener)

    def close(self) -> None:
        """Stop following: the model and the session no longer write to each other (again: nothing)."""
        if getattr(self, "_closed", False):
            return
        self._closed = True
        self.model.unobserve(self._on_model, names=self.model.trait_names(op=True))
        self.session.unobserve(self._listener)

    # -- pure parts, per model ------------------------------------------------------------------------
    def to_ops(self, params: dict) -> list:
        if isinstance(self.model, StaggerModel):
            return stagger_params_to_ops(params, self.model.edit_bases)
        if isinstance(self.model, WandModel):
            return wand_params_to_ops(params)
        return warp_params_to_ops(params, self.references, self.model.source_duration)

    def from_ops(self, ops: list, base: dict) -> tuple[dict, list]:
        names = self.model.joint_names
        if isinstance(self.model, StaggerModel):
            return stagger_ops_to_params(ops, base, names, self.model.edit_bases)
        if isinstance(self.model, WandModel):
            return wand_ops_to_params(ops, base, names, self.model.default_sigma or None)
        p, notes, new_refs = warp_ops_to_params(ops, base, self.references, self.model.source_duration)
        if new_refs:
            self.references.update(new_refs)
            self.model.reference_options = list(self.model.reference_options) + [
                n for n in new_refs if n not in self.model.reference_options]
        return p, notes

    def ops_for(self, **changes) -> list:
        """The session's op list as it would be if the model's op traits took ``changes`` (e.g.
        ``percent=40.0``), the ops the editor does not own kept in place; neither the model nor the session
        changes (e.g. to warm a slider's next positions with ``Session.warm(("replay", lists))``)."""
        new = dict(self.model.params(), **changes)
        return merge_ops(self.session.ops, self.to_ops(self._last), self.to_ops(new), self.owned, self._home)

    @contextlib.contextmanager
    def paused(self):
        """Model changes made inside are not written to the session (e.g. a control resetting its value while
        its options are replaced: the caller puts the model's value back before leaving)."""
        old, self._loading = self._loading, True
        try:
            yield self
        finally:
            self._loading = old

    # -- directions -----------------------------------------------------------------------------------
    def _on_model(self, change) -> None:
        if self._loading:
            return
        if change["name"] == "cull_by" and isinstance(self.model, StaggerModel):
            self._same_poses(change["new"])
        control = self.model._control_change
        gesture = self._gesture_of(change["name"], control)
        try:
            if not self.push(gesture) and self._error:   # refused: the model goes back to what the session holds
                self._revert()
                raise T.TraitError(self._error)
        finally:
            if gesture is not None:
                self._gesture = (control, gesture, time.monotonic())

    def _gesture_of(self, name: str, control):
        """The gesture token a change of op trait ``name`` made through the control of trait ``control`` is
        committed with: the last change's when it came from the same control and ended less than
        :attr:`gesture_rest` s ago, a new one otherwise; None (a step of its own) for a change made by code, a
        toggle, a choice or a pick."""
        trait = self.model.traits().get(name)
        if control is None or name in self._NOT_GESTURES or not isinstance(trait, (T.Float, T.Int, T.List, T.Dict)):
            self._gesture = None
            return None
        g = self._gesture
        if g is not None and g[0] == control and time.monotonic() - g[2] < self.gesture_rest:
            return g[1]
        return next(self._gesture_ids)

    def _same_poses(self, cull_by: str) -> None:
        """Switching the cull to "count" or "picked" starts from the poses the current cull keeps (its count,
        or its indices), so the pose edits, retimes and IK targets keep meaning the poses they meant."""
        m, cull = self.model, next((o for o in self.session.ops if o["op"] == "cull"), None)
        if cull is None or (cull_by == "keep" and m.keep) or (cull_by == "count" and m.count) or cull_by == "percent":
            return
        from ... import staggered
        try:
            kept = ([int(k) for k in cull["keep"]] if cull.get("keep") is not None else
                    [int(k) for k in staggered.cull_keep(self.session.extraction(), cull.get("percent"),
                                                         count=cull.get("count"))])
        except ValueError:
            return
        with self.paused():
            if cull_by == "keep":
                m.keep = kept
            else:
                m.count = len(kept)

    def _revert(self) -> None:
        m = self.model
        self._loading = True
        try:
            with m.loading(), m.hold_trait_notifications():
                for k, v in self._last.items():
                    if _canon(getattr(m, k)) != _canon(v):
                        setattr(m, k, copy.deepcopy(v))
        finally:
            self._loading = False

    def commit(self, ops: list, gesture=None) -> bool:
        """Write ``ops`` as the session's op list (one undo step, or the step of ``gesture``) if it replays;
        returns whether the list changed. Raises ValueError (:class:`~stagger_nb.session.ReplayError` for a
        replay failure) and leaves the session as it was otherwise."""
        if _canon(ops) == _canon(self.session.ops):
            return False
        try:
            self.session.check_ops(ops)
        except ReplayError as e:
            if not self._fails_already(e):
                raise
        return self.session.set_ops(ops, gesture=None if gesture is None else ("model", id(self), gesture))

    def _fails_already(self, error: ReplayError) -> bool:
        """Whether the session's own op list fails at the same op as ``error`` (replayed states are cached:
        only the failing op runs again)."""
        try:
            self.session.check_ops(self.session.ops)
        except ReplayError as e:
            return e.op.key == error.op.key
        return False

    def push(self, gesture=None) -> bool:
        """Model -> session (as one step of ``gesture``, a token of :meth:`_gesture_of`, when given). Returns True
        when the op list changed; False when nothing changed or the change was refused (then ``model.message``
        says why and the session is as it was)."""
        new = self.model.params()
        old_ops = self.to_ops(self._last)  # as written (with the bases they were written with)
        if isinstance(self.model, StaggerModel):
            # the bases belong to the state the edits apply to: a new cull (or anything before the edits)
            # drops them, and the nudges are written as deltas until that state is the session's
            cur = self.session.ops
            nxt = merge_ops(cur, old_ops, stagger_params_to_ops(new), self.owned, self._home)
            if _edit_prefix(nxt) != self._bases_prefix:
                self._clear_bases()
            if _edit_prefix(nxt) == _edit_prefix(cur):
                # bases for the nudges this change makes (every nudge when edit_mode changes: the toggle acts
                # on them all), only: an untouched edit keeps its form (deltas stay deltas, in place)
                old_edits, toggle = self._last["pose_edits"], new["edit_mode"] != self._last["edit_mode"]
                self._record_bases((k, j) for k, d in new["pose_edits"].items() for j in d
                                   if toggle or _canon(d[j]) != _canon(old_edits.get(k, {}).get(j)))
        ops = merge_ops(self.session.ops, old_ops, self.to_ops(new), self.owned, self._home)
        try:
            changed = self.commit(ops, gesture)
        except ValueError as e:
            self._error = plain_message(e)
            self._show()
            return False
        self._error = ""
        self._last = new
        if self.model.notes:   # a change went through (even one writing no op): earlier refusals are history
            self.model.notes = {}
        if not changed:
            self._show()
        return changed

    def _on_session(self, session) -> None:
        self.pull()

    def pull(self) -> None:
        """Session -> model (op traits set from the session's op list)."""
        if isinstance(self.model, StaggerModel):
            if _edit_prefix(self.session.ops) != self._bases_prefix:
                self._clear_bases()
            self._record_bases((int(o["pose"]), j) for o in self.session.ops if o["op"] == "edit_pose"
                               for j in o.get("targets") or {})
        if isinstance(self.model, WandModel):
            with self.model.loading():
                self.model.input_frames = _wand_input_frames(self.session)
        if isinstance(self.model, WarpModel):
            with self.model.loading():
                self.model.has_staggered = any(getattr(OPS.get(o["op"]), "needs", "") == "staggered"
                                               for o in self.session.ops if o["op"] != "guide_poses")
        params, notes = self.from_ops(self.session.ops, self.model.params())
        self._loading = True
        try:
            with self.model.loading(), self.model.hold_trait_notifications():
                for k, v in params.items():
                    if _canon(getattr(self.model, k)) != _canon(v):
                        setattr(self.model, k, v)
            m = self.model
            if isinstance(m, WandModel) and m.edits and m.edit_frame not in m.edits:
                with m.loading():
                    m.edit_frame = m.edited_frames[-1]
        except T.TraitError as e:   # a value the model refuses: say so, keep the op
            notes.append(f"{e}; the op is kept unchanged")
        finally:
            self._loading = False
        self._last = self.model.params()
        self._notes = notes
        self._error = ""
        self._show()

    def show_staggered(self, sm) -> None:
        """StaggerModel: show the staggered state ``sm`` (the session's last, drawn by the editor): its pose times,
        each pose's source frame (``staggered.source_pose_times``) and, while the region is on, the region's
        falloff at each pose (``Session.pose_falloff``: the scale of the timing edits there)."""
        from ... import staggered
        m = self.model
        ft = self.session.source.frame_time
        weights = []
        if m.region:
            try:
                weights = [float(w) for w in self.session.pose_falloff(m.region_frame, m.sigma or None)]
            except ValueError as e:     # a region frame past the clip: said in the message line
                self._notes = [n for n in self._notes if not n.startswith("region")] + [f"region: {e}"]
                self._show()
        with m.loading(), m.hold_trait_notifications():
            m.pose_times = [float(t) for t in sm.pose_times]
            m.pose_source_frames = [int(round(float(t) / ft)) for t in staggered.source_pose_times(sm)]
            m.region_weights = weights

    def show_quality(self, bounds=None) -> None:
        """StaggerModel: set ``model.quality`` from :meth:`Session.quality <stagger_nb.session.Session.quality>`
        of the current edit: ``{"text": summary, "ok": bool, "items": [{"text", "ok"}, ...]}`` (the one-line
        summary and its parts, each out-of-bounds part ``ok=False``); ``{}`` when the replay fails (the message
        line says why)."""
        try:
            q = self.session.quality(bounds)
        except ValueError:
            q = None
        value = {} if q is None else {"text": q.summary, "ok": bool(q.ok),
                                      "items": [{"text": i.text, "ok": bool(i.ok)} for i in q.items]}
        with self.model.loading():
            self.model.quality = value
        note = CONTACTS_HINT if (q is not None and isinstance(self.model, StaggerModel)
                                 and not self.model.keep_contacts
                                 and any(not i.ok and i.figure in FOOT_FIGURES for i in q.items)) else ""
        if note != self.model.hint:
            with self.model.loading():
                self.model.hint = note

    def _clear_bases(self) -> None:
        if self.model.edit_bases:
            with self.model.loading():
                self.model.edit_bases = {}
        self._bases_prefix = None

    def _record_bases(self, pairs) -> None:
        """StaggerModel: record in ``model.edit_bases`` the value of each new ``(pose, joint)`` in the staggered
        state the pose edits apply to (its editing knot, the true pose at ``t_k``: what the view shows), once;
        nothing when that state is not a staggered representation (the nudge is then written as deltas)."""
        m = self.model
        pairs = {(int(k), j) for k, j in pairs if j not in m.edit_bases.get(int(k), {})}
        if not pairs:
            return
        try:
            sm = self._edit_state()
        except ValueError:  # a replay error: shown by the editor; the nudges stay deltas
            sm = None
        knots = getattr(sm, "editing_knots", None)
        if knots is None:
            return
        names = list(sm.skeleton.names)
        bases = copy.deepcopy(m.edit_bases)
        for k, j in pairs:
            if 0 <= k < len(knots) and j in names:
                bases.setdefault(k, {})[j] = [float(x) for x in knots[k][names.index(j)]]
        with m.loading():
            m.edit_bases = bases
        self._bases_prefix = _edit_prefix(self.session.ops)

    def _edit_state(self):
        """The state the StaggerEditor's pose edits apply to: after :func:`_edit_prefix` of the session's ops
        (the source's extraction when it is empty)."""
        n = len(json.loads(_edit_prefix(self.session.ops)))
        return self.session.extraction() if n == 0 else self.session.states()[n - 1]

    def _show(self) -> None:
        notes = self._notes + [n for n in (getattr(self.model, "range_note", ""),) if n]   # WandModel's standing note
        self.model.message = "; ".join([self._error] + notes if self._error else notes)


def _weak_listener(method, session) -> Callable:
    """A ``session.observe`` listener calling the bound ``method`` while its object lives (a dropped editor's
    binding is not kept alive by the session it watched), then removing itself."""
    ref = weakref.WeakMethod(method)

    def listener(s):
        m = ref()
        if m is None:
            s.unobserve(listener)
        else:
            m(s)
    return listener
