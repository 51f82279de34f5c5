"""Deprecated session names, kept for old code: :func:`register_op` and ``Session.REQUIRED``.

New ops are an :class:`~.ops.Op` subclass (a frozen dataclass whose fields carry their checks) plus a runner in
``runners.RUNNERS``; CONTRIBUTING.md ("How to add an op") walks through one.
"""
from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from typing import Any

from .ops import Op
from .runners import RUNNERS

__all__ = ["register_op", "REQUIRED"]

REQUIRED = dataclasses.MISSING
"""Marks a required field in :func:`register_op`'s ``fields`` (also ``Session.REQUIRED``)."""


def register_op(name: str, needs: str, fields: dict, run: Callable) -> type:
    """Deprecated: define an :class:`~.ops.Op` subclass and add its runner to ``runners.RUNNERS``.

    Kept for old code: builds that subclass from ``fields`` (``{field: (check(value, field) or None,
    default)}``, ``Session.REQUIRED`` for a required field) and registers ``run(state, params: dict, run)``,
    which now receives the op's JSON dict and a :class:`~.runners.Run` (``run.heads`` has the cached heads)."""
    warnings.warn("register_op is deprecated: subclass stagger_nb.session.ops.Op and add the runner to "
                  "stagger_nb.session.runners.RUNNERS", DeprecationWarning, stacklevel=2)
    if needs not in ("staggered", "motion", "any"):
        raise ValueError(f"needs: expected 'staggered', 'motion' or 'any', got {needs!r}")
    order = sorted(fields.items(), key=lambda kv: kv[1][1] is not REQUIRED)  # required fields first
    spec = [(k, Any, dataclasses.field(default=d, metadata={"check": c}) if d is not REQUIRED
             else dataclasses.field(metadata={"check": c})) for k, (c, d) in order]
    cls = dataclasses.make_dataclass(f"_Registered_{name}", spec, bases=(Op,), frozen=True,
                                     namespace={"name": name, "needs": needs, "__annotations__": {}})
    RUNNERS[cls] = lambda state, op, r: run(state, op.to_json(), r)
    return cls
