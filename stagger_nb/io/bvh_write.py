"""BVH (Biovision Hierarchy) writer: :func:`write_bvh`, :func:`format_bvh` (the reader is :mod:`.bvh_read`;
:mod:`.bvh` is the public module holding both).

Each joint's channel order and the end-site offsets are kept; rotation channels are intrinsic Euler angles in
degrees in the order listed. The channel table is formatted with a vectorised fixed-point formatter
(rotations to 1e-6 degree, positions to 1e-8 of the largest translation) and the file replaced atomically.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_angle, quat_to_euler
from ..core.skeleton import Skeleton
from ._common import atomic_write_bytes, euler_deg_to_quat
from ._numformat import format_table
from .bvh_read import name_fits_bvh

__all__ = ["write_bvh", "format_bvh", "bvh_bytes"]


_ROT_DECIMALS = 6  # degrees: 5e-7 deg = 9e-9 rad worst-case rounding


def _position_decimals(motion: Motion) -> int:
    """Decimal places for position channels: 1e-8 of the largest translation (at least 6, at most 12),
    so the written file reproduces world positions well within 1e-6 of the skeleton's size."""
    scale = max(float(np.max(np.abs(motion.root_positions))), float(np.max(np.abs(motion.skeleton.offsets))),
                0.0 if motion.local_translations is None else float(np.max(np.abs(motion.local_translations))),
                1e-12)
    return int(np.clip(8 - np.floor(np.log10(scale)), 6, 12))


_FORMAT_BLOCK = 1 << 17  # values formatted at once by write_bvh (~15 MB of temporaries)
_MAX_INDENT = 16  # tabs: deeper joints are not indented further, so the text grows linearly with depth



def _check_names(skel: Skeleton) -> None:
    """``ValueError`` naming the joint whose name the format cannot hold (see :func:`name_fits_bvh`)."""
    for j, name in enumerate(skel.names):
        if not name_fits_bvh(name):
            raise ValueError(f"write_bvh: joint {j} has the name {name!r}, which BVH cannot hold (names need "
                             "printable characters, single spaces between words, no line breaks or tabs, "
                             "no lone braces): rename the joint")


def _hierarchy_lines(skel: Skeleton) -> tuple[list[str], list[int]]:
    """The HIERARCHY section (iterative depth-first walk; children in index order) and the joints in
    the order written, which is the order of their channels in each frame line."""
    kids = [[] for _ in range(skel.num_joints)]
    for j in range(1, skel.num_joints):
        kids[int(skel.parents[j])].append(j)
    out = ["HIERARCHY"]
    written = []
    stack = [(0, 0, False)]
    while stack:
        j, depth, closing = stack.pop()
        ind = "\t" * min(depth, _MAX_INDENT)
        if closing:
            if j in skel.end_sites:
                e = skel.end_sites[j]
                out += [f"{ind}\tEnd Site", f"{ind}\t{{", f"{ind}\t\tOFFSET {e[0]:.9g} {e[1]:.9g} {e[2]:.9g}",
                        f"{ind}\t}}"]
            out.append(f"{ind}}}")
            continue
        o = skel.offsets[j]
        written.append(j)
        out += [f"{ind}{'ROOT' if j == 0 else 'JOINT'} {skel.names[j]}", f"{ind}{{",
                f"{ind}\tOFFSET {o[0]:.9g} {o[1]:.9g} {o[2]:.9g}",
                f"{ind}\tCHANNELS {len(skel.channels[j])}" + "".join(" " + c for c in skel.channels[j])]
        stack.append((j, depth, True))
        stack.extend((c, depth + 1, False) for c in reversed(kids[j]))
    return out, written


def _partial_euler(q: np.ndarray, order: str) -> np.ndarray:
    """Angles ``(F, 3)`` (degrees) in ``order`` plus the missing axes, whose leading ``len(order)`` angles
    reproduce ``q (F, 4)`` whenever it is a rotation about those one or two axes. scipy keeps the middle
    angle in [-90, 90] and may return the equivalent ``(a + 180, 180 - b, c + 180)``; for a two-axis
    rotation that puts 180 in the dropped third angle, so it is turned back into ``(a, b, 0)``."""
    full = order + "".join(a for a in "XYZ" if a not in order)[: 3 - len(order)]
    e = quat_to_euler(q, full)
    if len(order) == 2:
        flip = np.abs(e[:, 2]) > 90.0
        e[flip, 0] += 180.0
        e[flip, 1] = 180.0 - e[flip, 1]
        e[flip, 2] -= np.copysign(180.0, e[flip, 2])
        e[:, :2] = (e[:, :2] + 180.0) % 360.0 - 180.0
    return e


