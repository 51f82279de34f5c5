"""Figure builders: pure functions returning plotly figure dicts ``{"data": [...], "layout": {...}}``.

Used by the editors' plot views (:class:`stagger_nb.widgets.PlotView` draws a dict as given) and by the
notebooks (``plotly.graph_objects.Figure(d)`` or ``plotly.io.show(d)``). Arrays in the dicts are numpy
arrays; shapes and units are in each builder's docstring. Sits beside ``session``: uses numpy only.
"""
from .views import SPEED_LIMITS, falloff_figure, joint_curves_figure, pose_probability_figure, warp_figure

__all__ = ["pose_probability_figure", "joint_curves_figure", "falloff_figure", "warp_figure", "SPEED_LIMITS"]
