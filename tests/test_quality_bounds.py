"""stagger_nb.quality.bounds: Bounds checks each field once, and a ``bounds=`` argument reads a preset, a Bounds
or a dict (a preset with fields overridden)."""
from __future__ import annotations

import dataclasses

import pytest
from quality_figures import FEET, standing

from stagger_nb import quality


@pytest.mark.parametrize("kwargs,message", [
    ({"travel": -0.5}, r"bounds.travel must be >= 0 or None"),
    ({"floor": "x"}, r"bounds.floor must be a number"),
    ({"moved": float("inf")}, r"bounds.moved must be finite"),
    ({"knots": True}, r"bounds.knots must be a non-negative int or None"),
    ({"knots": -1}, r"bounds.knots must be a non-negative int or None"),
    ({"detail": (2.0, 1.0)}, r"bounds.detail must satisfy 0 <= low <= high < inf"),
    ({"detail": "wide"}, r"bounds.detail must be \(low, high\) or None"),
])
def test_a_bad_bound_names_its_field(kwargs, message):
    with pytest.raises(ValueError, match=message):
        quality.Bounds(**kwargs)


def test_bounds_are_normalised_and_round_trip_through_a_dict():
    b = quality.Bounds(travel=2, knots=3, detail=[0.25, 4], no_worse_than_baseline=1)
    assert b.travel == 2.0 and isinstance(b.travel, float) and b.knots == 3
    assert b.detail == (0.25, 4.0) and b.no_worse_than_baseline is True
    d = b.to_dict()
    assert d["detail"] == [0.25, 4.0]
    assert quality.Bounds(**d) == b


def test_a_dict_overrides_its_preset_and_the_report_reads_the_result():
    m = standing()
    r = quality.compare(m, m, contacts=FEET, bounds={"preset": "strong", "travel": 0.5})
    want = dataclasses.replace(quality.PRESETS["strong"], travel=0.5)
    assert r.bounds == want
    assert quality.compare(m, m, contacts=FEET).bounds == quality.PRESETS["mild"]      # the default
    assert r.with_bounds("unedited").bounds == quality.PRESETS["unedited"]
    with pytest.raises(ValueError, match=r"bounds must be a preset name .* got int"):
        quality.compare(m, m, bounds=3)
