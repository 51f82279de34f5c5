"""The one switch for the optional C extensions (``io/_cparse.c``, ``staggered/_cspline.c``, ``timewarp/_cdp.c``).

Each extension does the numpy path's operations in the same order, so results are bit-identical; setting the
environment variable ``STAGGER_NB_NO_ACCEL`` to anything but empty or ``0`` runs the numpy paths instead
(read at every call)."""
from __future__ import annotations

import os

__all__ = ["NO_ACCEL_ENV", "accel_allowed"]

NO_ACCEL_ENV = "STAGGER_NB_NO_ACCEL"


def accel_allowed() -> bool:
    """False when ``STAGGER_NB_NO_ACCEL`` asks for the numpy paths."""
    return os.environ.get(NO_ACCEL_ENV, "") in ("", "0")
