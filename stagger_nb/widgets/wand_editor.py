"""The magic-wand editor (Dean et al. 2018) over a :class:`~stagger_nb.session.models.WandModel`."""
from __future__ import annotations

import math

import ipywidgets as widgets

from ..core.motion import Motion
from ..plotting import EDIT_COLOUR, falloff_figure, joint_curves_figure
from ..session import Session
from ..session.models import WandModel
from ..session.models.views import joint_curves_view
from ._editor import (
    _PLOT_HEIGHT,
    _STYLE,
    _VIEW_SIZE,
    _WIDE,
    _default_joint,
    _Editor,
    _inert,
    _link,
    _session_for,
    _slider,
    _x_span,
)
from .plots import PlotView
from .skeleton_view import SkeletonView

__all__ = ["WandEditor"]


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
        F = m.num_frames
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
                                            step=model.SIGMA_STEP, description="σ", readout_format=".3g",
                                            continuous_update=True, style=_STYLE, layout=_WIDE)
        c["edit_frame"] = _slider(widgets.IntSlider, "edited frame", min=0, max=F - 1)
        c["propagate"] = widgets.Checkbox(description="propagate (off: edit the frames only)", indent=False)
        c["repetitions"] = widgets.ToggleButtons(options=["keep", "discard"], description="repetitions",
                                                 style=_STYLE, tooltips=["propagate to repeats of the edited pose",
                                                                         "edit only the neighbourhood (§3.3)"])
        c["joint"] = widgets.Dropdown(options=names, description="joint", style=_STYLE)
        for a in "xyz":
            c["r" + a] = _slider(widgets.FloatSlider, f"rotate {a} (°)", min=-90.0, max=90.0, step=model.step("r" + a))
        c["compare"] = widgets.SelectMultiple(options=["isomap", "diffusion", "spline"], rows=3,
                                              description="compare with", style=_STYLE)
        self.controls = c
        self.limit_range = widgets.Checkbox(value=False, description="limit edit range", indent=False)
        self.range = _slider(widgets.IntRangeSlider, "range [start, stop)", min=0, max=F, value=(0, F))
        self.edited_frames = widgets.Dropdown(options=[], description="edited frames", style=_STYLE)
        self.add_button = widgets.Button(description="add edit at playhead", layout=widgets.Layout(width="180px"))
        self.remove_button = widgets.Button(description="remove this edit", layout=widgets.Layout(width="150px"))
        self.add_button.on_click(lambda _: self.model.add_edit(self.model.frame))
        self.remove_button.on_click(lambda _: self.model.remove_edit(self.model.edit_frame))

        view = SkeletonView(m, ghost=m, show_ghost=show_ghost, **_VIEW_SIZE)
        self.falloff_plot = PlotView(frame_time=m.frame_time)
        self.curves = PlotView(frame_time=m.frame_time)
        quick = [c["sigma"], c["rx"], c["ry"], c["rz"]]
        tools = {"edit": [widgets.HBox([c["joint"]]), widgets.HBox([c["edit_frame"]]),
                          widgets.HBox([self.edited_frames]), widgets.HBox([self.add_button, self.remove_button])],
                 "propagation": [widgets.HBox([c["propagate"]]), widgets.HBox([c["repetitions"]]),
                                 widgets.HBox([self.limit_range]), widgets.HBox([self.range])],
                 "compare": [widgets.HBox([c["compare"]])]}
        c["sigma"].add_class("sn-sigma")
        c["edit_frame"].add_class("sn-edit-frame")
        self._setup(model, session, view, [self.falloff_plot, self.curves], tools, quick=quick)
        if not model.edits and any(rotation):   # an initial rotation becomes the first edit
            model.rx, model.ry, model.rz = (float(r) for r in rotation)
        # slider positions snap to the warmed sigma grid
        self._links.append(_link(model, "sigma", c["sigma"], log=True, transform=(float, model.snap_sigma)))
        for k in ("edit_frame", "propagate", "repetitions", "joint", "rx", "ry", "rz"):
            self._links.append(_link(model, k, c[k]))
        self._links.append(_link(model, "compare", c["compare"], transform=(tuple, list)))
        self._links.append(_link(model, "frame_range", self.range,
                                 transform=(lambda v: tuple(v) if v else (0, F), list)))
        self.limit_range.value = bool(model.frame_range)
        self.limit_range.observe(self._on_limit, names="value")
        self._range_link_paused = False
        model.observe(self._on_edits, names=["edits", "edit_frame"])
        model.observe(self._on_inert, names=["propagate", "frame_range"])
        model.observe(self._on_view_state, names=["compare", "joint"])
        self.edited_frames.observe(self._on_pick_edit, names="value")
        self._on_edits()
        self._on_inert()
        if precompute:
            self._warm(("wand_basis", model.sigmas_nearest_first()))

    def _on_limit(self, change) -> None:
        self.model.frame_range = list(self.range.value) if change["new"] else []

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
        _inert(c["sigma"], not m.propagate, "σ sets the propagation's falloff: inert while propagate is off")
        _inert(c["repetitions"], not m.propagate, "repetitions apply to the propagation: inert while it is off")
        _inert(self.range, not m.frame_range, "tick 'limit edit range' to restrict the propagation")
        self.limit_range.value = bool(m.frame_range)

    def _on_view_state(self, change=None) -> None:
        self._redraw(self._update_views)

    def _update_views(self, edited: Motion) -> None:
        m = self.session.source
        mod = self.model
        f = int(mod.edit_frame)
        fr = mod.frame_range or None
        compare = list(mod.compare)
        # the falloff depends on the source and these only (not on the rotation): rebuilt when they change
        key = (f, float(mod.sigma), None if fr is None else tuple(fr), tuple(compare), tuple(mod.edited_frames),
               _x_span(edited))
        if f < m.num_frames and (key != getattr(self, "_falloff_key", None) or not self.falloff_plot.figure):
            curves = self.session.falloff_curves(f, mod.sigma, fr, compare=compare)
            self.falloff_plot.figure = falloff_figure(
                m.times, curves, edited_times=mod.edited_times() or [mod.time_of(f)],
                title=f"Green's falloff from frame {f} (σ = {mod.sigma:.3g})", x_range=_x_span(edited),
                height=_PLOT_HEIGHT)
            self._falloff_key = key
        v = joint_curves_view(self.session, edited, mod.joint,
                              source_degrees=self._source_degrees(m.skeleton.index(mod.joint)))
        self.curves.figure = joint_curves_figure(
            v["times"], v["degrees"], v["source_degrees"], v["source_times"], pose_times=mod.edited_times(),
            pose_label="edited frames", pose_colour=EDIT_COLOUR,
            title=f"{mod.joint}: rotation vector (°), edited vs original", x_range=_x_span(edited))
        self._show_motion(edited, pose_frames=mod.edited_frames or [f])
        self.view.highlight_joints([mod.joint])
