"""Figure builders: pure functions returning plotly figure dicts ``{"data": [...], "layout": {...}}``.

Used by the editors' plot views (:class:`stagger_nb.widgets.PlotView` draws a dict as given) and by the
notebooks (``plotly.graph_objects.Figure(d)`` or ``plotly.io.show(d)``). Arrays in the dicts are numpy
arrays; shapes and units are in each builder's docstring. Sits beside ``session``: uses numpy only.
:func:`decimate` thins a long line to plot resolution without losing a peak (the builders use it; so may a
figure of one's own).
"""
from ._style import EDIT_COLOUR, POSE_COLOUR, decimate
from .papers import (
                     distance_figure,
                     heatmap_figure,
                     knots_figure,
                     lines_figure,
                     skeleton_strobe_figure,
                     speeds_figure,
                     spline_displacement_figure,
                     support_figure,
                     table_figure,
)
from .views import SPEED_LIMITS, falloff_figure, joint_curves_figure, pose_probability_figure, warp_figure

__all__ = ["pose_probability_figure", "joint_curves_figure", "falloff_figure", "warp_figure", "SPEED_LIMITS",
           "EDIT_COLOUR", "POSE_COLOUR", "decimate",
           "skeleton_strobe_figure", "lines_figure", "knots_figure", "spline_displacement_figure", "heatmap_figure",
           "distance_figure", "speeds_figure", "support_figure", "table_figure"]
