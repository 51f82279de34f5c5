"""The quality report of a session's current edit: :meth:`Session.quality <stagger_nb.session.Session.quality>`.

``sn.quality.compare(source, edited, staggered=, baseline=, prepared=)`` with what the replay already holds
(Coleman et al. 2008, §3 and §5.2: a timing edit should keep the contacts and the detail):

- ``prepared``: :func:`stagger_nb.quality.prepare` of the source, once per session (cache kind
  ``"quality_source"``; it reads the source's FK from the ``"positions"`` entry ``keep_contacts`` uses);
- ``staggered``: the last staggered state of the replay (its time warps carry the source's contacts, its knots
  are checked for order) when the edited motion keeps its timeline, i.e. when the staggered ops start from the
  source (extracted from it, not from a warped motion) and every op after the last staggered state is
  ``keep_contacts``, ``edit_frame`` or ``propagate``; otherwise None (the contacts stay on their frames);
- ``baseline``: with a ``keep_contacts`` op, the same op list without it (the replay's state before that op
  when it is the last one): what the contact layer itself changed.

The report is cached per op list (cache kind ``"quality"``, keyed by the digest of the whole op prefix chain,
the replay's own content key): asking again for the same edit, after an undo or from another view, computes
nothing. ``bounds`` only changes the verdict (:meth:`QualityReport.with_bounds`), not the figures.
"""
from __future__ import annotations

from .. import quality as Q
from ..core.motion import Motion
from . import ops as O
from .replay import chain_keys
from .runners import convert

__all__ = ["session_quality", "TIMELINE_KEEPING"]

#: Motion ops after the last staggered state that keep the edited motion's frames and times (the staggered
#: state's time warps still carry the contacts onto it).
TIMELINE_KEEPING = (O.KeepContacts, O.EditFrame, O.Propagate)


def source_figures(session) -> Q.SourceFigures:
    """:func:`stagger_nb.quality.prepare` of the session's source, cached (once per session)."""
    heads, src = session._ctx, session.source
    return heads.cache.get("quality_source", heads.key(src), None,
                           lambda: Q.prepare(src, source_positions=heads.positions(src)))


def session_quality(session, bounds=None) -> Q.QualityReport:
    """The report of ``session``'s current edit against its source (see the module docstring)."""
    ops = session.typed_ops
    prep = source_figures(session)
    if not ops:
        return Q.compare(session.source, session.source, prepared=prep, bounds=bounds)
    replay, cache = session._replay, session._ctx.cache
    with session._worker.foreground(), replay.lock:    # the warm-up gives way (session/warm.py)
        edited = replay.edited(ops)                    # ValueError naming the op that failed
        keys = replay.prefix_keys(ops)

        def make():
            return _report(session, ops, keys, edited, prep)
        report = cache.get("quality", keys[-1], None, make)
    return report if bounds is None else report.with_bounds(bounds)


def _report(session, ops, keys, edited, prep) -> Q.QualityReport:
    replay, cache = session._replay, session._ctx.cache
    staggered = [replay._info[k].staggered for k in keys]
    last = max((i for i, s in enumerate(staggered) if s), default=None)
    sm = None
    if (last is not None and all(staggered[:last + 1])
            and all(isinstance(op, TIMELINE_KEEPING) for op in ops[last + 1:])):
        sm = replay.run(ops, keys, last + 1)
    baseline = None
    if any(isinstance(op, O.KeepContacts) for op in ops):
        rest = tuple(op for op in ops if not isinstance(op, O.KeepContacts))
        if not rest:
            baseline = session.source
        else:   # the prefix's states are in the cache under the same chained digests: usually one evaluation
            state = replay.run(rest, chain_keys(rest), len(rest))
            baseline = state if isinstance(state, Motion) else cache.get(
                "state", cache.token(state), "motion", lambda: convert(state, "motion", None))
    return Q.compare(session.source, edited, staggered=sm, baseline=baseline, prepared=prep)
