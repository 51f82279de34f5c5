"""Editor models: one evented ``traitlets.HasTraits`` per editor, the pure ``params <-> ops`` functions, and the
binding that keeps a model and a :class:`~stagger_nb.session.Session` in step.

The model is the single place an editor's state lives (STYLE.md lesson 9). Controls ``link`` to its traits and
views observe it; :class:`ModelBinding` turns a model change into ``session.set_ops`` (one undo step) and a session
change (undo/redo, load, code calling ``set_ops``) back into model traits. Nothing here imports ipywidgets.

Values coming from a session are never clamped: ``skip=100`` stays 100 (a slider's range grows to show it); a
joint name the skeleton does not have becomes a readable note in ``model.message`` and the op is kept unchanged.

One module per editor: :mod:`.stagger` (Coleman et al. 2008; its ``params <-> ops`` in :mod:`.stagger_ops`),
:mod:`.wand` (Dean et al. 2018), :mod:`.warp` (Hsu et al. 2007); :mod:`._base` what they share; :mod:`.merge` an
editor's ops into the session's list; :mod:`.binding` the binding; :mod:`.messages` the plain sentences of a
refused change; :mod:`.views` the numbers behind the editors' views.
"""
from . import views
from ._base import snap
from .binding import ModelBinding, merge_ops
from .messages import describe_op, plain_message
from .stagger import STAGGER_OPS, StaggerModel, stagger_ops_to_params, stagger_params_to_ops
from .wand import WAND_OPS, WandModel, wand_ops_to_params, wand_params_to_ops
from .warp import WARP_OPS, WarpModel, warp_ops_to_params, warp_params_to_ops

__all__ = ["StaggerModel", "WandModel", "WarpModel", "ModelBinding", "merge_ops",
           "stagger_params_to_ops", "stagger_ops_to_params", "wand_params_to_ops", "wand_ops_to_params",
           "warp_params_to_ops", "warp_ops_to_params", "STAGGER_OPS", "WAND_OPS", "WARP_OPS", "plain_message",
           "describe_op", "views", "snap"]
