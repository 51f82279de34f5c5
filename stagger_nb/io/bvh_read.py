"""BVH (Biovision Hierarchy) reader: :func:`read_bvh`, :func:`parse_bvh` (the writer is :mod:`.bvh_write`;
:mod:`.bvh` is the public module holding both).

Semantics: rotation channels are intrinsic Euler angles in degrees in the order they are listed
(``Zrotation Xrotation Yrotation`` means ``R = Rz Rx Ry``), any order per joint. Position channels give
the joint's translation relative to its parent and *replace* its OFFSET (as Blender and MotionBuilder
read them), on the root or on any joint. Line breaks may be LF, CRLF, CR or mixed; tokens may be
separated by tabs; numbers may have a leading dot or an exponent; joint names may contain colons.

The header (HIERARCHY, ``Frames:``, ``Frame Time:``) is read by :mod:`.bvh_header`, the motion block by
:mod:`.bvh_block`; this module holds the two entry points and the limits between them.

Reading is fast and lean. Where the optional C accelerator was built (:func:`accelerated`), the motion block
is parsed by ``_cparse.parse_rows`` (plain decimal tokens only, rounded exactly as ``float``: Clinger's fast
path, else CPython's own strtod) ~500 frames at a time into a reused scratch buffer laid out so the angles
convert to quaternions without transposes; a block it does not certify goes to the path below, which
gives the same values or the error. Otherwise the motion block is cut into ~1 MB pieces at line breaks, each parsed by
:func:`._numparse.parse_lines` (vectorised tokenising and pyarrow's float conversion, bit-identical to
``float``, any spacing) and converted straight into its frames of the output arrays, which the Motion takes
without copies; the pieces are spread over the CPUs (up to 4 threads: numpy and pyarrow release the GIL).
When a piece cannot be certified, a line-by-line parser (bounded memory) finds the first bad line and
raises :class:`BVHError` naming the file, the line and what was expected. Only regular files within
:data:`stagger_nb.io.MAX_INPUT_BYTES` are read; frame times outside [1e-4, 3600] s, frames x joints beyond
:data:`~stagger_nb.core.motion.MAX_FRAME_JOINTS`, duplicate joint names and a second End Site under a joint
are refused. Both paths give the same bits, the sign of zero included: no quaternion component is -0, and an
angle's quaternion does not depend on the other angles of its piece.
"""
from __future__ import annotations

import numpy as np

from ..core.accel import NO_ACCEL_ENV
from ..core.motion import MAX_FRAME_JOINTS, MAX_FRAME_TIME, MIN_FRAME_TIME, Motion
from ._common import (
    UTF8_BOM,
    decode,
    file_path,
    read_bytes,
)
from .bvh_block import accelerated, read_block
from .bvh_header import (
    _FIRST_TOKEN,
    BVHError,
    _find_motion_line,
    _header_value,
    _next_line,
    _normalise_breaks,
    _not_hierarchy,
    _parse_hierarchy,
    _Tokens,
    name_fits_bvh,
)

__all__ = ["BVHError", "read_bvh", "parse_bvh", "accelerated", "name_fits_bvh", "NO_ACCEL_ENV"]

_MAX_FRAMES = 10_000_000  # refuse absurd headers before allocating anything


