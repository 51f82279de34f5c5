"""Small array helpers shared by the frozen dataclasses."""
from __future__ import annotations

import numpy as np


def readonly(a, dtype=float) -> np.ndarray:
    """A read-only copy of ``a`` as ``dtype`` (frozen dataclasses hand these out)."""
    a = np.array(a, dtype=dtype)
    a.setflags(write=False)
    return a
