"""The magic-wand editor (Dean et al. 2018) over a :class:`~stagger_nb.session.models.WandModel`."""
from __future__ import annotations

import html
import math
import weakref

import ipywidgets as widgets
import traitlets

from ..core.motion import Motion
from ..plotting import EDIT_COLOUR, falloff_figure, joint_curves_figure
from ..session import Session
from ..session.heads import DIFFUSION_MAX_FRAMES
from ..session.models import WandModel
from ..session.models.views import joint_curves_view
from ._controls import _STYLE, _inert, _inline, _link, _slider
from ._editor import _Editor, _session_for
from ._lifecycle import _on_kernel_thread
from ._sizes import _PLOT_HEIGHT, _VIEW_SIZE, _WIDE, _default_joint, _x_span
from .plots import PlotView
from .skeleton_view import SkeletonView

_TOGGLES = {"description_width": "120px", "button_width": "72px"}   # the label and its buttons on one line

__all__ = ["WandEditor"]

_SIGMA_TIP = ("σ, the width of the pose-space kernel (Dean et al. 2018, §3.3; pose-vector units): it sets how far "
              "the edit reaches; the falloff plot shows the reach of each σ (not always wider for a larger σ: on "
              "CMU 01_01 x4 reaches about half as far as x1)")


class _RotateSlider(widgets.FloatSlider):
    """A rotate slider whose values from the browser are not echoed back (``echo_update=False``): during a drag
    the kernel's echo of an older value would pull the handle back, and the next move then jumps (a 60 px drag
    landed on 90°). The model's own changes (a rounded or refused value) are still sent."""

    value = traitlets.CFloat(0.0, help="Float value").tag(sync=True, echo_update=False)


def _clear_status(ref) -> None:
    ed = ref()
    if ed is not None:
        ed.status.value = ""


