"""Argument checks shared by the layers: a bad value is a ``ValueError`` naming the parameter."""
from __future__ import annotations

import math

__all__ = ["finite_number"]


def finite_number(x, name: str) -> float:
    """``float(x)``, or a ``ValueError`` naming ``name``: "must be a number" (not convertible) or "must be
    finite" (nan, inf)."""
    try:
        x = float(x)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {x!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return x
