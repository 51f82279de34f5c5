"""The edit session: a source motion plus an ordered list of ops, replayed into the edited motion.

:class:`Session` holds the op list (:mod:`.history`: undo/redo, observers), the one cache of the expensive heads
(:mod:`.runners`, :mod:`.cache`), the replay (:mod:`.replay`), the background warm-up (:mod:`.warm`) and the
files (:mod:`.files`). Ops are validated on the way in (``add``/``set_ops``) and when a session file is loaded:
an unknown op, an unknown or missing field or a wrongly typed value raises ``ValueError`` naming the field
(e.g. ``ops[2].s``).
"""
from __future__ import annotations

import os
import weakref
from collections.abc import Callable
from concurrent.futures import Future

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_to_rotvec
from ..io._common import file_path
from .cache import Cache
from .cached_heads import CachedHeads
from .deprecated import REQUIRED
from .files import SessionFiles, read_source
from .heads import Heads
from .history import Flag, History
from .ops import Op
from .ops.fields import _fail, _limit, check_extract_options
from .quality import session_quality
from .replay import Replay
from .warm import Worker, next_step, warm_items
from .warp_steps import warm_next_lengths

__all__ = ["Session", "joint_rotation_degrees"]

def joint_rotation_degrees(motion: Motion, joint) -> np.ndarray:
    """Local rotation of ``joint`` (name or index) over time as a rotation vector, shape (F, 3), degrees."""
    j = motion.skeleton.index(joint) if isinstance(joint, str) else int(joint)
    return np.degrees(quat_to_rotvec(motion.local_quats[:, j]))


