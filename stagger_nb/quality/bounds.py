"""The bounds a :class:`~stagger_nb.quality.QualityReport` is checked against: :class:`Bounds`, the named
:data:`PRESETS`, and how a ``bounds=`` argument is read."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..core.checks import finite_number as _number


def _positive(x, name: str) -> float:
    x = _number(x, name)
    if x <= 0:
        raise ValueError(f"{name} must be > 0, got {x}")
    return x


@dataclass(frozen=True)
class Bounds:
    """Largest allowed figures of a :class:`QualityReport` (``None``: not checked).

    Attributes: ``travel``, ``height``, ``floor``, ``pelvis``, ``moved`` (cm of a 170 cm body), ``pop``
    (degrees), ``knots`` (joints whose knots are out of order), ``detail`` ((low, high) ratio) and
    ``no_worse_than_baseline`` (the held feet travel no more than in the ``baseline``, when one is given).
    ``pelvis`` is checked against ``pelvis_vs_baseline`` when a baseline is given (the layer's own change),
    else against ``pelvis`` (vs the source).
    """

    travel: float | None = 1.0
    height: float | None = 1.5
    floor: float | None = 1.5
    pelvis: float | None = 3.0
    pop: float | None = 5.0
    moved: float | None = None
    knots: int | None = 0
    detail: tuple | None = (0.5, 2.0)
    no_worse_than_baseline: bool = False

    def __post_init__(self):
        for name in ("travel", "height", "floor", "pelvis", "pop", "moved"):
            v = getattr(self, name)
            if v is not None:
                v = _number(v, f"bounds.{name}")
                if v < 0:
                    raise ValueError(f"bounds.{name} must be >= 0 or None, got {v}")
                object.__setattr__(self, name, v)
        if self.knots is not None:
            if isinstance(self.knots, bool) or not isinstance(self.knots, (int, np.integer)) or self.knots < 0:
                raise ValueError(f"bounds.knots must be a non-negative int or None, got {self.knots!r}")
            object.__setattr__(self, "knots", int(self.knots))
        if self.detail is not None:
            try:
                lo, hi = (float(x) for x in self.detail)
            except (TypeError, ValueError):
                raise ValueError(f"bounds.detail must be (low, high) or None, got {self.detail!r}") from None
            if not (0 <= lo <= hi) or not math.isfinite(hi):
                raise ValueError(f"bounds.detail must satisfy 0 <= low <= high < inf, got {self.detail!r}")
            object.__setattr__(self, "detail", (lo, hi))
        object.__setattr__(self, "no_worse_than_baseline", bool(self.no_worse_than_baseline))

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["detail"] = None if self.detail is None else list(self.detail)
        return d


#: Named bounds: the goals of issue "Edits an animator would keep" (cm of a 170 cm body, degrees).
#: ``unedited``: the contact layer on an unedited extraction moves no joint more than 2 cm.
PRESETS = {
    "unedited": Bounds(travel=1.0, height=1.5, floor=1.5, pelvis=2.0, pop=5.0, moved=2.0),
    "mild": Bounds(travel=1.0, height=1.5, floor=1.5, pelvis=3.0, pop=5.0),
    "moderate": Bounds(travel=2.0, height=2.0, floor=2.0, pelvis=5.0, pop=5.0),
    "strong": Bounds(travel=2.0, height=3.0, floor=3.0, pelvis=8.0, pop=10.0, no_worse_than_baseline=True),
}


def _bounds(bounds) -> Bounds:
    if bounds is None:
        return PRESETS["mild"]
    if isinstance(bounds, Bounds):
        return bounds
    if isinstance(bounds, str):
        if bounds not in PRESETS:
            raise ValueError(f"bounds: unknown preset {bounds!r}; presets are {', '.join(PRESETS)}")
        return PRESETS[bounds]
    if isinstance(bounds, dict):
        names = {f.name for f in dataclasses.fields(Bounds)}
        bad = sorted(set(bounds) - names - {"preset"})
        if bad:
            raise ValueError(f"bounds: unknown field(s) {', '.join(map(repr, bad))}; "
                             f"fields are {', '.join(sorted(names))}")
        base = _bounds(bounds.get("preset"))
        return dataclasses.replace(base, **{k: v for k, v in bounds.items() if k != "preset"})
    raise ValueError(f"bounds must be a preset name ({', '.join(PRESETS)}), a Bounds, a dict or None, "
                     f"got {type(bounds).__name__}")
