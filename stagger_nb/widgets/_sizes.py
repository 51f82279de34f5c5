"""The editors' workspace layout: the 3D view's and the first plot's sizes, the message line's text, one x range
for every time plot, the default joint, and the sharing of equal layouts and styles (fewer models for JupyterLab).
Used by :mod:`._editor` and the three editors; no math."""
from __future__ import annotations

import ipywidgets as widgets

from ..core.motion import Motion
from .plots import PlotView
from .skeleton_view import SkeletonView

_WIDE = widgets.Layout(width="340px")
#: The editors' 3D view: beside the tool column in a notebook's output area at 1280x800 (sidebar open)
_VIEW_SIZE = {"width": 400, "height": 236}
#: The height (px) of an editor's first plot, legend row included: it ends inside the first screen
_PLOT_HEIGHT = 272
#: the message line's text: lines 17 px apart (an HTML widget's lines are 28 px apart: a two-line note took 56 px
#: of the tool column)
_LINES = "font-size:13px;line-height:17px"


def _x_span(edited: Motion) -> tuple:
    """The x range (seconds) of every time plot of an editor: the edited motion's span, the frames the
    playhead walks; one range for all plots, so their playheads line up down the column."""
    return (0.0, max(float(edited.times[-1]), float(edited.frame_time)))


def _default_joint(names, *preferred) -> str:
    for p in preferred:
        for n in names:
            if n.lower() == p.lower():
                return n
    return names[min(len(names) - 1, 1)]



def _share_layouts_and_styles(root: widgets.Widget, keep=()) -> int:
    """Let the widgets under ``root`` with equal ``layout`` (or equal ``style``) share one model, closing the
    duplicates (ipywidgets lets controls share a Layout or style instance): fewer models for JupyterLab to send
    and restore on a page reload. The 3D view and the plots (their own models), the widgets in ``keep`` (whose
    layout is changed later) and the module's ``_WIDE`` are left alone. Call it before the editor is displayed.
    Returns the number of models closed."""
    canon, stack, done, closed = {}, [root], set(), 0
    skip = {id(w) for w in keep}
    while stack:
        w = stack.pop()
        if id(w) in done or id(w) in skip or isinstance(w, (SkeletonView, PlotView)):
            continue
        done.add(id(w))
        stack.extend(getattr(w, "children", ()) or ())
        for name in ("layout", "style"):
            sub = getattr(w, name, None) if w.has_trait(name) else None
            if not isinstance(sub, widgets.Widget):
                continue
            key = (type(sub), tuple(sorted((k, repr(v)) for k, v in sub.get_state().items())))
            first = canon.setdefault(key, sub)
            if first is not sub:
                setattr(w, name, first)
                if sub is not _WIDE:
                    sub.close()
                    closed += 1
    return closed
