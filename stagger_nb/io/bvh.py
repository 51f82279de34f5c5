"""BVH (Biovision Hierarchy) reader and writer: the public module.

:func:`read_bvh` / :func:`parse_bvh` live in :mod:`.bvh_read` (the semantics of channels, line breaks and
names, the C accelerator and its fallback, the limits on what is read), :func:`write_bvh` /
:func:`format_bvh` in :mod:`.bvh_write` (channel orders kept, atomic replacement). :func:`accelerated` says
whether the motion block is parsed in C (``STAGGER_NB_NO_ACCEL=1`` forces the bit-identical fallback).
"""
from __future__ import annotations

from ..core.accel import NO_ACCEL_ENV
from .bvh_read import BVHError, accelerated, name_fits_bvh, parse_bvh, read_bvh
from .bvh_write import format_bvh, write_bvh

__all__ = ["BVHError", "read_bvh", "write_bvh", "parse_bvh", "format_bvh", "accelerated", "name_fits_bvh",
           "NO_ACCEL_ENV"]
