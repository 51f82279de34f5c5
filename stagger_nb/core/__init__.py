"""Numeric core: rotations, the Skeleton/Motion data model, kinematics. numpy + scipy only."""
from . import rotations
from .kinematics import fk_arrays, forward_kinematics, positions_in_root_frame, skeleton_height
from .motion import Motion, concatenate
from .skeleton import Skeleton

__all__ = ["rotations", "Skeleton", "Motion", "concatenate", "forward_kinematics", "fk_arrays",
           "positions_in_root_frame", "skeleton_height"]
