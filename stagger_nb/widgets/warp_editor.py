"""The guided time-warping editor (Hsu et al. 2007) over a :class:`~stagger_nb.session.models.WarpModel`."""
from __future__ import annotations

import ipywidgets as widgets
import numpy as np
import traitlets

from ..core.motion import Motion
from ..session import Session, warp_table_key
from ..session.models import WarpModel
from ..timewarp.guided import AUTO_APPROX_PAIRS
from ..plotting import warp_figure
from ._editor import _STYLE, _WIDE, _Editor, _inert, _link, _session_for, _slider
from .plots import PlotView
from .skeleton_view import SkeletonView

__all__ = ["WarpEditor"]


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
        session = _session_for(motion, session, source_path)
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
        model = WarpModel(duration=D, segment=[0.0, round(D / 2, 6)])
        c = {}
        c["mode"] = widgets.ToggleButtons(options=["guided", "linear"], description="warp", style=_STYLE)
        c["duration"] = _slider(widgets.FloatSlider, "duration (s)", min=round(D / 8 + m.frame_time, 3),
                                max=round(2 * D, 3), step=m.frame_time, readout_format=".2f")
        c["free_length"] = widgets.Checkbox(description="free length", indent=False)
        c["skip"] = _slider(widgets.IntSlider, "skip s", min=1, max=16)
        c["backward"] = widgets.Checkbox(description="backward", indent=False)
        c["reference"] = widgets.Dropdown(options=["self", "segment"], description="reference", style=_STYLE)
        c["segment"] = _slider(widgets.FloatRangeSlider, "segment (s)", min=0.0, max=round(D, 3), step=m.frame_time,
                               readout_format=".2f")
        self.keytimes = widgets.Text(value="", placeholder="in:out, in:out  (seconds)", description="keytimes",
                                     style=_STYLE, layout=_WIDE)
        self.controls = c
        view = SkeletonView(m, ghost=m, show_ghost=show_ghost)
        self.warp_plot = PlotView(frame_time=m.frame_time)
        layout = [widgets.HBox([c["mode"], c["skip"], c["backward"]]),
                  widgets.HBox([c["duration"], c["free_length"], self.keytimes]),
                  widgets.HBox([c["reference"], c["segment"]])]
        self.click_keytime = widgets.Checkbox(value=False, indent=False,
                                              description="click the warp plot to add a keytime")
        self.clear_keytimes = widgets.Button(description="clear keytimes", layout=widgets.Layout(width="130px"))
        self.clear_keytimes.on_click(lambda _: setattr(self.model, "keytimes", []))
        self.warp_plot.on_click(self._on_warp_click)
        layout.append(widgets.HBox([self.click_keytime, self.clear_keytimes]))
        c["duration"].add_class("sn-duration")
        c["skip"].add_class("sn-skip")
        self._setup(model, session, view, [self.warp_plot], layout, references=refs)
        # a reference given to the constructor is the one used (when the session has no warp op yet)
        traitlets.link((model, "reference_options"), (c["reference"], "options"))
        for k in ("mode", "duration", "free_length", "skip", "backward", "reference"):
            self._links.append(_link(model, k, c[k]))
        self._links.append(traitlets.link((model, "segment"), (c["segment"], "value"), transform=(tuple, list)))
        self._links.append(traitlets.link((model, "keytimes"), (self.keytimes, "value"),
                                          transform=(self._format_keytimes, self._parse_keytimes)))
        model.observe(self._on_inert, names=["mode", "reference", "free_length", "duration", "keytimes", "backward"])
        self._on_inert()
        if given and not any(o["op"] in ("guided_warp", "linear_warp") for o in session.ops):
            model.reference = next(iter(given))   # a style warp on the given clip, at the same duration
        self._warmed_tables = None
        model.observe(lambda _: self._warm_skip_tables(),
                      names=["reference", "backward", "free_length", "duration", "segment", "mode"])
        self._warm_skip_tables()

    def _warm_skip_tables(self) -> None:
        """Warm (``Session.warm``) the kNN tables of the skip slider's largest value for the current reference,
        direction and upsampling: the session slices every smaller skip from them, so a skip move re-runs only
        the DP. With no warp yet, the tables of a compression (the first duration move's). Submitted again only
        when what chooses the tables changes; long clips (approximate kNN, not sliced) are not warmed."""
        if self.session.source.num_frames ** 2 > AUTO_APPROX_PAIRS:
            return
        ops = [o for o in self.binding.to_ops(self.model.params()) if o["op"] == "guided_warp"]
        if not ops and self.model.mode == "guided":
            ops = [o for o in self.binding.to_ops(dict(self.model.params(), reference="self", free_length=False,
                                                       duration=0.9 * self.session.source.duration))
                   if o["op"] == "guided_warp"]
        if not ops:
            return
        op = dict(ops[-1], skip=max(int(self.controls["skip"].max), int(ops[-1].get("skip", 8))))
        try:
            key = warp_table_key(self.session.source, op) + (op["skip"],)
            if key == self._warmed_tables:
                return
            self._warm(("warp_tables", [op]))
            self._warmed_tables = key
        except ValueError:
            pass   # an op the session cannot warm (e.g. a duration out of range): computed on demand, reported there

    def _on_warp_click(self, x, y, frame) -> None:
        """With "click to add a keytime" on, a click on the warp plot at (output time x, input time y) adds
        the keytime [y, x] (Hsu et al. 2007, §4.2)."""
        if self.click_keytime.value and y is not None and not self.model.free_length:
            kt = sorted(self.model.keytimes + [[float(y), float(x)]], key=lambda p: p[1])
            self.model.keytimes = kt

    @staticmethod
    def _format_keytimes(kt) -> str:
        return ", ".join(f"{a:g}:{b:g}" for a, b in kt)

    def _parse_keytimes(self, text: str):
        """``"in:out, in:out"`` seconds; a malformed entry is reported and the keytimes stay as they were."""
        pairs = []
        for item in text.replace(";", ",").split(","):
            if not item.strip():
                continue
            a, sep, b = item.partition(":")
            try:
                if not sep:
                    raise ValueError
                pairs.append([float(a), float(b)])
            except ValueError:
                self.error = f"keytimes: {item.strip()!r} is not 'input_time:output_time' (seconds)"
                self._show_message()
                return self.model.keytimes
        self.error = ""
        return pairs

    def _on_inert(self, change=None) -> None:
        c, m = self.controls, self.model
        _inert(c["segment"], m.reference != "segment", "the segment is used only when reference = segment")
        linear = m.mode == "linear"
        for k in ("skip", "reference", "backward", "free_length"):
            _inert(c[k], linear, f"{k} applies to guided warps only")
        if not linear and not self.binding.to_ops(m.params()):   # a self-guided warp at the source's duration
            _inert(c["skip"], True, "the warp is the identity (reference 'self' at the source's duration): "
                                    "change the duration, the reference or a keytime first")
        _inert(c["duration"], m.free_length and not linear, "free length: the warp chooses its duration")
        _inert(self.keytimes, m.free_length and not linear, "keytimes need a fixed duration (free length is on)")

    def _update_views(self, edited: Motion) -> None:
        from .. import timewarp
        ft = edited.frame_time
        warp = None
        names = [op.name for op in self.session.typed_ops]   # not .ops: a JSON copy of every op per call
        for i in range(len(names) - 1, -1, -1):
            if names[i] in ("guided_warp", "linear_warp"):
                warp = self.session.warp_curve(i)
                break
        if warp is None:   # no warp op (e.g. undone): the identity
            warp = edited.times
        out_t = np.arange(len(warp)) * ft
        kt = self.model.keytimes or None
        self.warp_plot.figure = warp_figure(out_t, warp, timewarp.warp_speed(warp, ft), keytimes=kt,
                                            title=f"{self.model.mode} warp: {self.session.source.duration:.2f} s "
                                                  f"→ {out_t[-1]:.2f} s")
        self._show_motion(edited)
