"""One editor per technique: controls + a :class:`SkeletonView` + plots over a :class:`~stagger_nb.session.Session`.

The controls only write op dicts into the session (``session.set_ops``); the session replays them, re-running
only the tail that changed (its prefix memo and cached heads: extraction, pose graph/eigenbases, warp tables).
A session change (a control, undo/redo, or code calling ``editor.session.set_ops``) redraws the views in
place. Errors from the technique modules are shown in the editor's ``message`` HTML, never as a traceback.
"""
from __future__ import annotations

import html
import logging
import threading
from typing import Any, Callable

import ipywidgets as widgets
import numpy as np

from ..core.motion import Motion
from ..session import Session, joint_rotation_degrees
from .plots import FalloffPlot, JointCurvesPlot, ProbabilityPlot, WarpPlot
from .skeleton_view import SkeletonView

__all__ = ["StaggerEditor", "WandEditor", "WarpEditor"]

_log = logging.getLogger(__name__)

_SLIDER = dict(continuous_update=True, style={"description_width": "110px"}, layout=widgets.Layout(width="340px"))


def _session_for(motion, session: Session | None, source_path=None) -> Session:
    if session is not None:
        return session
    if isinstance(motion, Session):
        return motion
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion or a Session, got {type(motion).__name__}")
    return Session(motion, source_path=source_path)