def parse_bvh(text: str | bytes, source: str = "<string>", *, max_samples: int | None = None) -> Motion:
    """Parse BVH text (``str`` or the file's ``bytes``) into a :class:`Motion`; ``source`` names the file
    in error messages. ``max_samples``: most frames x joints allocated (default
    :data:`~stagger_nb.core.motion.MAX_FRAME_JOINTS`, 32 bytes of rotation each)."""
    limit = MAX_FRAME_JOINTS if max_samples is None else _positive_int(max_samples, "max_samples")
    raw = text.encode("utf-8") if isinstance(text, str) else bytes(text)
    if raw[:3] == UTF8_BOM:  # a byte-order mark some Windows tools write
        raw = raw[3:]
    first = _FIRST_TOKEN.match(raw)  # a file that does not start with HIERARCHY is refused before any scan
    if first.group(1).upper() != b"HIERARCHY":  # (a 255 MB file of NULs: 9 s of searching for 'MOTION')
        ln = _normalise_breaks(raw[:first.start(1)]).count(b"\n") + 1
        raise BVHError(source, ln, _not_hierarchy(first.group(1)))
    raw = _normalise_breaks(raw)
    motion_at = _find_motion_line(raw)
    if motion_at is None:
        last = raw.count(b"\n") + (0 if raw.endswith(b"\n") else 1)
        raise BVHError(source, max(last, 1), "no 'MOTION' section found")
    head = decode(memoryview(raw)[:motion_at])
    ln = head.count("\n") + 1  # the MOTION line
    skel = _parse_hierarchy(_Tokens(head, source, ln))
    del head
    line, pos = _next_line(raw, motion_at)
    while True:  # blank lines may precede 'Frames:'
        if pos >= len(raw):
            raise BVHError(source, ln, "file ends early: expected 'Frames: <count>'")
        line, pos = _next_line(raw, pos)
        ln += 1
        if line.strip():
            break
    nf = _header_value(line, "Frames", source, ln)
    if nf != int(nf) or nf < 1:
        raise BVHError(source, ln, f"expected a positive whole number of frames, found {nf:g}")
    if nf > _MAX_FRAMES:
        raise BVHError(source, ln, f"declared {nf:g} frames, more than the {_MAX_FRAMES} supported")
    nf = int(nf)
    if nf * skel.num_joints > limit:  # joints without channels cost memory but no text
        raise BVHError(source, ln, f"declared {nf} frames x {skel.num_joints} joints, more than the "
                                   f"{limit:,} joint samples allowed"
                                   + (" by default: pass max_samples= to read_bvh to read it anyway (32 bytes "
                                      "of rotations per joint sample), or split the take" if max_samples is None
                                      else ""))
    if pos >= len(raw):
        raise BVHError(source, ln, "file ends early: expected 'Frame Time: <seconds>'")
    line, pos = _next_line(raw, pos)
    ln += 1
    ft = _header_value(line, "Frame Time", source, ln)
    if ft <= 0:
        raise BVHError(source, ln, f"frame time must be positive, found {ft:g}")
    if not MIN_FRAME_TIME <= ft <= MAX_FRAME_TIME:  # see core.motion: a corrupt value, not a capture rate
        raise BVHError(source, ln, f"frame time {ft:g} s is outside the {MIN_FRAME_TIME:g}-{MAX_FRAME_TIME:g} s "
                                   f"supported (at most {1 / MIN_FRAME_TIME:g} frames per second)")
    num_channels = sum(len(c) for c in skel.channels)
    root_pos, quats, trans = read_block(raw, pos, nf, skel, num_channels, ln, source)
    return Motion._from_owned(skel, float(ft), root_pos, quats, trans, continuous=True)


def _positive_int(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be a positive whole number, got {value!r}")
    return int(value)


def read_bvh(path, *, max_bytes: int | None = None, max_samples: int | None = None) -> Motion:
    """Read a BVH file into a :class:`Motion` (see the module docstring for the semantics).

    Returns a Motion with ``root_positions (F, 3)`` (file units), ``local_quats (F, J, 4)`` (x, y, z, w),
    ``local_translations (F, J, 3)`` when non-root joints have position channels (else ``None``),
    ``frame_time`` in seconds, and a Skeleton keeping each joint's channel layout and end sites.

    Raises :class:`BVHError` (a ``ValueError``) naming the file, the line and what was expected: bad
    numbers, NaN/inf, wrong value counts, unknown channels, unbalanced braces, ``Frames:`` disagreeing
    with the data, a frame time <= 0, absurd declared sizes (nothing is allocated from them).

    The size limits protect a notebook from a file that would exhaust memory; raise them per call for a
    take known to be larger: ``max_bytes`` (default :data:`stagger_nb.io.MAX_INPUT_BYTES`, 256 MiB)
    and ``max_samples`` (frames x joints, default :data:`~stagger_nb.core.motion.MAX_FRAME_JOINTS`).
    """
    path = file_path(path, "path")
    if max_bytes is not None:
        max_bytes = _positive_int(max_bytes, "max_bytes")
    return parse_bvh(read_bytes(path, BVHError, max_bytes), path, max_samples=max_samples)
