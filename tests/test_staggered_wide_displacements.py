"""Displacements that turn more than pi (long merged segments under exaggeration and timing edits) are
interpolated between their samples on the quaternions, not on the rotation vectors (``evaluation._wide_pairs``):
near a full turn two neighbouring samples close as rotations can be far apart as vectors, and the vector half-way
between them is a large rotation: a one-frame pop. Found in a browser review (cull 95 %, s 0.05, τ 0.05,
w_r 0.5 on CMU 01_01: "right arm pops 149°")."""
from __future__ import annotations

import numpy as np

import stagger_nb as sn
from stagger_nb import data, staggered
from stagger_nb.session import Session


def _largest_step_deg(q: np.ndarray) -> float:
    d = np.abs(np.sum(q[1:] * q[:-1], axis=-1)).clip(0.0, 1.0)
    return float(np.degrees(2.0 * np.arccos(d)).max())


def test_an_exaggerated_timed_cull_of_the_walk_has_no_pop_from_its_wide_displacements():
    m = data.load("walk")
    culled = staggered.cull(staggered.extract(m), 50.0)
    ex = staggered.exaggerate(culled, list(range(culled.num_poses)), 0.8)
    timed = staggered.random_timing(staggered.succession(ex, root=m.skeleton.names[0], s=0.03, l=1.5),
                                    tau=0.06, seed=3)
    assert (np.linalg.norm(timed.displacements, axis=-1) > np.pi).any()       # the case is reached
    # linear rotation-vector interpolation gave a 175.7 degree step (LeftArm, frame 132); the source's is 13.8
    assert _largest_step_deg(staggered.evaluate(timed).local_quats) <= _largest_step_deg(m.local_quats) + 5.0


def test_exaggeration_then_timing_on_cmu_01_01_adds_no_149_degree_pop():
    m = data.load("cmu_01_01")
    ops = [{"op": "cull", "percent": 95.0}, {"op": "exaggerate", "w_r": 0.5},
           {"op": "succession", "root": "Hips", "s": 0.05, "l": 1.0}, {"op": "random_timing", "tau": 0.05, "seed": 0}]
    e = Session(m, ops=ops).edited()
    r = sn.quality.compare(m, e)
    assert r.added_pop <= 5.0, r.summary          # was 149 (RightArm / LeftForeArm, one frame)
