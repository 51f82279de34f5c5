"""The motion block of a BVH file: the C accelerator's read (:func:`accelerated`), the ~1 MB pieces parsed on
up to 4 threads (:func:`_read_chunks`, :class:`_Layout` converting each piece's angles straight into the output
arrays) and the line-by-line parser that names the first bad line (:func:`_parse_motion_lines`);
:func:`read_block` runs them in that order (see :mod:`.bvh_read` for the semantics and the guarantees)."""
from __future__ import annotations

import os
import threading

import numpy as np

from ..core.accel import accel_allowed
from ..core.motion import _continuous_inplace
from ..core.rotations import quat_continuous
from ..core.skeleton import Skeleton
from ._common import (
    _EULER_BLOCK,
    MAX_TOKEN,
    decode,
    euler_components,
    euler_deg_to_quat,
    quarter_tan,
    split_values,
)
from ._numparse import NUMBER_RE, content_end, parse_lines
from .bvh_header import BVHError

try:
    from . import _cparse  # the optional C accelerator (setup.py builds it where a compiler is found)
except ImportError:  # pragma: no cover - installed without a compiler: numpy + pyarrow parse the block
    _cparse = None


def accelerated() -> bool:
    """Whether :func:`read_bvh` parses motion blocks with the C accelerator (``stagger_nb/io/_cparse.c``).
    True when it was built at install time (``pip install`` compiles it where a C compiler is found) and
    the environment variable ``STAGGER_NB_NO_ACCEL`` is unset, empty or ``0``; any other value forces the
    numpy + pyarrow path (read at every call), which gives bit-identical motions, only slower."""
    return _cparse is not None and accel_allowed()


_C_CONTINUITY: list[bool] = []  # the answer of _c_continuity, once known


def _c_continuity() -> bool:
    """Whether the C accelerator's hemisphere continuity decides exactly as numpy's ``einsum`` does here
    (:func:`~stagger_nb.core.rotations.quat_continuous`): its dot products are summed in the order
    ``(x x' + z z') + (y y' + w w')``, numpy's here (an AVX-512 build); another order (other builds or
    CPUs) is detected on pairs of quaternions whose sign of dot product depends on it, and the reader
    then keeps numpy's pass. Checked once per process (0.6 ms), on the first accelerated read."""
    if not accelerated():
        return False
    if not _C_CONTINUITY:
        # 512 pseudo-random pairs (a hash, not numpy.random: it is not imported yet), made orthogonal:
        # ~40 of them get the sign of their dot product wrong in any other summation order
        a, b = ((np.sin(np.arange(1.0, 4097.0) * 12.9898) * 43758.5453) % 1.0 - 0.5).reshape(2, 512, 1, 4)
        b = b - (np.einsum("fji,fji->fj", a, b) / np.einsum("fji,fji->fj", a, a))[..., None] * a  # dots ~ 0
        q = np.empty((2 * len(a), 1, 4))
        q[0::2], q[1::2] = b, a  # frame pairs (b, a): the odd frames' flips depend on dot(a, b) < 0
        mine = q.copy()
        _cparse.make_continuous(mine, 1)
        _C_CONTINUITY.append(np.array_equal(quat_continuous(q).view(np.int64), mine.view(np.int64)))
    return _C_CONTINUITY[0]


def _parse_motion_lines(block: bytes, first_ln: int, num_frames: int, num_channels: int, source: str,
                        start: int = 0, first_frame: int = 0):
    """Line-by-line parse of the frame lines ``block[start:]`` (frames ``first_frame`` on, the first on
    line ``first_ln``) into ``(num_frames - first_frame, C)`` floats; raises :class:`BVHError` at the first
    bad line (the reference for :func:`parse_table`, and the fallback where a piece cannot be certified).
    Lines are taken one at a time and split into at most ``C + 1`` pieces, so a hostile block (millions
    of blank lines, a line of millions of values) costs no more memory than its output."""
    stop = _data_end(block, start)
    out = np.empty((max(0, min(num_frames - first_frame, block.count(b"\n", start, stop) + 1)), num_channels))
    first_ln -= first_frame  # so that frame k is on line first_ln + k
    k, pos = first_frame, start
    longest = (num_channels + 1) * (MAX_TOKEN + 1)
    while pos < stop:
        nl = block.find(b"\n", pos, stop)
        end = stop if nl < 0 else nl
        line = block[pos:min(end, pos + longest)]  # a prefix: enough to find C + 1 tokens of sane length
        pos = end + 1
        ln = first_ln + k
        if k >= num_frames:
            raise BVHError(source, ln, f"more frame lines than 'Frames: {num_frames}' declares")
        toks = split_values(line, num_channels, len(line) == longest, f"on frame {k}", source, ln, BVHError)
        for c, t in enumerate(toks):
            if not NUMBER_RE.match(t):
                raise BVHError(source, ln, f"expected a number on frame {k}, found {decode(t[:40])!r}")
            v = float(t)
            if not np.isfinite(v):
                raise BVHError(source, ln, f"expected a finite number on frame {k}, found {decode(t[:40])!r}")
            out[k - first_frame, c] = v
        k += 1
    if k < num_frames:
        raise BVHError(source, first_ln + max(k - 1, 0),
                       f"file ends early: 'Frames: {num_frames}' declared, {k} frame lines found")
    return out


