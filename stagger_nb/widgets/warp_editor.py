"""The guided time-warping editor (Hsu et al. 2007) over a :class:`~stagger_nb.session.models.WarpModel`."""
from __future__ import annotations

import math

import ipywidgets as widgets
import traitlets

from ..core.motion import Motion
from ..plotting import warp_figure
from ..session import Session, warp_table_key
from ..session.models import WarpModel
from ..session.models.views import warp_replays_first_changes, warp_tables_first_changes, warp_view
from ._controls import _STYLE, _inert, _inline, _link, _slider
from ._editor import _Editor, _session_for
from ._sizes import _PLOT_HEIGHT, _VIEW_SIZE, _WIDE
from .plots import PlotView
from .skeleton_view import SkeletonView

__all__ = ["WarpEditor"]

_SKIP_TIP = ("skip limit s (Hsu et al. 2007, §3.1): at most s input frames per output frame, so the warp plays at "
             "most s times real time; a shorter output needs a larger s")
_DURATION_TIP = "the output's duration in seconds: arrow keys move one frame, a drag is coarse, ±1 s beside it"
_FREE_TIP = ("free length: the warp chooses its own duration, as the reference's timing asks (Hsu et al. 2007, "
             "§3.3); no target duration, no keytimes")
_KEYTIMES_TIP = ("keytimes (§4.2), in seconds: input time:output time pairs, e.g. 2:1.5 plays the input's 2 s at "
                 "1.5 s of output; applied on Enter or when the box loses focus")
_SEGMENT_TIP = "the part of the source used as the reference (reference = segment), in seconds"
# every label reads in full at 1280x800 with the file browser open (a description in 120 px, a checkbox's in
# 300 px, a toggle's in its button): the long sense is in the tooltip (tests/test_browser_workspace.py checks)