class _Editor(widgets.VBox):
    """Common plumbing: message line, progress bar, undo/redo, session <-> controls sync."""

    def _setup(self, session: Session, view: SkeletonView, plots: list, controls: list, op_controls: list,
               view_controls: list = ()):
        self.session = session
        self.view = view
        self.plots = plots
        self.message = widgets.HTML("", layout=widgets.Layout(min_height="20px"))
        self.progress = widgets.IntProgress(value=0, min=0, max=1, description="computing",
                                            layout=widgets.Layout(visibility="hidden", width="300px"))
        self.undo_button = widgets.Button(description="undo", icon="undo", layout=widgets.Layout(width="90px"))
        self.redo_button = widgets.Button(description="redo", icon="repeat", layout=widgets.Layout(width="90px"))
        self.undo_button.on_click(lambda _: self.session.undo())
        self.redo_button.on_click(lambda _: self.session.redo())
        self._syncing = False
        self.warm_thread = self.warm_error = None
        self._lock = threading.RLock()
        for w in op_controls:
            w.observe(self._on_control, names="value")
        for w in view_controls:
            w.observe(self._on_view_control, names="value")
        for p in plots:
            p.on_frame_click(self._goto)
        if not session.ops:   # initial control values (e.g. a rotation given to the constructor) become ops
            initial = self._ops_from_controls()
            if initial:
                session.set_ops(initial)
        session.observe(self._on_session)
        session.observe_busy(self._on_busy)
        top = widgets.HBox([self.undo_button, self.redo_button, self.progress])
        # the plots take the width left beside the 3D view, or go below it (wrap) when less than 420 px is left
        body = widgets.HBox([view, widgets.VBox(plots, layout=widgets.Layout(flex="1 1 420px", min_width="0",
                                                                           max_width="100%"))],
                            layout=widgets.Layout(width="100%", flex_flow="row wrap", align_items="flex-start"))
        self.children = [top, widgets.VBox(controls), self.message, body]
        self._controls_from_ops(session.ops)
        self._update_buttons()
        self._refresh()

    def _start_warm(self, work: Callable[[Callable[[], bool]], Any]) -> None:
        """Run ``work(stop)`` in a daemon thread (cache warm-up: every result is also computed on demand,
        so a failure only means a cache miss later). ``stop()`` turns true when the editor is closed.
        A failure is kept in ``warm_error`` and logged, never lost; ``warm_thread`` is the thread."""
        self._closed = False
        self.warm_error = None

        def run():
            try:
                work(lambda: self._closed)
            except Exception as e:  # noqa: BLE001 - reported below; the foreground computes on demand
                self.warm_error = e
                _log.warning("%s: cache warm-up stopped: %s: %s", type(self).__name__, type(e).__name__, e)

        self.warm_thread = threading.Thread(target=run, name=f"{type(self).__name__}-warm-up", daemon=True)
        self.warm_thread.start()

    def close(self):
        self._closed = True   # a running warm-up stops after its current item
        super().close()

    def _tag(self, editor_class: str, **controls) -> None:
        """CSS classes for notebooks and the browser test: ``sn-<name>`` on each named control."""
        self.add_class(editor_class)
        for name, w in controls.items():
            w.add_class(f"sn-{name.replace('_', '-')}")

    # -- plumbing -------------------------------------------------------------------------------------
    def _goto(self, frame: int) -> None:
        self.view.frame = int(frame)

    def _show_error(self, e: Exception) -> None:
        self.message.value = (f'<span style="color:#c53030">&#9888; {html.escape(type(e).__name__)}: '
                              f'{html.escape(str(e))}</span>')

    def _on_control(self, change=None) -> None:
        if self._syncing:
            return
        try:
            ops = self._ops_from_controls()
            with self._lock:
                changed = self.session.set_ops(ops)
            if not changed:
                self._refresh()
        except Exception as e:  # the UI boundary: report, never raise into the frontend
            self._show_error(e)

    def _on_view_control(self, change=None) -> None:
        if not self._syncing:
            self._refresh()

    def _on_session(self, session) -> None:
        self._syncing = True
        try:
            self._controls_from_ops(session.ops)
        finally:
            self._syncing = False
        self._update_buttons()
        self._refresh()

    def _update_buttons(self):
        self.undo_button.disabled = not self.session.can_undo
        self.redo_button.disabled = not self.session.can_redo

    def _on_busy(self, kind: str, started: bool) -> None:
        if threading.current_thread() is self.warm_thread:
            return  # the background warm-up: nobody waits for it, and it must not hide a foreground bar
        labels = {"extract": "extracting poses", "graph": "pose graph", "basis": "eigenvectors",
                  "warp": "kNN tables"}
        if started:
            self.progress.description = labels.get(kind, kind)
            self.progress.value = 0
            self.progress.layout.visibility = "visible"
        else:
            self.progress.value = 1
            self.progress.layout.visibility = "hidden"

    def _on_progress(self, done, total, label) -> None:
        if total > 1 and self.progress.layout.visibility == "visible":
            self.progress.max = total
            self.progress.value = done

    def _refresh(self) -> None:
        try:
            with self._lock:
                edited = self.session.edited(progress=self._on_progress)
                self._update_views(edited)
            if not self._message_is_warning():
                self.message.value = ""
        except Exception as e:  # the UI boundary
            self._show_error(e)

    def _message_is_warning(self) -> bool:
        return False

    # -- per editor -----------------------------------------------------------------------------------
    def _ops_from_controls(self) -> list:
        raise NotImplementedError

    def _controls_from_ops(self, ops: list) -> None:
        raise NotImplementedError

    def _update_views(self, edited: Motion) -> None:
        raise NotImplementedError

    def _set(self, widget, value) -> None:
        """Set a control without triggering a session change."""
        old, self._syncing = self._syncing, True
        try:
            widget.value = value
        finally:
            self._syncing = old


def _joint_options(motion: Motion):
    return list(motion.skeleton.names)


def _default_joint(motion: Motion, *preferred) -> str:
    names = motion.skeleton.names
    for p in preferred:
        for n in names:
            if n.lower() == p.lower():
                return n
    return names[min(len(names) - 1, 1)]