_ACCEL_VALUES = 1 << 16  # values per piece of the C parser's read (a 512 KB scratch buffer, reused)


_PIECE_BYTES = 1 << 20  # the motion block is parsed and converted in pieces of about this size ...


_MIN_PIECE_BYTES = 1 << 18  # ... split among the CPUs, but no smaller than this (a thread hand-off costs ~0.1 ms)


_MAX_PIECE_BYTES = 4 << 20  # a piece this long (one huge line) goes to the line parser: bounded memory


def _data_end(raw: bytes, pos: int) -> int:
    """The end of the last non-blank byte of ``raw[pos:]`` (trailing blank lines are allowed)."""
    return pos + content_end(memoryview(raw)[pos:])


def _pieces(raw: bytes, pos: int, stop: int, workers: int) -> list[tuple[int, int]]:
    """``[pos, stop)`` cut after line breaks into pieces of about ``_PIECE_BYTES`` (at least ``workers``
    of them when each still gets ``_MIN_PIECE_BYTES``)."""
    size = stop - pos
    n = max(1, min(-(-size // _MIN_PIECE_BYTES), max(workers, -(-size // _PIECE_BYTES))))
    step = -(-size // n)
    out = []
    while pos < stop:
        nl = raw.find(b"\n", min(pos + step, stop), stop)
        end = stop if nl < 0 else nl + 1
        out.append((pos, end))
        pos = end
    return out


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        return os.cpu_count() or 1


_MAX_THREADS = 4


_POOL = None


_POOL_PID = None


def _pool(workers: int):
    """A thread pool of ``workers - 1`` threads (the caller's thread is the other one), created once per
    process (a forked child makes its own: threads do not survive ``fork``)."""
    global _POOL, _POOL_PID
    if _POOL is None or _POOL_PID != os.getpid():
        from concurrent.futures import ThreadPoolExecutor
        _POOL = ThreadPoolExecutor(max_workers=workers - 1, thread_name_prefix="stagger_nb-read_bvh")
        _POOL_PID = os.getpid()
    return _POOL


def _read_chunks(raw: bytes, pos: int, stop: int, nf: int, C: int, layout: _Layout, out) -> tuple[int, int]:
    """Parse ``raw[pos:stop]`` (``nf`` lines of ``C`` numbers) piece by piece with
    :func:`._numparse.parse_lines`, each piece converted into its frames of ``out`` at once, the pieces
    spread over the CPUs (numpy and pyarrow release the GIL). Returns ``(position, frames)``: where the
    first piece that could not be certified starts and the frames before it (``(stop, nf)`` when all
    were), so the line-by-line parser reads or reports only the rest: a bad last line of a long take
    costs one piece of slow parsing, not the whole file.

    A piece's first frame is the sum of the line counts of the pieces before it, which each piece
    publishes as soon as it is parsed; pieces start in order, so a piece only ever waits for pieces that
    have already started."""
    workers = min(_cpus(), _MAX_THREADS)
    bounds = _pieces(raw, pos, stop, workers)
    n = len(bounds)
    rows = [-1] * n
    parsed = [threading.Event() for _ in range(n)]
    view = memoryview(raw)

    def piece(k: int) -> bool:
        a, b = bounds[k]
        try:
            data = parse_lines(view[a:b], C, max_rows=nf) if b - a <= _MAX_PIECE_BYTES else None
            if data is not None:
                rows[k] = data.shape[1]
        finally:
            parsed[k].set()
        if data is None:
            return False
        first = 0
        for j in range(k):
            parsed[j].wait()
            if rows[j] < 0:
                return False
            first += rows[j]
        if first + rows[k] > nf:
            return False
        layout.fill(data, first, out)
        return True

    if n == 1 or workers == 1:
        ok = []
        for k in range(n):
            ok.append(piece(k))
            if not ok[-1]:
                break
    else:
        futures = [_pool(workers).submit(piece, k) for k in range(1, n)]
        ok = [False]
        try:
            ok[0] = piece(0)
        finally:  # no thread may still write into ``out`` when this returns
            ok += [f.result() for f in futures]
    first_bad = next((k for k, good in enumerate(ok) if not good), None)
    if first_bad is None:
        return stop, sum(rows)
    return bounds[first_bad][0], sum(rows[:first_bad])


class _Layout:
    """Where each column of the ``(F, C)`` channel table goes: root position axes, animated joint
    translations, and rotations grouped by channel order (one vectorised conversion per order)."""

    def __init__(self, skel: Skeleton):
        self.skel = skel
        self.root_pos, self.trans = [], []  # (axis, col), (joint, axis, col)
        groups: dict[str, tuple[list, list]] = {}
        col = 0
        for j, chans in enumerate(skel.channels):
            rot_cols, order = [], ""
            for c in chans:
                axis = "XYZ".index(c[0].upper())
                if c[1:].lower() == "position":
                    (self.root_pos.append((axis, col)) if j == 0 else self.trans.append((j, axis, col)))
                else:
                    rot_cols.append(col)
                    order += c[0].upper()
                col += 1
            if order:
                joints, cols = groups.setdefault(order, ([], []))
                joints.append(j)
                cols.append(rot_cols)
        J = skel.num_joints
        self.groups = [(order, joints, np.array(cols)) for order, (joints, cols) in groups.items()]
        # every joint in one order and in file order: the conversion writes the output rows directly
        self.direct = len(self.groups) == 1 and self.groups[0][1] == list(range(J))
        self.num_channels = col
        self._plan = None

    def _accel_plan(self):
        """Where the C parser puts each column of a piece of ``R`` frames in its scratch buffer: position
        columns as an ``(R, P)`` table, then per rotation group (order, joints ``Jg``, ``L`` angles) an
        ``(L, R, Jg)`` table, frame-major within each angle: the layout the conversion writes from
        without transposes. ``(R, base (C,), stride (C,), group offsets, scratch size)``."""
        if self._plan is None:
            C = self.num_channels
            rotating = sum(len(joints) for _, joints, _ in self.groups)  # a piece's rotations: one block of
            R = max(1, min(_ACCEL_VALUES // C, _EULER_BLOCK // max(1, rotating)))  # euler_components
            base, stride = np.empty(C, np.int64), np.empty(C, np.int64)
            pos_cols = [col for _, col in self.root_pos] + [col for _, _, col in self.trans]
            base[pos_cols] = np.arange(len(pos_cols))
            stride[pos_cols] = len(pos_cols)
            off, offsets = R * len(pos_cols), []
            for _, _, cols in self.groups:
                Jg, L = cols.shape
                for k in range(L):
                    base[cols[:, k]] = off + k * R * Jg + np.arange(Jg)
                    stride[cols[:, k]] = Jg
                offsets.append(off)
                off += L * R * Jg
            self._plan = R, base, stride, offsets, off
        return self._plan

    def read_accelerated(self, raw: bytes, pos: int, stop: int, nf: int, out) -> bool:
        """Parse ``raw[pos:stop]`` (``nf`` lines of ``C`` numbers) with the C parser, ``R`` frames at a
        time into one reused scratch buffer, each piece converted into its frames of ``out`` at once
        (numpy's tan, then the rest of :func:`euler_components` in C: the same bits).
        False when the C parser does not certify the block (``out`` is then partly written: the caller
        parses the block again, which rewrites every value it sets)."""
        R, base, stride, offsets, size = self._accel_plan()
        scratch = np.empty(size)
        tmp = np.empty(3 * R * max([len(joints) for _, joints, _ in self.groups] + [0]))  # quarter_tan's scratch
        root_pos, quats, trans = out
        P = len(self.root_pos) + len(self.trans)
        row = 0
        while row < nf:
            n = min(R, nf - row)
            pos = _cparse.parse_rows(raw, pos, stop, n, scratch, base, stride)
            if pos < 0:
                return False
            sl = slice(row, row + n)
            if P:
                table = scratch[:R * P].reshape(R, P)
                for p, (axis, _) in enumerate(self.root_pos):
                    root_pos[sl, axis] = table[:n, p]
                for p, (j, axis, _) in enumerate(self.trans, len(self.root_pos)):
                    trans[sl, j, axis] = table[:n, p]
                if trans is not None:
                    trans[sl, 0] = root_pos[sl]
            for (order, joints, cols), off in zip(self.groups, offsets):
                Jg, L = cols.shape
                ang = scratch[off:off + L * R * Jg].reshape(L, R, Jg)[:, :n]  # (L, n, Jg) degrees
                if L == 3 and len(set(order)) == 3:
                    # numpy's tan (its bits), then the rest of euler_components in one C loop (same operations)
                    t = quarter_tan(ang.reshape(3, -1), tmp[:3 * n * Jg].reshape(3, -1))
                    if n < R:  # the last piece: three rows at a stride of R * Jg
                        t = np.ascontiguousarray(t)
                    if self.direct:  # rotation (frame, joint) is row frame * J + joint of the output
                        _cparse.quats_from_tangents(t, order, quats[sl].reshape(-1, 4))
                    else:
                        q = np.empty((n * Jg, 4))
                        _cparse.quats_from_tangents(t, order, q)
                        quats[sl, joints] = q.reshape(n, Jg, 4)
                else:
                    quats[sl, joints] = euler_deg_to_quat(np.moveaxis(ang, 0, -1), order)
            row += n
        return pos == stop

    def empty(self, F: int):
        """Output arrays for ``F`` frames: root positions ``(F, 3)`` (the root OFFSET where not animated),
        local quaternions ``(F, J, 4)`` (identity where a joint has no rotation channels) and joint
        translations ``(F, J, 3)`` or ``None``."""
        skel, J = self.skel, self.skel.num_joints
        root_pos = np.empty((F, 3))
        root_pos[:] = skel.offsets[0]
        if self.direct:
            quats = np.empty((F, J, 4))
        else:
            quats = np.zeros((F, J, 4))
            quats[..., 3] = 1.0
        trans = None
        if self.trans:
            trans = np.empty((F, J, 3))
            trans[:] = skel.offsets
        return root_pos, quats, trans

    def fill(self, data: np.ndarray, row: int, out) -> None:
        """Convert the table ``data (C, n)`` (column-major: one row per channel) into frames
        ``[row, row + n)`` of ``out``."""
        root_pos, quats, trans = out
        sl = slice(row, row + data.shape[1])
        for axis, col in self.root_pos:
            root_pos[sl, axis] = data[col]
        for j, axis, col in self.trans:
            trans[sl, j, axis] = data[col]
        if trans is not None:
            trans[sl, 0] = root_pos[sl]
        for order, joints, cols in self.groups:
            dst = quats[sl] if self.direct else np.empty((data.shape[1], len(joints), 4))
            if len(order) == 3 and len(set(order)) == 3:  # (3, joints, n) angles -> (4, joints, n) components
                comps = euler_components(data[cols.T], order)
                for c in range(4):  # one 2-D transpose per component: ~4x faster than numpy's 3-D one
                    dst[..., c] = comps[c].T
            else:
                dst[...] = euler_deg_to_quat(data[cols].transpose(2, 0, 1), order)
            if not self.direct:
                quats[sl, joints] = dst


def read_block(raw: bytes, pos: int, nf: int, skel, num_channels: int, ln: int, source: str):
    """``(root_positions, local_quats, local_translations)`` of the ``nf`` frames of the motion block of
    ``raw`` that starts at byte ``pos`` (``ln``: the line before its first frame, the ``Frame Time:`` line),
    read by the C accelerator, else by pieces on threads, the rest (or the first bad line's error) by the
    line-by-line parser; the quaternions hemisphere-continuous, with no -0 component."""
    layout = _Layout(skel)
    stop = _data_end(raw, pos)
    out, done, continuous = None, 0, False
    if num_channels == 0:
        if stop == pos:
            out, done = layout.empty(nf), nf
    elif stop - pos >= 2 * nf * num_channels - 1:  # a value and its separator take >= 2 bytes: a block that
        # cannot hold the declared values allocates nothing (the line parser reports where it ends)
        out = layout.empty(nf)
        if accelerated() and layout.read_accelerated(raw, pos, stop, nf, out):
            pos, done = stop, nf
            if _c_continuity():  # one C pass instead of numpy's einsum + mask (~0.85 -> ~0.2 ms on CMU 01_01)
                _cparse.make_continuous(out[1], skel.num_joints)
                continuous = True
        else:  # no accelerator, or a block it does not certify: today's parser (same values, or the error)
            pos, done = _read_chunks(raw, pos, stop, nf, num_channels, layout, out)
    if done < nf or pos < stop:  # the line-by-line parser reads the rest, or reports its first bad line
        data = _parse_motion_lines(raw, ln + 1 + done, nf, num_channels, source, start=pos, first_frame=done)
        if out is None:
            out = layout.empty(nf)
        layout.fill(data.T, done, out)
    root_pos, quats, trans = out
    if not continuous:
        _continuous_inplace(quats)
    # no negative zeros: every -0 component becomes +0 (nothing else changes), after the sign flips of
    # continuity, so the two paths (and any cut of the block) agree on the sign of zero by construction
    quats += 0.0
    return root_pos, quats, trans
