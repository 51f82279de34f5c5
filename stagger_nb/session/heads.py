"""The expensive heads of the techniques, each computed once in the session's one cache (:mod:`.cache`) and
shared by every op list reaching the same state: the staggered extraction and its culls, exaggeration bases,
forward kinematics, the magic wand's pose graph, eigenbases and falloffs, warp references and guided warping's
kNN tables.

:class:`Heads` computes and keeps them (the runners read them as ``run.heads``);
:class:`~.cached_heads.CachedHeads` is the part of :class:`~stagger_nb.session.Session` that offers them to callers
and to the editors' views.
"""
from __future__ import annotations

import inspect
from collections.abc import Callable

from ..core.kinematics import forward_kinematics
from ..core.motion import Motion
from ..io.bvh import read_bvh
from .cache import Cache
from .ops import MAX_SKIP
from .ops.fields import number, optional
from .run import _staggered, _timewarp, _wand

__all__ = ["Heads", "DIFFUSION_TOL", "DIFFUSION_MAX_FRAMES", "SWEEP_FRAMES", "SWEEP_MARGIN"]

DIFFUSION_TOL = 1e-8  # diffusion comparison: coordinates weighted below this fraction are left out (Heads.diffusion)
DIFFUSION_MAX_FRAMES = 6000  # ... and clips longer than this are refused (a dense F x F kernel: 0.27 GiB here)
SWEEP_FRAMES = 128  # Heads.sweep_ahead: the lengths a sweep searches, +- this many output frames around the current
SWEEP_MARGIN = 32   # ... (+-1.07 s at 120 Hz, ~5 px of the duration track), rebuilt around a new length this close to
                    # its ends

_percent = number(0.0, 100.0, open_lo=True)
_sigma = optional(number(0.0, open_lo=True))