class StaggerEditor(_Editor):
    """Staggered-pose editor (Coleman et al. 2008): cull %, succession (root, s, l), random timing (τ, seed,
    joints), pose nudges and exaggeration ``w_r``; a 3D view with the original as ghost, the joint curves
    with pose times and refinement knots, and the pose probability with candidate and kept poses.

    Parameters
    ----------
    motion : Motion or Session
    session : Session, optional
        Edit this session (its op list is shown and edited); default a new one on ``motion``.
    precompute : bool
        Warm the cull cache for every slider position in a background thread (each cull is a refit).
    show_ghost : bool
        Start with the original shown as a grey ghost beside the edit (off: playback then streams only
        J * 3 floats per frame; the checkbox under the view turns it on).
    """

    _CULL_STEP = 5.0

    def __init__(self, motion, session: Session | None = None, source_path=None, precompute: bool = True,
                 show_ghost: bool = False, **kwargs):
        super().__init__(**kwargs)
        session = _session_for(motion, session, source_path)
        m = session.source
        names = _joint_options(m)
        self.cull = widgets.FloatSlider(value=100.0, min=self._CULL_STEP, max=100.0, step=self._CULL_STEP,
                                        description="keep poses %", readout_format=".0f", **_SLIDER)
        self.root = widgets.Dropdown(options=names, value=_default_joint(m, "LeftShoulder", "LeftArm", "lShldr"),
                                     description="succession root", style=_SLIDER["style"])
        self.s = widgets.FloatSlider(value=0.0, min=-0.1, max=0.1, step=0.005, description="s (s/bone)",
                                     readout_format=".3f", **_SLIDER)
        self.l = widgets.FloatSlider(value=1.0, min=0.25, max=4.0, step=0.05, description="exponent l", **_SLIDER)
        self.tau = widgets.FloatSlider(value=0.0, min=0.0, max=0.15, step=0.005, description="random τ (s)",
                                       readout_format=".3f", **_SLIDER)
        self.seed = widgets.BoundedIntText(value=0, min=0, max=2**31 - 1, description="seed",
                                           layout=widgets.Layout(width="160px"))
        self.joint_set = widgets.SelectMultiple(options=names, value=(), rows=5, description="τ joints",
                                                layout=widgets.Layout(width="260px"))
        self.w_r = widgets.FloatSlider(value=0.0, min=-1.0, max=2.0, step=0.05, description="exaggerate w_r",
                                       **_SLIDER)
        self.pose = widgets.IntSlider(value=0, min=0, max=1, description="pose k", **_SLIDER)
        self.joint = widgets.Dropdown(options=names, value=_default_joint(m, "LeftElbow", "LeftForeArm", "lForeArm"),
                                      description="joint", style=_SLIDER["style"])
        self.nudge = [widgets.FloatSlider(value=0.0, min=-90, max=90, step=1, description=f"nudge {c} (°)",
                                          **_SLIDER) for c in "xyz"]
        self._nudges: dict = {}   # {pose k: {joint: [rx, ry, rz] degrees}}
        self._closed = False
        self._warning = False

        view = SkeletonView(m, ghost=m, show_ghost=show_ghost)
        self.curves = JointCurvesPlot(m.frame_time)
        self.probability = ProbabilityPlot(m.frame_time)
        for w in self.nudge:
            w.observe(self._on_nudge, names="value")
        self.pose.observe(self._on_pose_or_joint, names="value")
        self.joint.observe(self._on_pose_or_joint, names="value")
        controls = [
            widgets.HBox([self.cull, self.w_r]),
            widgets.HBox([self.root, self.s, self.l]),
            widgets.HBox([self.tau, self.seed, self.joint_set]),
            widgets.HBox([self.pose, self.joint]),
            widgets.HBox(self.nudge),
        ]
        self._tag("sn-stagger-editor", cull=self.cull, s=self.s, l=self.l, tau=self.tau, w_r=self.w_r)
        self._setup(session, view, [self.curves, self.probability], controls,
                    op_controls=[self.cull, self.root, self.s, self.l, self.tau, self.seed, self.joint_set, self.w_r])
        if precompute:
            self._start_warm(self._warm_cull)

    # -- ops ------------------------------------------------------------------------------------------
    def _ops_from_controls(self) -> list:
        ops = []
        if self.cull.value < 100.0:
            ops.append({"op": "cull", "percent": float(self.cull.value)})
        for k in sorted(self._nudges):
            deltas = {j: list(v) for j, v in self._nudges[k].items() if any(v)}
            if deltas:
                ops.append({"op": "edit_pose", "pose": int(k), "deltas": deltas})
        if self.w_r.value != 0.0:
            ops.append({"op": "exaggerate", "w_r": float(self.w_r.value)})
        if self.s.value != 0.0:
            ops.append({"op": "succession", "root": self.root.value, "s": float(self.s.value),
                        "l": float(self.l.value)})
        if self.tau.value > 0.0:
            ops.append({"op": "random_timing", "tau": float(self.tau.value), "seed": int(self.seed.value),
                        "joints": list(self.joint_set.value) or None})
        return ops

    def _controls_from_ops(self, ops: list) -> None:
        by = {}
        nudges = {}
        for op in ops:
            if op["op"] == "edit_pose":
                nudges[op["pose"]] = {j: list(v) for j, v in op["deltas"].items()}
            else:
                by[op["op"]] = op
        self._nudges = nudges
        self._set(self.cull, by.get("cull", {}).get("percent", 100.0))
        self._set(self.w_r, by.get("exaggerate", {}).get("w_r", 0.0))
        succ = by.get("succession")
        self._set(self.s, succ["s"] if succ else 0.0)
        if succ:
            self._set(self.root, succ["root"])
            self._set(self.l, succ["l"])
        rt = by.get("random_timing")
        self._set(self.tau, rt["tau"] if rt else 0.0)
        if rt:
            self._set(self.seed, rt["seed"])
            self._set(self.joint_set, tuple(rt["joints"] or ()))
        self._show_nudge()

    def _show_nudge(self):
        v = self._nudges.get(self.pose.value, {}).get(self.joint.value, [0.0, 0.0, 0.0])
        for w, x in zip(self.nudge, v):
            self._set(w, x)

    def _on_pose_or_joint(self, change):
        if self._syncing:
            return
        self._show_nudge()
        self._refresh()

    def _on_nudge(self, change):
        if self._syncing:
            return
        self._nudges.setdefault(self.pose.value, {})[self.joint.value] = [float(w.value) for w in self.nudge]
        self._on_control()

    def _warm_cull(self, stop):
        """Cache the cull result of every slider position (background thread; each cull is a refit)."""
        pcs = np.arange(100.0 - self._CULL_STEP, self._CULL_STEP - 1e-9, -self._CULL_STEP)
        self.session.precompute_cull([float(p) for p in pcs], stop=stop)

    # -- views ----------------------------------------------------------------------------------------
    def _message_is_warning(self) -> bool:
        return self._warning

    def _update_views(self, edited: Motion) -> None:
        sm = self.session.staggered()
        full = self.session.extraction()
        m = self.session.source
        ft = m.frame_time
        K = sm.num_poses
        with self.pose.hold_trait_notifications():
            self._set(self.pose, min(self.pose.value, K - 1))
            self.pose.max = K - 1
        j = m.skeleton.index(self.joint.value)
        kept = np.asarray(sm.pose_times)
        prob = full.metadata.get("probability")
        times = np.arange(m.num_frames) * ft
        cand_t = np.asarray(full.pose_times)
        self.probability.update(times if prob is not None else None, prob, cand_t, full.pose_probability,
                                kept, np.interp(kept, times, prob) if prob is not None else sm.pose_probability)
        knots = kept + np.asarray(sm.refinements)[:, j]
        self.curves.update(edited.times, joint_rotation_degrees(edited, j), joint_rotation_degrees(m, j),
                           pose_times=kept, knot_times=knots,
                           title=f"{self.joint.value}: rotation vector (°), edited vs original; pose k={self.pose.value} "
                                 f"at {kept[self.pose.value]:.2f} s")
        self.view.set_motion(edited)
        self.view.set_pose_frames(np.round(kept / ft).astype(int))
        self.view.set_contacts(list(getattr(sm, "contacts", ())))
        self.view.highlight_joints([self.joint.value])
        warnings = sm.metadata.get("warnings") or ()
        self._warning = bool(warnings)
        if warnings:
            w0 = warnings[0]
            text = getattr(w0, "message", str(w0))
            self.message.value = (f'<span style="color:#b7791f">&#9888; {len(warnings)} timing warning(s): '
                                  f'{html.escape(text)}</span>')


