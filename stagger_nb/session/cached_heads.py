"""The part of :class:`~stagger_nb.session.Session` that offers the heads (:mod:`.heads`) to callers and to the
editors' views: ``precompute_cull``, ``precompute_wand_bases``, ``use_reference``, ``wand_basis``, ``positions``,
``wand_graph``, ``falloff_curves``, ``falloff_ready``, ``pose_falloff``.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.motion import Motion
from .heads import _percent, _sigma
from .ops.fields import text
from .run import Run

__all__ = ["CachedHeads"]


class CachedHeads:
    """The cached heads of a :class:`~stagger_nb.session.Session` (a mixin over the session's ``source``, its
    :class:`~.heads.Heads` ``_ctx``, its replay and op history)."""

    def precompute_cull(self, percents, stop: Callable | None = None) -> int:
        """Compute and cache ``cull`` of the source's extraction for each of ``percents`` in this thread;
        stops early when ``stop()`` is true. Returns how many were computed or already cached.
        (Prefer :meth:`warm`, which runs on the session's executor.)"""
        n = 0
        sm = self.extraction()
        for pc in percents:
            if stop is not None and stop():
                break
            self._ctx.cull(sm, _percent(pc, "percents[]"))
            n += 1
        return n

    def precompute_wand_bases(self, sigmas, stop: Callable | None = None, motion: Motion | None = None) -> int:
        """Compute and cache the magic-wand eigenbasis for each of ``sigmas`` in this thread; stops early when
        ``stop()`` is true. Returns how many. (Prefer :meth:`warm`.)"""
        n = 0
        for sg in sigmas:
            if stop is not None and stop():
                break
            self.wand_basis(_sigma(sg, "sigmas[]"), motion)
            n += 1
        return n

    def use_reference(self, path: str, motion: Motion) -> dict:
        """Resolve the op reference ``{"path": path}`` to ``motion`` in this session (e.g. an in-memory clip
        under a name like ``"<memory:name>"``) instead of reading the file; returns that reference.
        A saved session keeps only the path: a new process reads the file."""
        if not isinstance(motion, Motion):
            raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
        self._ctx.memory_references[text(path, "path")] = motion
        return {"path": path}

    def wand_basis(self, sigma: float | None = None, motion: Motion | None = None):
        """The (cached) magic-wand eigenbasis of ``motion`` (default: the source) for ``sigma``."""
        return self._ctx.wand_basis(self.source if motion is None else motion, sigma)

    def positions(self, motion: Motion | None = None) -> np.ndarray:
        """World joint positions ``(F, J, 3)`` of ``motion`` (default: the source), ``forward_kinematics``
        computed once per motion and kept in the session's cache (read-only)."""
        return self._ctx.positions(self.source if motion is None else motion)

    def wand_graph(self, motion: Motion | None = None):
        """The (cached) sigma-independent pose graph of ``motion`` (default: the source)."""
        return self._ctx.wand_graph(self.source if motion is None else motion)

    def falloff_curves(self, frame: int, sigma: float | None = None, frame_range=None, compare=(),
                       spline_extent: float | None = None, motion: Motion | None = None,
                       repetitions: bool = True) -> dict:
        """Falloff weights around ``frame`` (1 there, 0 far away), each (F,), for the views.

        ``"green"``: the magic wand's Green's-function falloff (Dean et al. 2018, §3.3) with the cached
        basis (``repetitions`` False: only the valley around ``frame``, as a propagate op with repetitions
        "discard" weighs it); ``compare`` may add ``"isomap"`` and ``"diffusion"`` (``1 - normalised distance``, Fig. 3)
        and ``"spline"`` (a generic smoothstep falloff of ``spline_extent`` frames, Fig. 6). Their
        frame-independent heads (ISOMAP's graph, the diffusion coordinates per sigma) are cached: a new frame
        costs a Dijkstra or a norm; :meth:`falloff_ready` says which are computed, :meth:`warm` fills them.
        """
        from .. import wand
        m = self.source if motion is None else motion
        fr = None if frame_range is None else tuple(frame_range)
        f = int(frame)
        out = {"green": wand.greens_falloff(self._ctx.wand_basis(m, sigma), f, fr, repetitions=bool(repetitions))}
        sg = None if sigma is None else float(sigma)
        for name in compare:
            if name == "isomap":
                g = self._ctx.isomap_graph(m)
                make = lambda g=g: 1.0 - wand.normalize_distance(wand.isomap_distance(m, f, graph=g), fr)  # noqa: E731
            elif name == "diffusion":
                c = self._ctx.diffusion(m, sg)
                make = lambda c=c: 1.0 - wand.normalize_distance(np.linalg.norm(c - c[f], axis=1), fr)  # noqa: E731
            elif name == "spline":
                extent = spline_extent or max(2.0, m.num_frames / 10)
                make = lambda extent=extent: wand.spline_falloff(m.num_frames, f, extent)  # noqa: E731
            else:
                raise ValueError(f"compare: unknown curve {name!r}; use 'isomap', 'diffusion', 'spline'")
            key = (name, f, sg, fr, spline_extent if name == "spline" else None)
            out[name] = self._ctx.cache.get("curve", self._ctx.key(m), key, make)
        return out

    def falloff_ready(self, sigma: float | None = None, compare=(), motion: Motion | None = None) -> list:
        """The curves among ``"green"`` and ``compare`` that :meth:`falloff_curves` can draw for ``sigma`` without
        a long computation (their heads are cached: the basis for ``sigma``, ISOMAP's graph, the diffusion
        coordinates for ``sigma``; a spline always), in the order given. An editor draws these at once and
        warms the others (``warm(("wand_basis", [sigma]), ("compare", [(name, sigma)]))``)."""
        m = self.source if motion is None else motion
        cache, owner = self._ctx.cache, self._ctx.key(m)
        sg = None if sigma is None else float(sigma)
        heads = {"green": ("basis", sg), "isomap": ("compare", "isomap"), "diffusion": ("compare", ("diffusion", sg))}
        return [n for n in ["green", *compare] if n not in heads or cache.peek(heads[n][0], owner, heads[n][1])
                is not None]

    def pose_falloff(self, frame: int, sigma: float | None = None, frame_range=None):
        """The magic wand's falloff around source ``frame`` (Dean et al. 2018, §3.3; the cached basis of ``sigma``)
        read at every pose of :meth:`staggered` at its source time, shape (K,): the weight a timing edit with
        ``"falloff": {"frame": frame, "sigma": sigma}`` gives each pose's offsets (a region of the clip), and the
        share a propagated pose edit at that frame's pose gives it. ``frame`` indexes the motion the poses were
        extracted from (the source, unless a motion op comes first)."""
        from .runners import falloff_at_poses  # late: the runners import this module
        sm = self.staggered()
        fr = None if frame_range is None else tuple(int(x) for x in frame_range)
        run = Run(self._ctx, self._replay.origin(self._history.ops))
        return falloff_at_poses(sm, run, int(frame), None if sigma is None else float(sigma), fr, "")