class WarpEditor(_Editor):
    """Guided time-warping editor (Hsu et al. 2007): target duration or free length, skip limit, keytimes,
    backward warps, a reference (the input itself, a segment of it, or other clips) and linear vs guided; the
    warp curve and its log-scale derivative (Fig. 5).

    Parameters
    ----------
    motion : Motion or Session
    reference : Motion, path, dict {name: Motion or path}, or None
        Extra reference clips offered besides "self" and "segment". A Motion is offered as "reference".
        In-memory clips are registered with ``Session.use_reference`` (a saved session keeps the name only).
    """

    _css = "sn-warp-editor"

    def __init__(self, motion, reference=None, session: Session | None = None, source_path=None,
                 show_ghost: bool = False, **kwargs):
        super().__init__(**kwargs)
        session = _session_for(self, motion, session, source_path)
        m = session.source
        given = {}
        if isinstance(reference, (Motion, str)):
            given["reference"] = reference
        elif isinstance(reference, dict):
            given.update(reference)
        elif reference is not None:
            raise ValueError(f"reference: expected a Motion, a path, a dict of them or None, "
                             f"got {type(reference).__name__}")
        refs = {}
        for name, r in given.items():
            if isinstance(r, Motion):
                refs[name] = session.use_reference(f"<memory:{name}>", r)
            else:
                refs[name] = {"path": str(r)}
        D = m.duration
        # the segment opens on the first half of the clip, a whole number of frames (the slider's grid)
        half = round(round(D / 2 / m.frame_time) * m.frame_time, 6)
        model = WarpModel(frame_time=m.frame_time, duration=D, segment=[0.0, half])
        c = {}
        # each toggle's description beside its buttons, in 72 px (the "retime" row then fits the tool column)
        c["mode"] = widgets.ToggleButtons(options=["guided", "linear"], description="time warp",
                                          style={"description_width": "72px", "button_width": "72px"},
                                          tooltips=["guided by a reference's timing (Hsu et al. 2007)",
                                                    "piecewise linear through the keytimes"])
        # 1/8x .. 2x the clip; a key moves one frame; the readout takes a typed value (the track grows to show it)
        # the track's positions are min + n * step (the browser snaps to them): min is a whole number of frames
        # below the source's duration, so the opening value reads as the title does (22.92, not 22.91)
        ft = model.step("duration")
        lo = round(D - math.floor((D - D / 8 - ft) / ft) * ft, 6)
        c["duration"] = _slider(widgets.FloatSlider, "duration (s)", min=lo,
                                max=round(2 * D, 3), step=model.step("duration"), readout_format=".2f",
                                tooltip=_DURATION_TIP)
        # a coarse step beside the slider (its keys move one frame): -1 s / +1 s, clamped to the slider's range
        self.duration_steps = [widgets.Button(description=f"{d:+d} s", layout=widgets.Layout(width="52px"),
                                              tooltip=f"{'shorten' if d < 0 else 'lengthen'} the output by 1 s")
                               for d in (-1, 1)]
        for b, d in zip(self.duration_steps, (-1.0, 1.0)):
            b.on_click(lambda _, d=d: self._step_duration(d))
        c["free_length"] = widgets.Checkbox(description="free length (the warp chooses it)", indent=False,
                                            tooltip=_FREE_TIP)
        c["skip"] = _slider(widgets.IntSlider, "fastest (× speed)", min=1, max=16, tooltip=_SKIP_TIP)
        c["backward"] = widgets.Checkbox(description="backward (play the clip in reverse)", indent=False)
        c["target"] = widgets.ToggleButtons(options=[("the motion", "motion"), ("staggered poses", "poses")],
                                            description="retime",
                                            style={"description_width": "72px", "button_width": "140px"},
                                            tooltips=["warp the edited motion (guided_warp)",
                                                      "warp the staggered pose times (guide_poses): the staggering "
                                                      "and the staggered edits stay, still editable"])
        c["target"].add_class("sn-warp-target")
        _inline(c["mode"])
        _inline(c["target"])
        c["reference"] = widgets.Dropdown(options=["self", "segment"], description="reference", style=_STYLE)
        c["segment"] = _slider(widgets.FloatRangeSlider, "segment (s)", min=0.0, max=round(D, 3),
                               step=model.step("segment"), readout_format=".1f",
                               tooltip=_SEGMENT_TIP)
        # applied on Enter or when the box loses focus (continuous_update off): a half-typed entry ('99:') is
        # never read; a complete one that cannot apply is refused then, in a sentence
        self.keytimes = widgets.Text(value="", placeholder="in s:out s, e.g. 2:1.5",
                                     description="keytimes (s)", style=_STYLE, tooltip=_KEYTIMES_TIP,
                                     layout=_WIDE, continuous_update=False)
        self.controls = c
        view = SkeletonView(m, ghost=m, show_ghost=show_ghost, **_VIEW_SIZE)
        self.warp_plot = PlotView(frame_time=m.frame_time)
        self.click_keytime = widgets.Checkbox(value=False, indent=False,
                                              description="click the warp plot to add a keytime")
        self.clear_keytimes = widgets.Button(description="clear keytimes", layout=widgets.Layout(width="130px"))
        self.clear_keytimes.on_click(lambda _: setattr(self.model, "keytimes", []))
        self.warp_plot.on_click(self._on_warp_click)
        quick = [widgets.HBox([c["duration"], *self.duration_steps]), c["skip"]]
        tools = {"warp": [widgets.HBox([c["mode"]]), widgets.HBox([c["target"]]),
                          widgets.HBox([c["free_length"], c["backward"]])],
                 "reference": [widgets.HBox([c["reference"]]), widgets.HBox([c["segment"]])],
                 "keytimes": [widgets.HBox([self.keytimes]), widgets.HBox([self.click_keytime]),
                              widgets.HBox([self.clear_keytimes])]}
        c["duration"].add_class("sn-duration")
        c["skip"].add_class("sn-skip")
        self._setup(model, session, view, [self.warp_plot], tools, references=refs, quick=quick)
        # a reference given to the constructor is the one used (when the session has no warp op yet)
        traitlets.link((model, "reference_options"), (c["reference"], "options"))
        for k in ("mode", "duration", "free_length", "skip", "backward", "reference", "target"):
            self._links.append(_link(model, k, c[k]))
        self._links.append(_link(model, "segment", c["segment"], transform=(tuple, list)))
        self._links.append(_link(model, "keytimes_text", self.keytimes))
        model.observe(self._on_inert, names=["mode", "reference", "free_length", "duration", "keytimes", "backward",
                                             "target", "has_staggered"])
        self._on_inert()
        if given and not any(o["op"] in ("guided_warp", "linear_warp") for o in session.ops):
            model.reference = next(iter(given))   # a style warp on the given clip, at the same duration
            if self._owns_session:                # the editor's opening state: nothing the user did to undo
                session.reset_history()
        self._warmed_tables = None
        model.observe(lambda _: self._warm_skip_tables(),
                      names=["reference", "backward", "free_length", "duration", "segment", "mode"])
        self._warm_skip_tables()

    def _warm_skip_tables(self) -> None:
        """Warm (``Session.warm``) the kNN tables of the skip slider's largest value for the current reference,
        direction and upsampling, then those of the first free-length and backward toggles (and with no warp
        yet of a lengthening): ``models.views.warp_tables_first_changes`` chooses them. The session slices every
        smaller skip from them, so a skip move re-runs only the DP. Then the replay of the first backward toggle
        (``warp_replays_first_changes``: its DP, 0.77 s CPU at CMU 01_01's own length). Submitted again only when
        what chooses the tables changes; long clips (approximate kNN, not sliced) are not warmed."""
        ops = warp_tables_first_changes(self.binding, self.controls["skip"].max)
        if not ops:
            return
        try:
            key = tuple(warp_table_key(self.session.source, op) + (op["skip"],) for op in ops)
            if key == self._warmed_tables:
                return
        except ValueError:
            return   # an op the session cannot warm (e.g. a duration out of range): computed on demand, reported there
        # then the first backward toggle's replay (its DP); Session.warm checks every job before it submits any:
        # a list it refuses is left out, the tables warmed alone
        try:
            self._warm(("warp_tables", ops), ("replay", warp_replays_first_changes(self.binding)))
        except ValueError:
            try:
                self._warm(("warp_tables", ops))
            except ValueError:
                return
        self._warmed_tables = key

    def _step_duration(self, seconds: float) -> None:
        """-1 s / +1 s: the duration moved by ``seconds`` within the slider's range (a refused value is said in
        the message line, as from the slider)."""
        c = self.controls["duration"]
        v = round(min(max(self.model.duration + seconds, c.min), c.max), 6)
        if v != self.model.duration:
            self.model.set_control("duration", v)
            self._show_message()

    def _on_warp_click(self, x, y, frame) -> None:
        """With "click to add a keytime" on, a click on the warp plot at (output time x, input time y) adds
        the keytime [y, x] (Hsu et al. 2007, §4.2)."""
        if self.click_keytime.value and y is not None and not self.model.free_length:
            self.model.set_control("keytimes", self.model.with_keytime(y, x))

    def _on_inert(self, change=None) -> None:
        c, m = self.controls, self.model
        _inert(c["segment"], m.reference != "segment", "the segment is used only when reference = segment",
               _SEGMENT_TIP)
        linear = m.mode == "linear"
        tips = {"skip": _SKIP_TIP, "free_length": _FREE_TIP}
        for k in ("skip", "reference", "backward", "free_length"):
            _inert(c[k], linear, f"{k} applies to guided warps only", tips.get(k, ""))
        if not linear and not self.binding.to_ops(m.params()):   # a self-guided warp at the source's duration
            _inert(c["skip"], True, "the warp is the identity (reference 'self' at the source's duration): "
                                    "change the duration, the reference or a keytime first")
        _inert(c["duration"], m.free_length and not linear, "free length: the warp chooses its duration",
               _DURATION_TIP)
        for b in self.duration_steps:
            b.disabled = c["duration"].disabled
            b.tooltip = c["duration"].tooltip if b.disabled else f"{b.description} on the output's duration"
        _inert(c["target"], linear or not (m.has_staggered or m.target == "poses"),
               "the staggered pose times can be warped in a session holding staggered edits (guided mode)")
        _inert(c["backward"], linear or m.target == "poses", "backward applies to guided warps of the motion only")
        _inert(self.keytimes, m.free_length and not linear, "keytimes need a fixed duration (free length is on)",
               _KEYTIMES_TIP)
        _inert(self.click_keytime, self.keytimes.disabled, self.keytimes.tooltip,
               "then a click on the warp plot at (output time, input time) adds that keytime")
        _inert(self.clear_keytimes, self.keytimes.disabled or not m.keytimes,
               self.keytimes.tooltip if self.keytimes.disabled else "there are no keytimes to clear",
               "remove every keytime")

    def _speed_limit(self) -> float | None:
        """The skip limit drawn on the speed plot (a guided warp plays at most ``skip`` times real time, Hsu et
        al. 2007, §3.1): the skip slider's move is seen there even where the warp stays under both values."""
        m = self.model
        identity = not self.binding.to_ops(m.params())   # (the skip slider is disabled then)
        return float(m.skip) if m.mode == "guided" and not identity else None

    def _update_views(self, edited: Motion) -> None:
        v = warp_view(self.session)
        with self.binding.paused():   # free length: the readout shows the duration the warp chose, as the title
            self.model.show_chosen_duration(float(v["out_times"][-1]))
        self.warp_plot.figure = warp_figure(v["out_times"], v["warp"], v["speed"], keytimes=self.model.keytimes or None,
                                            speed_limit=self._speed_limit(),
                                            title=f"{self.model.mode} warp: {self.session.source.duration:.2f} s "
                                                  f"→ {v['out_times'][-1]:.2f} s", height=_PLOT_HEIGHT + 30)
        self._show_motion(edited)