class WandEditor(_Editor):
    """Magic-wand editor (Dean et al. 2018): rotate a joint at the edited frame and propagate the edit with
    the Green's-function falloff; σ slider (cached pose graph, one eigenbasis per σ), edit range, propagate
    on/off, comparison curves (ISOMAP, diffusion, spline).

    Parameters
    ----------
    motion : Motion or Session
    frame : int, optional
        Edited frame (default the middle).
    joint : str, optional
        Joint whose rotation the sliders edit.
    rotation : (3,) degrees, optional
        Initial rotation-vector edit of ``joint``.
    """

    _SIGMA_STEP = 0.04   # log10 units between slider positions
    _SIGMA_STEPS = 15    # positions each side of the default sigma (x 0.25 .. x 4)

    def __init__(self, motion, session: Session | None = None, frame: int | None = None, joint: str | None = None,
                 rotation=(0.0, 0.0, 0.0), source_path=None, precompute: bool = True, show_ghost: bool = False,
                 **kwargs):
        super().__init__(**kwargs)
        session = _session_for(motion, session, source_path)
        m = session.source
        F = m.num_frames
        names = _joint_options(m)
        graph = session.wand_graph()
        s0 = float(graph.default_sigma)
        # the slider's positions: sigma snaps to this grid, whose bases are precomputed in the background
        self._sigma_grid = s0 * 10.0 ** (self._SIGMA_STEP * np.arange(-self._SIGMA_STEPS, self._SIGMA_STEPS + 1))
        self.sigma = widgets.FloatLogSlider(value=s0, base=10, min=np.log10(self._sigma_grid[0]),
                                            max=np.log10(self._sigma_grid[-1]), step=self._SIGMA_STEP,
                                            description="σ", readout_format=".3g", **_SLIDER)
        self.frame = widgets.IntSlider(value=F // 2 if frame is None else int(frame), min=0, max=F - 1,
                                       description="edited frame", **_SLIDER)
        self.limit_range = widgets.Checkbox(value=False, description="limit edit range", indent=False)
        self.range = widgets.IntRangeSlider(value=(0, F), min=0, max=F, description="range [start, stop)",
                                            **_SLIDER)
        self.joint = widgets.Dropdown(options=names, value=joint or _default_joint(m, "LeftUpLeg", "LeftHip",
                                                                                    "LeftFemur", "lThigh"),
                                      description="joint", style=_SLIDER["style"])
        self.rotation = [widgets.FloatSlider(value=float(r), min=-90, max=90, step=1, description=f"rotate {c} (°)",
                                             **_SLIDER) for c, r in zip("xyz", rotation)]
        self.propagate = widgets.Checkbox(value=True, description="propagate (off: edit one frame)", indent=False)
        self.compare = {name: widgets.Checkbox(value=False, description=name, indent=False,
                                               layout=widgets.Layout(width="110px"))
                        for name in ("isomap", "diffusion", "spline")}
        self.show_sweep = widgets.Checkbox(value=False, description="σ sweep (Fig. 5)", indent=False)
        self._deltas = {}
        if any(rotation):
            self._deltas[self.joint.value] = [float(r) for r in rotation]

        view = SkeletonView(m, ghost=m, show_ghost=show_ghost)
        self.falloff_plot = FalloffPlot(m.frame_time, sweep=5)
        self.curves = JointCurvesPlot(m.frame_time)
        for w in self.rotation:
            w.observe(self._on_rotation, names="value")
        self.joint.observe(self._on_joint, names="value")
        controls = [widgets.HBox([self.sigma, self.frame, self.propagate]),
                    widgets.HBox([self.limit_range, self.range]),
                    widgets.HBox([self.joint] + self.rotation),
                    widgets.HBox([widgets.Label("compare:")] + list(self.compare.values()) + [self.show_sweep])]
        self._tag("sn-wand-editor", sigma=self.sigma, frame=self.frame)
        self._setup(session, view, [self.falloff_plot, self.curves], controls,
                    op_controls=[self.sigma, self.frame, self.limit_range, self.range, self.propagate],
                    view_controls=list(self.compare.values()) + [self.show_sweep])
        self.view.frame = max(0, min(F - 1, self.frame.value + F // 6))
        if precompute:
            self._start_warm(self._warm_bases)

    def _snapped_sigma(self, value: float) -> float:
        return float(self._sigma_grid[np.argmin(np.abs(np.log(self._sigma_grid) - np.log(value)))])

    def _warm_bases(self, stop):
        """Cache the eigenbasis of every slider position, nearest to the current sigma first."""
        order = np.argsort(np.abs(np.log(self._sigma_grid) - np.log(self.sigma.value)), kind="stable")
        self.session.precompute_wand_bases([float(self._sigma_grid[i]) for i in order], stop=stop)

    def _frame_range(self):
        return list(self.range.value) if self.limit_range.value else None

    def _ops_from_controls(self) -> list:
        deltas = {j: list(v) for j, v in self._deltas.items() if any(v)}
        if self.propagate.value:
            return [{"op": "propagate", "frame": int(self.frame.value), "deltas": deltas,
                     "sigma": self._snapped_sigma(self.sigma.value), "frame_range": self._frame_range()}]
        return [{"op": "edit_frame", "frame": int(self.frame.value), "deltas": deltas}] if deltas else []

    def _controls_from_ops(self, ops: list) -> None:
        if not ops:
            self._deltas = {}
        else:
            op = ops[-1]
            self._deltas = {j: list(v) for j, v in op.get("deltas", {}).items()}
            self._set(self.frame, op["frame"])
            self._set(self.propagate, op["op"] == "propagate")
            if op["op"] == "propagate":
                if op.get("sigma") is not None:
                    self._set(self.sigma, op["sigma"])
                fr = op.get("frame_range")
                self._set(self.limit_range, fr is not None)
                if fr is not None:
                    self._set(self.range, tuple(fr))
        v = self._deltas.get(self.joint.value, [0.0, 0.0, 0.0])
        for w, x in zip(self.rotation, v):
            self._set(w, x)

    def _on_rotation(self, change):
        if self._syncing:
            return
        self._deltas[self.joint.value] = [float(w.value) for w in self.rotation]
        self._on_control()

    def _on_joint(self, change):
        if self._syncing:
            return
        v = self._deltas.get(self.joint.value, [0.0, 0.0, 0.0])
        for w, x in zip(self.rotation, v):
            self._set(w, x)
        self._refresh()

    def _update_views(self, edited: Motion) -> None:
        m = self.session.source
        f = int(self.frame.value)
        sigma = self._snapped_sigma(self.sigma.value)
        compare = [n for n, w in self.compare.items() if w.value]
        fr = self._frame_range()
        curves = self.session.falloff_curves(f, sigma, fr, compare=compare)
        sweep = None
        if self.show_sweep.value:
            i = int(np.argmin(np.abs(self._sigma_grid - sigma)))
            picks = np.clip(i + np.array([-10, -5, 0, 5, 10]), 0, len(self._sigma_grid) - 1)
            sweep = [(f"σ={s:.3g}", self.session.falloff_curves(f, s, fr)["green"])
                     for s in self._sigma_grid[picks]]
        self.falloff_plot.update(m.times, curves, frame=f, sweep=sweep,
                                 title=f"Green's falloff from frame {f} (σ = {sigma:.3g})")
        j = m.skeleton.index(self.joint.value)
        self.curves.update(edited.times, joint_rotation_degrees(edited, j), joint_rotation_degrees(m, j),
                           pose_times=[f * m.frame_time],
                           title=f"{self.joint.value}: rotation vector (°), edited vs original")
        self.view.set_motion(edited)
        self.view.highlight_joints([self.joint.value])
        self.view.set_pose_frames([f])


class WarpEditor(_Editor):
    """Guided time-warping editor (Hsu et al. 2007): target duration, skip limit ``s``, keytimes, reference
    (the input itself, another clip, or a segment of the input) and linear-vs-guided; the warp curve and its
    log-scale derivative (Fig. 5).

    Parameters
    ----------
    motion : Motion or Session
    reference : Motion, path, dict {name: Motion or path}, or None
        Extra reference clips offered besides "self" and "segment". A Motion is offered as "reference".
        Clips given as paths are recorded in the session by path, so a saved session reloads them; an
        in-memory Motion is recorded as ``{"path": "<memory:name>"}``, which a new process cannot reload
        (save such sessions after choosing "self"/"segment", or pass the clip's path).
    """

    def __init__(self, motion, reference=None, session: Session | None = None, source_path=None,
                 show_ghost: bool = False, **kwargs):
        super().__init__(**kwargs)
        session = _session_for(motion, session, source_path)
        m = session.source
        self._references = {}
        if isinstance(reference, Motion):
            self._references["reference"] = reference
        elif isinstance(reference, dict):
            self._references.update(reference)
        elif reference is not None and not isinstance(reference, (str,)):
            raise ValueError(f"reference: expected a Motion, a dict of them or None, got {type(reference).__name__}")
        elif isinstance(reference, str):
            self._references["reference"] = reference
        options = ["self", "segment"] + list(self._references)
        D = m.duration
        self.mode = widgets.ToggleButtons(options=["guided", "linear"], value="guided", description="warp")
        self.duration = widgets.FloatSlider(value=round(0.75 * D, 3), min=round(D / 8 + m.frame_time, 3),
                                            max=round(D, 3), step=m.frame_time, description="duration (s)",
                                            readout_format=".2f", **_SLIDER)
        self.skip = widgets.IntSlider(value=8, min=2, max=16, description="skip s", **_SLIDER)
        self.reference = widgets.Dropdown(options=options, value="self" if not self._references else options[2],
                                          description="reference", style=_SLIDER["style"])
        self.segment = widgets.FloatRangeSlider(value=(0.0, round(D / 2, 3)), min=0.0, max=round(D, 3),
                                                step=m.frame_time, description="segment (s)", readout_format=".2f",
                                                **_SLIDER)
        self.keytimes = widgets.Text(value="", placeholder="in:out, in:out  (seconds)", description="keytimes",
                                     style=_SLIDER["style"], layout=widgets.Layout(width="340px"))
        view = SkeletonView(m, ghost=m, show_ghost=show_ghost)
        self.warp_plot = WarpPlot(m.frame_time)
        controls = [widgets.HBox([self.mode, self.skip]),
                    widgets.HBox([self.duration, self.keytimes]),
                    widgets.HBox([self.reference, self.segment])]
        self._tag("sn-warp-editor", duration=self.duration, skip=self.skip)
        self._setup(session, view, [self.warp_plot], controls,
                    op_controls=[self.mode, self.duration, self.skip, self.reference, self.segment, self.keytimes])

    def _reference_json(self):
        r = self.reference.value
        if r == "self":
            return "self"
        if r == "segment":
            return {"segment": [float(x) for x in self.segment.value]}
        ref = self._references[r]
        if isinstance(ref, Motion):
            return self.session.use_reference(f"<memory:{r}>", ref)
        return {"path": str(ref)}

    def _parse_keytimes(self):
        text = self.keytimes.value.strip()
        if not text:
            return None
        pairs = []
        for item in text.replace(";", ",").split(","):
            if not item.strip():
                continue
            a, sep, b = item.partition(":")
            if not sep:
                raise ValueError(f"keytimes: {item.strip()!r} is not 'input_time:output_time'")
            pairs.append([float(a), float(b)])
        return pairs

    def _ops_from_controls(self) -> list:
        kt = self._parse_keytimes()
        if self.mode.value == "linear":
            return [{"op": "linear_warp", "duration": float(self.duration.value), "keytimes": kt}]
        return [{"op": "guided_warp", "duration": float(self.duration.value), "skip": int(self.skip.value),
                 "keytimes": kt, "reference": self._reference_json()}]

    def _controls_from_ops(self, ops: list) -> None:
        if not ops:
            return
        op = ops[-1]
        self._set(self.mode, "linear" if op["op"] == "linear_warp" else "guided")
        self._set(self.duration, op["duration"])
        kt = op.get("keytimes")
        self._set(self.keytimes, ", ".join(f"{a:g}:{b:g}" for a, b in kt) if kt else "")
        if op["op"] == "guided_warp":
            self._set(self.skip, op["skip"])
            ref = op["reference"]
            if ref == "self":
                self._set(self.reference, "self")
            elif "segment" in ref:
                self._set(self.reference, "segment")
                self._set(self.segment, tuple(ref["segment"]))

    def _update_views(self, edited: Motion) -> None:
        from .. import timewarp
        ft = edited.frame_time
        warp = self.session.warp_curve(-1) if self.session.ops else None
        if warp is None:   # no warp op (e.g. undone): the identity
            warp = edited.times
        out_t = np.arange(len(warp)) * ft
        kt = self._parse_keytimes()
        self.warp_plot.update(out_t, warp, timewarp.warp_speed(warp, ft), keytimes=kt,
                              title=f"{self.mode.value} warp: {self.session.source.duration:.2f} s → "
                                    f"{out_t[-1]:.2f} s")
        self.view.set_motion(edited)
