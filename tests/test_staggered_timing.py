"""Limits of the timing edits (stagger_nb/staggered/timing.py): declared once, in core.limits."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, staggered
from stagger_nb.core.limits import MAX_TAU
from stagger_nb.session import ops as O


@pytest.fixture
def sm():
    return staggered.cull(staggered.extract(data.load("walk")), 50)


def test_random_timing_accepts_max_tau_and_refuses_beyond(sm):
    out = staggered.random_timing(sm, tau=MAX_TAU, seed=1)
    assert np.any(out.refinements != sm.refinements)
    with pytest.raises(ValueError, match="tau"):
        staggered.random_timing(sm, tau=np.nextafter(MAX_TAU, np.inf))
    with pytest.raises(ValueError, match="tau"):
        staggered.random_timing(sm, tau=-1e-12)


def test_the_op_reads_the_same_bound():
    """The random_timing op and the function share one bound: the op accepts MAX_TAU and refuses more."""
    assert O.Op.from_json({"op": "random_timing", "tau": MAX_TAU}).tau == MAX_TAU
    with pytest.raises(ValueError, match="tau"):
        O.Op.from_json({"op": "random_timing", "tau": float(np.nextafter(MAX_TAU, np.inf))})