class WandEditor(_Editor):
    """Magic-wand editor (Dean et al. 2018): rotate joints at one or more edited frames and propagate the edit
    with the Green's-function falloff of width σ (§3.3); keep or discard repetitions; compare the falloff with
    ISOMAP, diffusion and spline falloffs (Fig. 3, 6).

    Parameters
    ----------
    motion : Motion or Session
    frame : int, optional
        Edited frame (default the middle).
    joint : str, optional
        Joint whose rotation the sliders edit.
    rotation : (3,) degrees, optional
        Initial rotation-vector edit of ``joint`` (written as an op when the session has no wand op).
    """

    _css = "sn-wand-editor"
    _ALIASES = {"rotation": ("rx", "ry", "rz")}

    def __init__(self, motion, session: Session | None = None, frame: int | None = None, joint: str | None = None,
                 rotation=(0.0, 0.0, 0.0), source_path=None, precompute: bool = True, show_ghost: bool = False,
                 **kwargs):
        super().__init__(**kwargs)
        session = _session_for(self, motion, session, source_path)
        m = session.source
        F, ft = m.num_frames, m.frame_time
        names = list(m.skeleton.names)
        s0 = float(session.wand_graph().default_sigma)
        f0 = F // 2 if frame is None else int(frame)
        joint = joint or _default_joint(names, "LeftUpLeg", "LeftHip", "LeftFemur", "lThigh")
        model = WandModel(sigma=s0, default_sigma=s0, joint=joint, frame=f0, frame_time=m.frame_time)
        with model.loading():
            model.edit_frame = f0
        c = {}
        grid = model.sigma_grid   # FloatLogSlider's min, max and step are base-10 exponents
        c["sigma"] = widgets.FloatLogSlider(base=10, min=math.log10(grid[0]), max=math.log10(grid[-1]),
                                            step=model.SIGMA_STEP, description="falloff width σ",
                                            readout_format=".3g", continuous_update=True, style=_STYLE,
                                            layout=_WIDE, tooltip=_SIGMA_TIP)
        # the edited frame in seconds (2,751 frames on CMU 01_01): one arrow key = one frame, a drag = coarse
        c["edit_frame"] = _slider(widgets.FloatSlider, "edited frame (s)", min=0.0, max=round((F - 1) * ft, 4),
                                  step=ft, readout_format=".2f")
        c["propagate"] = widgets.Checkbox(description="propagate (off: edit the frames only)", indent=False)
        c["repetitions"] = _inline(widgets.ToggleButtons(options=["keep", "discard"], description="repetitions",
                                                         style=_TOGGLES,
                                                         tooltips=["propagate to repeats of the edited pose",
                                                                   "edit only the neighbourhood (§3.3)"]))
        c["joint"] = widgets.Dropdown(options=names, description="joint", style=_STYLE)
        for a in "xyz":   # +-60 on a wide track (a drag 0.2 deg/px, a key 1 deg); a typed value past it grows it
            c["r" + a] = _slider(_RotateSlider, f"rotate {a} (°)", min=-60.0, max=60.0, step=model.step("r" + a),
                                 readout_format=".0f")
        c["compare"] = widgets.SelectMultiple(options=["isomap", "diffusion", "spline"], rows=3,
                                              description="compare with", style=_STYLE)
        self.controls = c
        self.limit_range = widgets.Checkbox(value=False, description="limit edit range", indent=False)
        self.range = _slider(widgets.FloatRangeSlider, "edit range (s)", min=0.0, max=round(F * ft, 4), step=ft,
                             value=(0.0, round(F * ft, 4)), readout_format=".1f")   # .2f was cut at 72 px
        self.edited_frames = widgets.Dropdown(options=[], description="edited frames", style=_STYLE)
        self.add_button = widgets.Button(description="add edit at playhead", layout=widgets.Layout(width="180px"))
        self.remove_button = widgets.Button(description="remove this edit", layout=widgets.Layout(width="150px"))
        self.add_button.on_click(lambda _: self._add_at_playhead())
        self.remove_button.on_click(lambda _: self._remove_selected())

        view = SkeletonView(m, ghost=m, show_ghost=show_ghost, pose_label="edited frame", **_VIEW_SIZE)
        self.falloff_plot = PlotView(frame_time=m.frame_time)
        self.curves = PlotView(frame_time=m.frame_time)
        # what the background warm-up is computing (seconds on a long clip): said until it is done
        self.status = widgets.HTML("", layout=widgets.Layout(min_height="0"))
        self.status.add_class("sn-wand-status")
        quick = [c["sigma"], self.status, c["rx"], c["ry"], c["rz"]]
        tools = {"edit": [widgets.HBox([c["joint"]]), widgets.HBox([c["edit_frame"]]),
                          widgets.HBox([self.edited_frames]), widgets.HBox([self.add_button, self.remove_button])],
                 "propagation": [widgets.HBox([c["propagate"]]), widgets.HBox([c["repetitions"]]),
                                 widgets.HBox([self.limit_range]), widgets.HBox([self.range])],
                 "compare": [widgets.HBox([c["compare"]])]}
        c["sigma"].add_class("sn-sigma")
        c["edit_frame"].add_class("sn-edit-frame")
        self.range.add_class("sn-edit-range")
        self.limit_range.add_class("sn-limit-range")
        for a in "xyz":
            c["r" + a].add_class(f"sn-r{a}")
        self._setup(model, session, view, [self.falloff_plot, self.curves], tools, quick=quick)
        if not model.edits and any(rotation):   # an initial rotation becomes the first edit
            model.rx, model.ry, model.rz = (float(r) for r in rotation)
        # slider positions snap to the warmed sigma grid
        self._links.append(_link(model, "sigma", c["sigma"], log=True, transform=(float, model.snap_sigma)))
        for k in ("propagate", "repetitions", "joint", "rx", "ry", "rz"):
            self._links.append(_link(model, k, c[k]))
        # frames <-> seconds on the slider (the model keeps frames: the ops index frames)
        self._links.append(_link(model, "edit_frame", c["edit_frame"],
                                 transform=(lambda f: round(model.time_of(f), 4), model.frame_at)))
        self._links.append(_link(model, "compare", c["compare"], transform=(tuple, list)))
        self._links.append(_link(model, "frame_range", self.range, transform=(
            model.range_seconds, model.range_frames)))
        self.limit_range.value = bool(model.frame_range)
        self.limit_range.observe(self._on_limit, names="value")
        self._range_link_paused = False
        model.observe(self._on_edits, names=["edits", "edit_frame"])
        model.observe(self._on_inert, names=["propagate", "frame_range"])
        # what the plots show besides the ops: a change that writes no op (sigma, the range or the edited frame
        # before any rotation, an empty edit) still redraws them (the drawn key skips a second draw)
        model.observe(self._on_view_state, names=["compare", "joint", "sigma", "frame_range", "edit_frame", "edits",
                                                  "repetitions", "propagate"])
        self.edited_frames.observe(self._on_pick_edit, names="value")
        self._on_edits()
        self._on_inert()
        if precompute:   # after first paint: the sigma slider's nearest positions, the comparisons' heads (a
            # first "compare" choice then draws at once), then the other positions; cancellable, yields to the user
            sigmas = model.sigmas_nearest_first()
            heads = [("isomap", None)] + ([("diffusion", float(model.sigma))] if F <= DIFFUSION_MAX_FRAMES else [])
            # one short line (the side column must not grow past the 3D view: the first plot stays on the first
            # screen); the whole sentence is the hover text
            self.status.value = (f'<span style="color:#2b6cb0;display:block;white-space:nowrap;overflow:hidden;'
                                 'text-overflow:ellipsis" title="the falloff for the σ '
                                 "positions nearest yours, then the comparison curves; a σ move or compare choice "
                                 f'meanwhile computes its own">preparing in the background ({F} frames)…</span>')
            fut = self._warm(("wand_basis", sigmas[:5]), ("compare", heads), ("wand_basis", sigmas[5:]))
            me = weakref.ref(self)
            fut.add_done_callback(lambda f: _on_kernel_thread(_clear_status, me))

    def _on_limit(self, change) -> None:
        """"limit edit range": ticked, the propagation is limited to the range slider's span; when that is the
        whole clip (nothing to see: the falloff would not change), to a window around the edited frames, a
        quarter of the clip each side (drag the range to change it)."""
        m = self.model
        if change["new"] and not m.frame_range:
            rng = m.range_frames(self.range.value)
            n = m.input_frames or self.session.source.num_frames
            if rng[0] <= 0 and rng[1] >= n:
                frames = m.edited_frames or [int(m.edit_frame)]
                rng = [max(0, min(frames) - n // 4), min(n, max(frames) + n // 4 + 1)]
            m.set_control("frame_range", rng)
        elif not change["new"] and m.frame_range:
            m.set_control("frame_range", [])

    def _add_at_playhead(self) -> None:
        """"add edit at playhead": a new edited frame at the playhead (the falloff plot moves there; rotate a
        joint to edit it), or the edit already there selected; said in the message line either way."""
        m, f = self.model, int(self.model.frame)
        if f in m.edits:
            m.edit_frame = f
            self._add_note = f"frame {f} ({m.time_of(f):.2f} s) is already edited: selected"
        else:
            m.add_edit(f)
            self._add_note = (f"frame {f} ({m.time_of(f):.2f} s) added as an edited frame: rotate a joint to edit "
                              "it (the falloff plot shows its reach)")
        self._show_message()

    def _remove_selected(self) -> None:
        """"remove this edit": the selected frame's edit removed; the message line says what that did (it
        replaces the note of the add, browser review D10)."""
        m, f = self.model, int(self.model.edit_frame)
        if f not in m.edits:
            self._add_note = f"frame {f} ({m.time_of(f):.2f} s) has no edit to remove"
        else:
            m.remove_edit(f)
            left = len(m.edits)
            self._add_note = (f"the edit of frame {f} ({m.time_of(f):.2f} s) removed; "
                              + (f"{left} edited frame{'s' if left != 1 else ''} left" if left else
                                 "no edited frames left"))
        self._show_message()

    def _on_pick_edit(self, change) -> None:
        if change["new"] is not None:
            self.model.edit_frame = int(change["new"])

    def _on_edits(self, change=None) -> None:
        opts = [(f"frame {f}", f) for f in self.model.edited_frames]
        if self.edited_frames.options != tuple(opts):
            self.edited_frames.options = opts
        self.edited_frames.value = self.model.edit_frame if self.model.edit_frame in self.model.edits else None

    def _on_inert(self, change=None) -> None:
        c, m = self.controls, self.model
        _inert(c["sigma"], not m.propagate, "σ sets the propagation's falloff: inert while propagate is off",
               _SIGMA_TIP)
        _inert(c["repetitions"], not m.propagate, "repetitions apply to the propagation: inert while it is off")
        _inert(self.limit_range, not m.propagate, "the edit range limits the propagation: tick 'propagate' first")
        _inert(c["compare"], not m.propagate, "the comparisons are of the propagation's falloff: tick 'propagate' "
                                              "first")
        _inert(self.range, not (m.propagate and m.frame_range),
               "tick 'propagate' first" if not m.propagate else "tick 'limit edit range' to restrict the propagation")
        self.limit_range.value = bool(m.frame_range)

    def _warnings_html(self) -> str:
        note = getattr(self, "_add_note", "")
        return f'<div style="color:#2b6cb0">{html.escape(note)}</div>' if note else ""

    def _on_view_state(self, change=None) -> None:
        if change is not None and change["name"] not in ("edits", "edit_frame"):
            self._add_note = ""
        self._redraw(self._update_views)

    def _update_views(self, edited: Motion) -> None:
        m = self.session.source
        mod = self.model
        compare = list(mod.compare)
        # the comparison curves whose heads are computed draw now; the others (ISOMAP's graph, the diffusion
        # coordinates of this sigma: seconds on long clips) are warmed and drawn when ready (yielding to the user)
        ready = self.session.falloff_ready(mod.sigma, compare)
        pending = [c for c in compare if c not in ready]
        drawn = (id(edited), self.session.typed_ops, mod.joint, float(mod.sigma), tuple(mod.frame_range),
                 tuple(compare), tuple(ready), int(mod.edit_frame), tuple(mod.edited_frames), mod.repetitions,
                 bool(mod.propagate))
        if drawn == getattr(self, "_drawn", None):
            return   # the same views (a model change and the session change it caused, drawn once)
        self._drawn = drawn
        f = int(mod.edit_frame)
        fr = mod.frame_range or None
        # the falloff depends on the source and these only (not on the rotation): rebuilt when they change
        key = (f, float(mod.sigma), None if fr is None else tuple(fr), tuple(compare), tuple(ready),
               tuple(mod.edited_frames), _x_span(edited), mod.repetitions, bool(mod.propagate))
        if f < m.num_frames and (key != getattr(self, "_falloff_key", None) or not self.falloff_plot.figure):
            edited_times = mod.edited_times() or [mod.time_of(f)]
            if mod.propagate:   # the weights the propagation gives (repetitions "discard": the valley only, §3.3)
                curves = self.session.falloff_curves(f, mod.sigma, fr, compare=[c for c in compare if c in ready],
                                                     repetitions=mod.repetitions == "keep")
                wait = f"; computing {', '.join(pending)}…" if pending else ""
                kept = "" if mod.repetitions == "keep" else ", repetitions discarded"
                title = f"Green's falloff from frame {f} ({m.times[f]:.2f} s), σ = {mod.sigma:.3g}{kept}{wait}"
            else:               # propagate off: weight 1 at the edited frames, 0 elsewhere
                curves = {"edited frames only": mod.frame_weights(m.num_frames)}
                title = "propagate off: only the edited frames change (weight 1 there, 0 elsewhere)"
            self.falloff_plot.figure = falloff_figure(m.times, curves, edited_times=edited_times, title=title,
                                                      x_range=_x_span(edited), height=_PLOT_HEIGHT)
            self._falloff_key = key
            if pending:
                self._warm(("compare", [(c, float(mod.sigma)) for c in pending]), then=self._on_compared)
        v = joint_curves_view(self.session, edited, mod.joint,
                              source_degrees=self._source_degrees(m.skeleton.index(mod.joint)))
        self.curves.figure = joint_curves_figure(
            v["times"], v["degrees"], v["source_degrees"], v["source_times"], pose_times=mod.edited_times(),
            pose_label="edited frames", pose_colour=EDIT_COLOUR,
            title=f"{mod.joint}: rotation vector (°), edited vs original", x_range=_x_span(edited))
        self._show_motion(edited, pose_frames=mod.edited_frames or [f])
        self.view.highlight_joints([mod.joint])

    def _on_compared(self) -> None:
        """A comparison's heads are warm: draw it (if it is still asked for)."""
        self._redraw(self._update_views)
