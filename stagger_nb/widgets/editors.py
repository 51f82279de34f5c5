"""Former home of the three editors (one module each now: :mod:`.stagger_editor`, :mod:`.wand_editor`,
:mod:`.warp_editor`, their shared base :mod:`._editor`); kept so ``stagger_nb.widgets.editors.X`` still imports."""
from .stagger_editor import StaggerEditor
from .wand_editor import WandEditor
from .warp_editor import WarpEditor

__all__ = ["StaggerEditor", "WandEditor", "WarpEditor"]