def _joint_translation(motion: Motion, j: int) -> np.ndarray:
    """Translations ``(F, 3)`` of joint ``j`` (a view where possible: no (F, J, 3) copy of the whole rig)."""
    if j == 0:
        return motion.root_positions
    if motion.local_translations is not None:
        return motion.local_translations[:, j]
    return np.broadcast_to(motion.skeleton.offsets[j], (motion.num_frames, 3))


def _by_frames(fn, q: np.ndarray) -> np.ndarray:
    """``fn(q)`` (angles ``(F, ..., 3)`` of quaternions ``q (F, ..., 4)``) computed in blocks of
    ``_CHECK_BLOCK`` frames into one output: the conversion's temporaries stay a few MB on a long take."""
    out = np.empty(q.shape[:-1] + (3,))
    for f0 in range(0, q.shape[0], _CHECK_BLOCK):
        out[f0:f0 + _CHECK_BLOCK] = fn(q[f0:f0 + _CHECK_BLOCK])
    return out


def _channel_table(motion: Motion, joint_order: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The ``(F, C)`` channel values of the joints in ``joint_order`` (the file's order) and the decimals
    for each column."""
    skel = motion.skeleton
    pos_dec = _position_decimals(motion)
    orders = ["".join(c[0].upper() for c in chans if c.lower().endswith("rotation")) for chans in skel.channels]
    full: dict[int, np.ndarray] = {}  # joint -> (F, 3) angles: one conversion per three-axis order
    for order in {o for o in orders if len(o) == 3}:
        joints = [j for j, o in enumerate(orders) if o == order]
        eul = _by_frames(lambda q, o=order: quat_to_euler(q, o), motion.local_quats[:, joints])
        full.update((j, eul[:, k]) for k, j in enumerate(joints))
    cols, dec = [], []
    for j in joint_order:
        chans = skel.channels[j]
        order = orders[j]
        eul = full.get(j)
        if order and eul is None:  # fewer than three rotation channels: the listed angles of a completed sequence
            eul = _by_frames(lambda q, o=order: _partial_euler(q, o), motion.local_quats[:, j])
        r = 0
        for c in chans:
            if c.lower().endswith("position"):
                cols.append(_joint_translation(motion, j)[:, "XYZ".index(c[0].upper())])
                dec.append(pos_dec)
            else:
                cols.append(eul[:, r])
                dec.append(_ROT_DECIMALS)
                r += 1
    table = np.stack(cols, axis=1) if cols else np.zeros((motion.num_frames, 0))
    return table, np.array(dec, dtype=np.int64)


_CHECK_BLOCK = 1 << 16  # frames checked at once by _rotates_beyond (a few MB of temporaries)


def _rotates_beyond(q: np.ndarray, order: str) -> bool:
    """Does ``q (F, 4)`` rotate about axes other than the one or two of ``order`` (beyond ``_ROT_TOL``)?
    Checked in blocks of frames, so a long take costs no more memory than a short one."""
    for f0 in range(0, q.shape[0], _CHECK_BLOCK):
        qb = q[f0:f0 + _CHECK_BLOCK]
        back = (euler_deg_to_quat(_partial_euler(qb, order)[:, :len(order)], order) if order
                else np.broadcast_to([0.0, 0.0, 0.0, 1.0], qb.shape))
        if float(np.max(quat_angle(qb, back))) > _ROT_TOL:
            return True
    return False


_ROT_TOL = 1e-8  # rad: a rotation further than this from what a joint's channels can express needs more
_POS_TOL = 1e-9  # of the largest translation: likewise for a translation on an axis without a channel


def _faithful(motion: Motion) -> Motion:
    """``motion`` with channels added to the joints whose channels cannot express their motion (an edit
    about z on a ``CHANNELS 1 Xrotation`` joint, a translation of a joint without position channels),
    each said in a ``UserWarning`` naming the joint; unchanged when every joint's channels suffice."""
    skel = motion.skeleton
    scale = max(float(np.max(np.abs(motion.root_positions), initial=0.0)), float(np.max(np.abs(skel.offsets))),
                1e-12)
    new_channels = list(skel.channels)
    for j, chans in enumerate(skel.channels):
        order = "".join(c[0].upper() for c in chans if c.lower().endswith("rotation"))
        have_pos = {c[0].upper() for c in chans if c.lower().endswith("position")}
        add_rot = ""
        if len(order) < 3 and _rotates_beyond(motion.local_quats[:, j], order):
            add_rot = "".join(a for a in "ZXY" if a not in order)
        add_pos = ""
        if len(have_pos) < 3 and (j == 0 or motion.local_translations is not None):
            t = _joint_translation(motion, j)
            off = skel.offsets[j]  # max |t - off| per axis from t's extremes: no (F, 3) temporaries
            reach = np.maximum(np.abs(np.max(t, axis=0, initial=-np.inf) - off),
                               np.abs(np.min(t, axis=0, initial=np.inf) - off)) if len(t) else np.zeros(3)
            moved = reach > _POS_TOL * scale
            add_pos = "".join(a for k, a in enumerate("XYZ") if moved[k] and a not in have_pos)
            if add_pos:
                add_pos = "".join(a for a in "XYZ" if a not in have_pos)
        if not (add_rot or add_pos):
            continue
        chans = list(chans)
        pos_at = max((k + 1 for k, c in enumerate(chans) if c.lower().endswith("position")), default=0)
        chans[pos_at:pos_at] = [a + "position" for a in add_pos]
        rot_at = max((k + 1 for k, c in enumerate(chans) if c.lower().endswith("rotation")), default=len(chans))
        chans[rot_at:rot_at] = [a + "rotation" for a in add_rot]
        new_channels[j] = tuple(chans)
        what = " and ".join(w for w, a in (("rotates about other axes", add_rot), ("moves", add_pos)) if a)
        warnings.warn(f"write_bvh: joint {skel.names[j]!r} {what} than its channels "
                      f"({' '.join(skel.channels[j]) or 'none'}) can express; written with CHANNELS "
                      f"{len(chans)} {' '.join(chans)} so the file holds the motion", UserWarning, stacklevel=4)
    if new_channels == list(skel.channels):
        return motion
    return motion.replace(skeleton=Skeleton(skel.names, skel.parents, skel.offsets, tuple(new_channels),
                                            skel.end_sites))


def _format_bytes(motion: Motion) -> bytes:
    if not isinstance(motion, Motion):
        raise ValueError(f"write_bvh: motion must be a stagger_nb Motion, got {type(motion).__name__}")
    _check_names(motion.skeleton)
    motion = _faithful(motion)
    head, joint_order = _hierarchy_lines(motion.skeleton)
    head += ["MOTION", f"Frames: {motion.num_frames}", f"Frame Time: {motion.frame_time:.9g}"]
    table, dec = _channel_table(motion, joint_order)
    parts = [("\n".join(head) + "\n").encode("utf-8")]
    # blocks of rows: the formatter holds ~15 int64 temporaries per value, so a whole long take (3M frames
    # x 1 channel) would peak at ~0.5 GB; blocks keep that to a few MB beside the text itself
    step = max(1, _FORMAT_BLOCK // max(table.shape[1], 1))
    for r0 in range(0, table.shape[0], step):
        block = table[r0:r0 + step]
        body = format_table(block, dec)
        if body is None:  # a value too large for fixed point: 9 significant digits instead
            body = "".join(" ".join(f"{v:.9g}" for v in row) + "\n" for row in block).encode()
        parts.append(body)
    return b"".join(parts)


def bvh_bytes(motion: Motion) -> bytes:
    """The UTF-8 bytes :func:`write_bvh` writes (the text of :func:`format_bvh`), for a writer with its own
    target policy (the batch writes them inside its output folder)."""
    return _format_bytes(motion)


def format_bvh(motion: Motion) -> str:
    """BVH text of ``motion``: each joint's channel order and the end-site offsets kept; rotations with
    6 decimals (degrees), positions with 6-12 decimals by their size (see :func:`_position_decimals`).
    BVH lists joints depth-first, so a skeleton stored in another parents-first order reads back with
    its joints in depth-first order (same names, same motion). Channels are added where needed, and
    bad joint names refused, as in :func:`write_bvh`."""
    return _format_bytes(motion).decode("utf-8")


def write_bvh(motion: Motion, path) -> None:
    """Write ``motion`` as BVH (see :func:`format_bvh`) atomically: the text is written to an unnamed
    file in the destination folder, synced, then renamed over ``path`` (see
    :func:`._common.atomic_write_bytes`), so readers see the old file or the new one, never half of one;
    the file gets the usual permissions (umask, or the mode of the file it replaces).

    A joint whose channels cannot express its motion (fewer than three rotation channels and a rotation
    about another axis, or a translation without position channels) is written with the channels it
    needs, and a ``UserWarning`` names it. A joint name the format cannot hold (line breaks, tabs, runs
    of spaces, lone braces) raises ``ValueError`` naming the joint; nothing is written then."""
    atomic_write_bytes(path, _format_bytes(motion))
