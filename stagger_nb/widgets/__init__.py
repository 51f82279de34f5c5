"""Interactive editors for Jupyter: evented controls over a :class:`stagger_nb.session.Session`, a pythreejs
skeleton view and plotly plots updated in place. No math here: numbers come from the technique packages
and the session."""
from .export import export_html
from .plots import FalloffPlot, JointCurvesPlot, PlotView, ProbabilityPlot, WarpPlot
from .skeleton_view import SkeletonView

__all__ = ["SkeletonView", "export_html", "PlotView", "JointCurvesPlot", "ProbabilityPlot", "FalloffPlot", "WarpPlot",
           "StaggerEditor", "WandEditor", "WarpEditor"]


def __getattr__(name):  # editors import the technique packages: load them on first use
    if name == "StaggerEditor":
        from .stagger_editor import StaggerEditor
        return StaggerEditor
    if name == "WandEditor":
        from .wand_editor import WandEditor
        return WandEditor
    if name == "WarpEditor":
        from .warp_editor import WarpEditor
        return WarpEditor
    raise AttributeError(f"module 'stagger_nb.widgets' has no attribute {name!r}")