class Heads:
    """The expensive heads of the techniques, computed once each in ``cache``.

    Parameters
    ----------
    cache : Cache
    source : Motion, the session's source ("self" warp reference; segments are cut from it)
    extract_options : dict, keyword arguments of ``staggered.extract`` (already checked)
    """

    def __init__(self, cache: Cache, source: Motion, extract_options: dict):
        self.cache = cache
        self.source = source
        self.extract_options = dict(extract_options)
        self.memory_references: dict[str, Motion] = {}  # Session.use_reference: never evicted
        cache.name(source, "source")

    def key(self, obj) -> str:
        return self.cache.token(obj)

    def extract(self, motion: Motion, progress: Callable | None = None):
        """``staggered.extract(motion, **extract_options)``, once per motion (``progress(fraction)`` is passed
        to the computation when this call computes it)."""
        def make():
            try:
                return _staggered().extract(motion, progress=progress, **self.extract_options)
            except (TypeError, ArithmeticError) as e:  # the options are checked already: a bad value
                raise ValueError(f"extract_options: {type(e).__name__}: {e}") from None
        return self.cache.get("extract", self.key(motion), None, make)

    def cull(self, sm, percent: float | None = None, count: int | None = None, progress: Callable | None = None):
        """``staggered.cull(sm, percent)`` or ``cull(sm, count=count)`` (a refit of the splines, the slow step
        of the cull slider), once per (representation, kept poses): the entry is keyed by
        ``staggered.cull_keep`` (cheap), so every percent or count keeping the same poses shares one refit."""
        st = _staggered()
        count = None if count is None else int(count)
        percent = None if count is not None or percent is None else float(percent)
        keep = tuple(int(k) for k in st.cull_keep(sm, percent, count=count))
        return self.cache.get("cull", self.key(sm), ("keep", keep),
                              lambda: st.cull(sm, percent, count=count, progress=progress))

    def offset_basis(self, sm, origin: Motion | None = None):
        """``staggered.pose_offset_basis(sm, origin)``: the offset-independent half of an exaggeration of ``sm``
        (§5.1), once per pre-exaggerate state (keyed by its content name): a ``w_r`` slider move reuses it.
        ``origin``: the Motion ``sm`` was extracted from (it reads the rotations on frames from it while
        ``sm`` reproduces it; a ``pose_offset_basis`` without that parameter, an older one or a wrapper, is
        called with ``sm`` alone). None when this version of staggered has no such function."""
        make = getattr(_staggered(), "pose_offset_basis", None)
        if make is None:
            return None
        try:
            takes = origin is not None and "reproduced" in inspect.signature(make).parameters
        except (TypeError, ValueError):
            takes = False
        return self.cache.get("offset_basis", self.key(sm), None,
                              lambda: make(sm, reproduced=origin) if takes else make(sm))

    def positions(self, motion: Motion):
        """World joint positions ``(F, J, 3)`` of ``motion`` (``forward_kinematics(motion)[0]``, read-only),
        once per motion: ``keep_contacts`` reads the source's on every replay."""
        def make():
            p = forward_kinematics(motion)[0]
            p.setflags(write=False)
            return p
        return self.cache.get("positions", self.key(motion), None, make)

    def wand_graph(self, motion: Motion):
        """The sigma-independent pose graph of ``motion`` (Dean et al. 2018, §3.1), once per motion."""
        return self.cache.get("graph", self.key(motion), None, lambda: _wand().pose_graph(motion))

    def wand_basis(self, motion: Motion, sigma: float | None):
        """The Green's eigenbasis of ``motion`` for ``sigma`` (§3.2), once per (motion, sigma); the graph is
        shared by every sigma."""
        sigma = None if sigma is None else float(sigma)
        return self.cache.get("basis", self.key(motion), sigma,
                              lambda: self.wand_graph(motion).basis(sigma))

    def isomap_graph(self, motion: Motion):
        """The ISOMAP comparison's kNN graph of ``motion`` (Dean et al. 2018, §4, Fig. 3), once per motion: each
        edited frame's curve is then one Dijkstra (~1 ms on 2,751 frames instead of ~0.1 s)."""
        return self.cache.get("compare", self.key(motion), "isomap", lambda: _wand().isomap_graph(motion))

    def diffusion(self, motion: Motion, sigma: float | None):
        """The diffusion-map comparison's coordinates of ``motion`` for ``sigma`` (§4, Fig. 3), once per (motion,
        sigma): the dense eigendecomposition (seconds on 2,751 frames) is frame-independent, each edited frame's
        curve is one norm. The coordinates whose weight ``mu^steps`` is below :data:`DIFFUSION_TOL` are left out
        (distances within that fraction; 373 of 2,751 kept on CMU 01_01). Refused (ValueError) past
        :data:`DIFFUSION_MAX_FRAMES` frames: the kernel is a dense F x F matrix."""
        if motion.num_frames > DIFFUSION_MAX_FRAMES:
            raise ValueError(f"compare: the diffusion comparison builds a dense {motion.num_frames:,} x "
                             f"{motion.num_frames:,} kernel (about {8 * motion.num_frames ** 2 / 2**30:.1f} GiB); it "
                             f"takes clips of up to {DIFFUSION_MAX_FRAMES:,} frames: slice the clip to compare")
        sg = None if sigma is None else float(sigma)
        return self.cache.get("compare", self.key(motion), ("diffusion", sg),
                              lambda: _wand().diffusion_coordinates(motion, sigma=sg, tol=DIFFUSION_TOL))

    def falloff(self, motion: Motion, frame: int, sigma: float | None, frame_range=None):
        """The magic wand's falloff ``(F,)`` of ``motion`` around ``frame`` (Dean et al. 2018, §3.3), from the
        cached basis of ``sigma``, once per (motion, frame, sigma, frame range): a slider that replays a
        propagated pose edit or a timing region reads it, it does not recompute it."""
        sigma = None if sigma is None else float(sigma)
        fr = None if frame_range is None else (int(frame_range[0]), int(frame_range[1]))

        def make():
            w = _wand().greens_falloff(self.wand_basis(motion, sigma), int(frame), fr)
            w.setflags(write=False)
            return w
        return self.cache.get("falloff", self.key(motion), (int(frame), sigma, fr), make)

    def reference(self, ref) -> Motion:
        """The warp reference ``ref`` (``"self"``, ``("segment", a, b)`` or ``("path", p)``) as a Motion."""
        if ref == "self":
            return self.source
        if ref[0] == "path" and ref[1] in self.memory_references:
            return self.memory_references[ref[1]]
        return self.cache.get("reference", ref, None, lambda: self._load_reference(ref))

    def _load_reference(self, ref) -> Motion:
        if ref[0] == "segment":
            a, b = ref[1:]
            src = self.source
            start = max(0, int(round(a / src.frame_time)))
            stop = min(src.num_frames, int(round(b / src.frame_time)) + 1)
            if stop - start < 3:
                raise ValueError(f"reference.segment: [{a}, {b}] s holds fewer than 3 frames")
            return src.slice(start, stop)
        try:
            return read_bvh(ref[1])  # a regular file within the size limit (io._common.read_regular_file)
        except ValueError as e:
            raise ValueError(f"reference.path: {e}") from None

    def warp_tables(self, motion: Motion, ref, skip: int, upsample: int, reverse: bool = False, k: int = 3,
                    progress: Callable | None = None, out_step: int = 1):
        """Guided time warping's features and kNN score tables (Hsu et al. 2007, §3.2), once per (input,
        reference, skip, upsampling, direction, kNN count, output step); not per duration: a duration change
        re-runs only the DP. A finished exact table of a larger skip (e.g. the slider's largest, warmed by
        ``Session.warm``) serves a smaller skip by slicing (:func:`~stagger_nb.timewarp.slice_tables`, the same
        numbers), uncached."""
        reference = self.reference(ref)  # keyed by the resolved clip: a re-registered in-memory name is new
        owner, rkey, skip = self.key(motion), self.key(reference), int(skip)
        rest = _tables_rest(upsample, reverse, k, out_step)
        own = self.cache.peek("warp", owner, (rkey, skip) + rest)
        if own is not None:
            self.cache.touch("warp", [(owner, (rkey, skip) + rest)])
            return own
        for s in range(MAX_SKIP, skip, -1):   # the largest skip a guided_warp op allows
            big = self.cache.peek("warp", owner, (rkey, s) + rest)
            if big is not None and big.knn == "exact":
                self.cache.touch("warp", [(owner, (rkey, s) + rest)])
                return _timewarp().slice_tables(big, skip)
        return self.cache.get("warp", owner, (rkey, skip) + rest,
                              lambda: _timewarp().prepare_warp(motion, reference, skip, int(upsample),
                                                               reverse=bool(reverse), k=int(k),
                                                               out_step=int(out_step), progress=progress))

    def warp_solution(self, motion: Motion, ref, skip: int, upsample: int, reverse: bool, k: int, out_step: int,
                      num_frames: int | None, keytimes=None, progress: Callable | None = None):
        """``(tables, solution)``: :meth:`warp_tables` and guided warping's search on them for ``num_frames``
        output frames through ``keytimes`` (Hsu et al. 2007, §3.3, ``timewarp.solve_warp`` with its default
        options, what ``guided_warp`` runs), the search cached per (tables, length, keytimes): a duration
        slider's step back, or the next step solved ahead (:meth:`solve_ahead`), runs only §3.4's tail.
        ``progress(fraction)``: the tables up to 0.9, the search after."""
        head = None if progress is None else (lambda f: progress(0.9 * f))    # the tables, then the search
        tail = None if progress is None else (lambda f: progress(0.9 + 0.1 * f))
        tables = self.warp_tables(motion, ref, skip, upsample, reverse, k, head, out_step=out_step)
        key = self._solution_key(ref, skip, upsample, reverse, k, out_step, num_frames, keytimes)
        sweep = self.cache.peek("warp_sweep", self.key(motion), _sweep_key(key))
        return tables, self.cache.get("warp_solution", self.key(motion), key,
                                      lambda: _timewarp().solve_warp(tables, num_frames, keytimes, progress=tail,
                                                                     sweep=sweep))

    def solve_ahead(self, motion: Motion, ref, skip: int, upsample: int, reverse: bool, k: int, out_step: int,
                    num_frames: int | None, keytimes=None, stop: Callable | None = None) -> bool:
        """:meth:`warp_solution`'s search computed in the background (the next step of a duration slider): from
        tables already cached only (False when they are not, or the search is cached already); ``stop()`` is
        asked between chunks of the search and True raises :class:`~.replay.Stopped`, the partial work thrown
        away (nothing is cached until the search has finished; a foreground replay asking meanwhile runs its
        own). A refused search (ValueError) is not cached either: the user's replay reports it."""
        owner = self.key(motion)
        key = self._solution_key(ref, skip, upsample, reverse, k, out_step, num_frames, keytimes)
        if self.cache.peek("warp_solution", owner, key) is not None or not self._has_tables(
                motion, ref, skip, upsample, reverse, k, out_step):
            return False
        tables = self.warp_tables(motion, ref, skip, upsample, reverse, k, out_step=out_step)
        check = _stopper(stop)
        check(0.0)
        sweep = self.cache.peek("warp_sweep", owner, _sweep_key(key))
        try:
            sol = _timewarp().solve_warp(tables, num_frames, keytimes, progress=check, sweep=sweep)
        except ValueError:
            return False
        self.cache.put("warp_solution", owner, key, sol)
        return True

    def sweep_ahead(self, motion: Motion, ref, skip: int, upsample: int, reverse: bool, k: int, out_step: int,
                    num_frames: int, keytimes=None, stop: Callable | None = None) -> bool:
        """In the background: the search of every length within :data:`SWEEP_FRAMES` of ``num_frames`` at once
        (``timewarp.length_sweep``, Hsu et al. 2007 §3.3's exact DP in one pass; the same frames as each
        search alone), so that :meth:`warp_solution` of any of them is a backtrack. Only from cached tables,
        only where the search is the exact DP (not coarse-to-fine) and only when the cached sweep of these
        tables does not reach :data:`SWEEP_MARGIN` frames either side of ``num_frames`` already (one sweep per
        tables and keytimes, bounded in the cache by count and bytes). ``stop()`` as :meth:`solve_ahead`'s.
        True when a sweep was built."""
        from ..timewarp.solve import AUTO_COARSE_FRAMES
        if num_frames is None or out_step != 1 or not self._has_tables(motion, ref, skip, upsample, reverse, k,
                                                                      out_step):
            return False
        owner = self.key(motion)
        key = self._solution_key(ref, skip, upsample, reverse, k, out_step, None, keytimes)
        skey = _sweep_key(key)
        old = self.cache.peek("warp_sweep", owner, skey)
        n = int(num_frames)
        if old is not None and old.m_lo <= n - SWEEP_MARGIN and n + SWEEP_MARGIN <= old.m_hi:
            return False
        tables = self.warp_tables(motion, ref, skip, upsample, reverse, k, out_step=out_step)
        if tables.n_up > AUTO_COARSE_FRAMES:
            return False
        check = _stopper(stop)
        check(0.0)
        shortest = -(-(tables.n_up - 1) // tables.skip) + 1
        lo, hi = max(3, shortest, n - SWEEP_FRAMES), min(tables.n_up, n + SWEEP_FRAMES)
        if lo > hi:
            return False
        try:
            sweep = _timewarp().length_sweep(tables, lo, hi, keytimes, progress=check)
        except ValueError:
            return False   # a length or keytime the search refuses, too large a sweep, no C kernel
        self.cache.put("warp_sweep", owner, skey, sweep)
        return True

    def _has_tables(self, motion: Motion, ref, skip: int, upsample: int, reverse: bool, k: int,
                    out_step: int) -> bool:
        """Whether :meth:`warp_tables` would find its tables cached (or slice them from a larger skip's)."""
        owner, rkey = self.key(motion), self.key(self.reference(ref))
        rest = _tables_rest(upsample, reverse, k, out_step)
        for s in range(MAX_SKIP, int(skip) - 1, -1):
            t = self.cache.peek("warp", owner, (rkey, s) + rest)
            if t is not None and (s == int(skip) or t.knn == "exact"):
                return True
        return False

    def _solution_key(self, ref, skip, upsample, reverse, k, out_step, num_frames, keytimes) -> tuple:
        pairs = None if keytimes is None else tuple((float(a), float(b)) for a, b in keytimes)
        return (self.key(self.reference(ref)), int(skip), int(upsample), bool(reverse), int(k), int(out_step),
                None if num_frames is None else int(num_frames), pairs)


def _tables_rest(upsample, reverse, k, out_step) -> tuple:
    """The part of a warp table's cache key after (reference, skip): upsampling, direction, a kNN count other
    than 3 and an output step other than 1 (the defaults left out, as the keys were first written)."""
    return (int(upsample), bool(reverse)) + (() if k == 3 else (int(k),)) + \
        (() if out_step == 1 else (("step", int(out_step)),))


def _sweep_key(solution_key: tuple) -> tuple:
    """A length sweep's cache key: :meth:`Heads._solution_key` without the length (one sweep serves them all)."""
    return solution_key[:-2] + solution_key[-1:]


def _stopper(stop: Callable | None) -> Callable:
    """A search's progress callback that raises :class:`~.replay.Stopped` (the partial work thrown away) once
    ``stop()`` is True; ``stop`` None: never."""
    from .replay import Stopped

    def check(_fraction) -> None:
        if stop is not None and stop():
            raise Stopped(0)
    return check
