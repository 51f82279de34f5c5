"""File formats: BVH read/write, CMU ASF/AMC read, glTF 2.0 write. Text in, :class:`~stagger_nb.core.Motion` out.

:data:`MAX_INPUT_BYTES` is the size limit of every file the package reads (256 MiB; ``read_bvh(path,
max_bytes=...)`` reads a larger take)."""
from ._input import MAX_INPUT_BYTES
from .asfamc import AMCError, read_asf_amc
from .bvh import BVHError, format_bvh, parse_bvh, read_bvh, write_bvh
from .gltf import write_gltf

__all__ = ["BVHError", "read_bvh", "write_bvh", "parse_bvh", "format_bvh", "AMCError", "read_asf_amc", "write_gltf",
           "MAX_INPUT_BYTES"]
