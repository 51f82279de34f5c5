"""stagger_nb: edit skeletal motion in Jupyter with staggered poses, the magic wand and guided time warping.

Quaternions are (x, y, z, w) everywhere (see :mod:`stagger_nb.core.rotations`).
"""
from . import data  # noqa: F401  (sn.data.load: the sample clips)
from .core import Motion, Skeleton, concatenate, forward_kinematics, positions_in_root_frame
from .io import AMCError, BVHError, read_asf_amc, read_bvh, write_bvh, write_gltf

__version__ = "0.1.0"

__all__ = ["Motion", "Skeleton", "concatenate", "forward_kinematics", "positions_in_root_frame",
           "BVHError", "read_bvh", "write_bvh", "AMCError", "read_asf_amc", "write_gltf", "__version__"]


def __getattr__(name):
    # sn.quality (the figures of an edit) imports the staggered package: loaded on first use, so that
    # ``import stagger_nb`` stays fast
    if name == "quality":
        import importlib
        return importlib.import_module(".quality", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