class Session(SessionFiles, CachedHeads):
    """A source motion plus an ordered list of ops; :meth:`edited` replays them.

    Parameters
    ----------
    source : Motion
        The unedited motion (never modified).
    ops : list of op dicts (or :class:`~.ops.Op`), optional
        Validated with :meth:`Op.from_json <stagger_nb.session.ops.Op.from_json>`.
    source_path : str, optional
        The file ``source`` was read from; saved sessions refer to it (with its SHA-256) instead of
        embedding the motion, and :meth:`save` / :meth:`export_bvh` refuse to overwrite it.
    extract_options : dict, optional
        Keyword arguments for ``staggered.extract`` (checked: names, types, ranges; saved with the session).

    Notes
    -----
    Each op list change (``add``, ``set_ops``, ``replace``, ``remove``, ``clear``) is one undo step.
    Listeners registered with :meth:`observe` are called as ``listener(session)`` after every change.
    """

    REQUIRED = REQUIRED  # deprecated with register_op
    #: Whether :meth:`check_ops` warms the next step of a slider (see :attr:`next_step`); False on an instance or
    #: the class turns it off (benchmarks compare both).
    warm_next_step = True

    def __init__(self, source: Motion, ops=None, source_path=None, extract_options=None):
        if not isinstance(source, Motion):
            raise ValueError(f"source: expected a Motion, got {type(source).__name__}")
        self.source = source
        self.source_path = None if source_path is None else os.path.abspath(file_path(source_path, "source_path"))
        self.extract_options = check_extract_options(extract_options)
        self._busy_listeners: list[Callable] = []
        self._ctx = Heads(Cache(busy=self._busy), source, self.extract_options)
        self._history = History(self._typed_list(ops or [], "ops"), owner=self)
        self._replay = Replay(self._ctx, source)
        self._worker = Worker()
        self._last_replayed: tuple = ()   # the op list checked last (check_ops), for the next slider step
        #: The warm-up of the next slider step (a Future, None before the first): :meth:`check_ops` of an op list
        #: that moved one number of one op from the list checked before warms the list one step further
        #: (session/warm.py, ``next_step``), so the next key press of that slider finds its replay cached; a moved
        #: guided-warp duration: its search at the next lengths (session/warp_steps.py).
        self.next_step = None
        weakref.finalize(self, self._worker.stop)   # a dropped session leaves no thread behind

    @classmethod
    def from_bvh(cls, path, ops=None, **kwargs) -> Session:
        """Read ``path`` as the source motion (remembering the path)."""
        motion, _ = read_source(file_path(path, "path"), "path")
        return cls(motion, ops, source_path=path, **kwargs)

    # -- ops ---------------------------------------------------------------------------------------
    @staticmethod
    def _typed(op, where: str) -> Op:
        return op if isinstance(op, Op) else Op.from_json(op, where)

    @classmethod
    def _typed_list(cls, ops, where) -> tuple:
        if not isinstance(ops, (list, tuple)):
            _fail(where, "a list of op objects", ops)
        _limit(ops, where)
        return tuple(cls._typed(op, f"{where}[{i}]") for i, op in enumerate(ops))

    @property
    def ops(self) -> list:
        """The current op list as JSON dicts (fresh copies: editing them does not edit the session)."""
        return [op.to_json() for op in self._history.ops]

    @property
    def typed_ops(self) -> tuple:
        """The current op list as typed, immutable :class:`~.ops.Op` objects."""
        return self._history.ops

    def __len__(self) -> int:
        return len(self._history.ops)

    def set_ops(self, ops, gesture=None) -> bool:
        """Replace the whole op list (one undo step); returns False when nothing changed. ``gesture``: a token;
        consecutive calls with the same one are one undo step (an editor's slider drag)."""
        return self._history.commit(self._typed_list(ops, "ops"), gesture=gesture)

    def check_ops(self, ops) -> None:
        """Replay the op list ``ops`` without changing the session (op list, history, observers): ValueError
        naming the field of a malformed op, :class:`~.replay.ReplayError` (a ValueError with ``index``,
        ``op`` and ``cause``) naming the op that fails at replay. What it computes is cached, so
        ``set_ops(ops)`` then ``edited()`` replays nothing (an editor tries a change this way first)."""
        typed = self._typed_list(ops, "ops")
        with self._worker.foreground():   # the warm-up gives way (session/warm.py)
            self._replay.check(typed)
        self._warm_next_step(typed)

    def _warm_next_step(self, ops: tuple) -> None:
        """After :meth:`check_ops` of ``ops``: when it moved one number of one op from the list checked before (a
        slider), warm the list one more step along (session/warm.py, ``next_step``; it gives way to every foreground
        replay between two ops and resumes at the next pause; :attr:`warm_next_step` False: not)."""
        nxt = next_step(self._last_replayed, ops) if self.warm_next_step else None
        before, self._last_replayed = self._last_replayed, ops
        if nxt is None and self.warm_next_step:   # a guided warp's duration: its next searches (warp_steps.py)
            self.next_step = warm_next_lengths(self._replay, self._worker, self._ctx, before, ops) or self.next_step
        if nxt is not None:
            replay, worker = self._replay, self._worker

            def wanted() -> bool:   # a foreground replay started, or a thread waits for the replay's lock
                return worker.wanted() or replay.waiting > 0

            def fill(report) -> None:   # Stopped (it gave way) goes to the worker: it resumes at the next pause
                try:
                    replay.check(nxt, None, stop=wanted)
                except (ValueError, ArithmeticError):
                    pass                # the failure shows when the user reaches that value
            self.next_step = worker.speculate("next step", fill)

    def add(self, op) -> bool:
        """Append one op."""
        cur = self._history.ops
        return self._history.commit(cur + (self._typed(op, f"ops[{len(cur)}]"),))

    def _index(self, index: int) -> int:
        n = len(self._history.ops)
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not -n <= index < n:
            raise ValueError(f"index: {index!r} is outside the {n} ops")
        return int(index) % n

    def replace(self, index: int, op) -> bool:
        """Replace op ``index`` (negative indices count from the end)."""
        i = self._index(index)
        new = list(self._history.ops)
        new[i] = self._typed(op, f"ops[{i}]")
        return self._history.commit(new)

    def remove(self, index: int) -> bool:
        i = self._index(index)
        new = list(self._history.ops)
        del new[i]
        return self._history.commit(new)

    def clear(self) -> bool:
        return self._history.commit(())

    def reset_history(self) -> None:
        """Forget undo and redo: the current op list becomes where :meth:`undo` stops (an editor's opening state,
        e.g. the first warp on the reference its constructor was given). The op list itself is unchanged."""
        self._history.rebase()

    @property
    def can_undo(self) -> Flag:
        """Whether :meth:`undo` would change something (a bool that may also be called: ``can_undo()``)."""
        return Flag(self._history.can_undo)

    @property
    def can_redo(self) -> Flag:
        return Flag(self._history.can_redo)

    def undo(self) -> bool:
        """Go back one change; returns False when there is nothing to undo."""
        return self._history.undo()

    def redo(self) -> bool:
        return self._history.redo()

    def observe(self, listener: Callable) -> None:
        """Call ``listener(session)`` after every change of the op list (undo and redo included)."""
        self._history.observe(listener)

    def unobserve(self, listener: Callable) -> None:
        self._history.unobserve(listener)

    def observe_busy(self, listener: Callable) -> None:
        """Call ``listener(kind, started)`` around expensive cached computations (``"extract"``, ``"cull"``,
        ``"graph"``, ``"basis"``, ``"warp"``, ``"reference"``), e.g. to show a progress bar. Called from the
        computing thread (the :meth:`warm` worker included)."""
        self._busy_listeners.append(listener)

    def unobserve_busy(self, listener: Callable) -> None:
        self._busy_listeners = [f for f in self._busy_listeners if f != listener]

    def _busy(self, kind: str, started: bool) -> None:
        for f in list(self._busy_listeners):
            f(kind, started)

    # -- replay (session/replay.py) ---------------------------------------------------------------------
    def states(self, progress: Callable | None = None) -> list:
        """The state after each op (``len(ops)`` items; Motion or StaggeredMotion).

        ``progress(done, total, label)`` is called before each op that is actually computed.
        """
        with self._worker.foreground():   # the warm-up gives way (session/warm.py)
            ops = self._history.ops
            return self._replay.walk(ops, len(ops), keep_all=True, progress=progress)

    def edited(self, progress: Callable | None = None) -> Motion:
        """The source motion with every op applied (a Motion; staggered states are evaluated).

        ``progress(done, total, label)`` is called before each op actually computed, with a fractional
        ``done`` while the op's long step reports (the staggered extraction, a cull refit, guided warping's
        tables and solve), and with ``"done"`` at the end; :func:`progress_bar` makes a tqdm bar of it."""
        if not self._history.ops:
            return self.source
        with self._worker.foreground():   # the warm-up gives way (session/warm.py)
            return self._replay.edited(self._history.ops, progress)

    def staggered(self, progress: Callable | None = None):
        """The last staggered representation of the replay (after the last staggered op), or the
        extraction of the source when no op is staggered."""
        return self._replay.staggered(self._history.ops, self.extraction, progress)

    def extraction(self):
        """The (cached) staggered extraction of the source motion."""
        return self._ctx.extract(self.source)

    def messages(self) -> list[str]:
        """Plain notes from the last replay, for the user: what a runner reported (an unreachable IK target,
        …) and the one plain timing sentence of the last staggered state (``staggered.timing_summary``: a
        timing edit limited to keep the poses in order, or knots that cross). Empty before the first replay."""
        return self._replay.messages(self._history.ops)

    def timing_warnings(self) -> tuple[str, tuple]:
        """``(summary, warnings)`` of the last staggered state of the replay (§5.2): the one plain sentence
        of :meth:`messages` (``staggered.timing_summary``; '' when none) and ``staggered.timing_warnings`` of
        that state (a tuple of ``TimingWarning``, the details). Both are computed once per state (keyed by the
        digest of the op prefix that made it: a slider move that leaves that state alone, or returns to it, does
        not recompute them); empty when no op is staggered."""
        return self._replay.timing_warnings(self._history.ops)

    def quality(self, bounds=None):
        """The :class:`~stagger_nb.quality.QualityReport` of the current edit against the source
        (``sn.quality.compare``: feet in their carried contacts, pelvis, pops, knot order, detail; with a
        ``keep_contacts`` op also against the same edit without it), cached per op list; ``bounds`` a preset
        name, ``Bounds`` or dict (default ``"mild"``). See :mod:`stagger_nb.session.quality`."""
        return session_quality(self, bounds)

    def quality_summary(self, bounds=None) -> str:
        """The one-line summary of :meth:`quality` ("feet held · pelvis ±0.8 cm · no pops"; what is out of
        bounds named plainly); its parts for a widget: ``quality().items``."""
        return self.quality(bounds).summary

    def warp_curve(self, index: int = -1):
        """The time warp computed by the warp op at ``index``: (N,) input seconds of each output frame
        (None when that op is not a warp)."""
        return self._replay.warp_curve(self._history.ops, self._index(index))

    # -- background cache fills --------------------------------------------------------------------
    def warm(self, *jobs, progress: Callable | None = None) -> Future:
        """Fill the caches in the background, on the session's own executor (one worker thread).

        Each job is one of

        - ``"extract"``: the staggered extraction of the source;
        - ``("cull", percents)``: ``cull`` of that extraction for each percent (a slider's positions);
        - ``("wand_basis", sigmas)``: the magic wand's pose graph of the source, then its basis per sigma
          (``None`` = the default sigma);
        - ``("compare", [(name, sigma), ...])``: the heads of :meth:`falloff_curves`' comparison curves,
          ``"isomap"`` (its graph; sigma ignored) or ``"diffusion"`` (its coordinates for sigma);
        - ``("warp_tables", warps)``: guided warping's kNN tables of the source for each warp, a
          ``guided_warp`` op (dict or :class:`~.ops.GuidedWarp`) whose reference, skip, duration, free_length,
          backward and upsample choose the table; a table also serves every smaller skip (sliced), so an
          editor warms its skip slider's largest value only.
        - ``("replay", op_lists)``: the replay of each op list (a list of op dicts, checked like
          :meth:`set_ops`) into the cache, step by step under the digest of each op prefix, without changing
          this session's op list or history: a later ``set_ops`` to one of them (a slider's next positions)
          replays nothing. Lists share their common prefixes' states. Bounded by the cache (count and bytes).

        Jobs are checked now (ValueError naming ``jobs[i]``); they run in order, one item at a time.
        ``progress(done, total, label)`` is called from the worker before each item, with a fractional
        ``done`` while an extraction, cull refit or warp table reports how far it is, and once at the end
        (e.g. ``progress=progress_bar("warm")``, a tqdm bar).

        Returns a :class:`concurrent.futures.Future` whose result is the number of items computed (or found
        cached). ``future.cancel()`` stops the work before its next item (the item running finishes and is
        cached) and makes the future cancelled; ``running()`` stays False until it is done. The worker is a
        daemon thread: an interpreter exit does not wait for it. Everything warmed is also computed on
        demand: warming only moves the wait.
        """
        return self._worker.submit(warm_items(self, jobs), progress)

    def close(self, wait: bool = False) -> None:
        """Cancel pending warm-ups (each stops before its next item) and end the warm-up thread after the item
        running now; with ``wait``, also wait until it has ended (e.g. before timing something else in this
        process, whose CPU time would otherwise include it). The session stays usable: a later :meth:`warm`
        starts a new thread. A session that is garbage-collected is closed the same way."""
        self._worker.stop()
        if wait:
            self._worker.join()

    def __repr__(self) -> str:
        src = os.path.basename(self.source_path) if self.source_path else repr(self.source)
        names = [o.name for o in self._history.ops]
        shown = ", ".join(names[:12]) + (f", … ({len(names) - 12} more)" if len(names) > 12 else "")
        return f"Session({src}, {len(names)} ops: {shown or '-'})"
