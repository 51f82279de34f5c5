"""session.ops: one frozen dataclass per op — JSON round trips, field checks naming the field, extract options."""
from __future__ import annotations

import dataclasses
import json
import re

import pytest

from stagger_nb.session import ops as O
from stagger_nb.session.ops import OPS, Op, check_extract_options, validate_op
from stagger_nb.session.runners import RUNNERS

D = {"LeftUpLeg": [10.0, -2.5, 0.0]}

# at least one JSON example per op; several where fields are alternatives
EXAMPLES = [
    {"op": "extract"},
    {"op": "cull", "percent": 40.0},
    {"op": "cull", "count": 5},
    {"op": "cull", "keep": [0, 3, 4, 9]},
    {"op": "succession", "root": "Hips", "s": 0.03, "l": 2.0, "joints": None, "limit": 1.5},
    {"op": "succession", "root": "Hips", "s": -0.01, "l": 1.0, "joints": ["LeftUpLeg", "LeftLeg"], "limit": None},
    {"op": "random_timing", "tau": 0.05, "seed": 7, "joints": ["Hips"], "limit": 2.0},
    {"op": "exaggerate", "w_r": 0.5, "poses": None, "reference": "mean", "mode": "staggered", "joints": None},
    {"op": "exaggerate", "w_r": -0.3, "poses": [1, 2], "reference": 4, "mode": "unstaggered", "joints": ["Hips"]},
    {"op": "edit_pose", "pose": 2, "deltas": D, "mode": "unstaggered"},
    {"op": "edit_pose", "pose": 2, "mode": "staggered", "targets": {"LeftUpLeg": [0.0, 0.0, 0.6, 0.8]}},
    {"op": "retime", "pose": 3, "time": 1.25},
    {"op": "refine", "pose": 2, "joint": "LeftFoot", "time": 1.23},
    {"op": "insert_pose", "time": 0.7},
    {"op": "delete_pose", "pose": 2},
    {"op": "keep_contacts"},
    {"op": "ik_pose", "pose": 1, "joint": "LeftHand", "target": [0.1, 1.2, -3.0]},
    {"op": "edit_frame", "frame": 3, "deltas": D},
    {"op": "propagate", "frame": 5, "deltas": D, "sigma": None, "frame_range": None, "repetitions": "keep"},
    {"op": "propagate", "frames": [5, 40], "deltas": [D, {"Hips": [0.0, 3.0, 0.0]}], "sigma": 0.4,
     "frame_range": [0, 60], "repetitions": "discard"},
    {"op": "guided_warp", "duration": 1.5, "skip": 8, "keytimes": [[0.5, 0.4]], "reference": "self",
     "backward": False, "free_length": False},
    {"op": "guided_warp", "free_length": True, "skip": 4, "keytimes": None, "reference": {"segment": [0.0, 1.0]},
     "backward": True},
    {"op": "guided_warp", "duration": 2.0, "skip": 8, "keytimes": None, "reference": {"path": "<memory:x>"},
     "backward": False, "free_length": False, "upsample": 3},
    {"op": "linear_warp", "duration": 0.8, "keytimes": [[0.2, 0.3]]},
    {"op": "resample", "frame_time": 1 / 30},
    # issue 24: pose edits propagated by the magic wand, timing edits in a region, pose times guided
    {"op": "edit_pose", "pose": 2, "deltas": D, "mode": "staggered", "propagate": True, "sigma": 0.4,
     "frame_range": [0, 60]},
    {"op": "exaggerate", "w_r": 0.5, "poses": [2, 5], "reference": "previous", "mode": "staggered", "joints": None,
     "propagate": True},
    {"op": "ik_pose", "pose": 1, "joint": "LeftHand", "target": [0.1, 1.2, -3.0], "propagate": True},
    {"op": "succession", "root": "Hips", "s": 0.03, "l": 2.0, "joints": None, "limit": 1.5,
     "falloff": {"frame": 30, "sigma": None}},
    {"op": "random_timing", "tau": 0.05, "seed": 7, "joints": None, "limit": None,
     "falloff": {"frame": 3, "sigma": 0.5, "frame_range": [0, 40]}},
    {"op": "guide_poses", "reference": {"path": "<memory:slow>"}, "keytimes": None, "skip": 8},
    {"op": "guide_poses", "reference": "self", "keytimes": [[1.0, 1.5]], "duration": 3.0, "skip": 4, "upsample": 3},
    {"op": "guide_poses", "reference": {"segment": [0.0, 1.0]}, "keytimes": None, "free_length": True, "skip": 8},
]


def test_every_op_has_an_example_and_a_runner():
    assert {e["op"] for e in EXAMPLES} == set(OPS)
    assert set(RUNNERS) == set(OPS.values())


@pytest.mark.parametrize("data", EXAMPLES, ids=[e["op"] for e in EXAMPLES])
def test_json_round_trip(data):
    op = Op.from_json(data)
    assert type(op) is OPS[data["op"]] and op.name == data["op"]
    j = op.to_json()
    assert j == data                              # the examples are written in normal form
    assert json.loads(json.dumps(j)) == j         # plain JSON
    assert Op.from_json(j) == op and hash(Op.from_json(j)) == hash(op)
    assert op.key == O.canonical(j)
    with pytest.raises(dataclasses.FrozenInstanceError):
        op.name_of_nothing = 1
    # the subclass's own from_json accepts its name only
    assert type(op).from_json(data) == op
    other = next(e for e in EXAMPLES if e["op"] != data["op"])
    with pytest.raises(ValueError, match=r"^op\.op"):
        type(op).from_json(other)


def test_defaults_are_filled_and_the_input_is_not_aliased():
    src = {"op": "random_timing", "tau": 0.05, "joints": ["A", "B"]}
    v = validate_op(src)
    assert v == {"op": "random_timing", "tau": 0.05, "seed": 0, "joints": ["A", "B"], "limit": O.TIMING_LIMIT}
    v["joints"].append("C")
    assert src["joints"] == ["A", "B"]


def test_timing_limit_is_checked_and_is_the_staggered_default():
    from stagger_nb import staggered
    assert O.TIMING_LIMIT == staggered.TIMING_LIMIT         # declared twice (ops import no technique): equal
    assert O.Succession(root="Hips", s=0.1).limit == staggered.TIMING_LIMIT
    assert O.Succession(root="Hips", s=0.1, limit=None).limit is None   # the paper's raw offsets
    for bad in (1.0, 0.5, -2, "x", float("inf")):
        with pytest.raises(ValueError, match=r"^limit: expected a number in \(1, 1000\]"):
            O.RandomTiming(tau=0.1, limit=bad)


def test_direct_construction_checks_fields_and_replace_keeps_them_checked():
    op = O.Succession(root="Hips", s=0.1)
    assert op.l == 1.0
    with pytest.raises(ValueError, match=r"^l: expected a number in \(0, 10\]"):
        O.Succession(root="Hips", s=0.1, l=0)
    assert dataclasses.replace(op, s=0.2).s == 0.2
    with pytest.raises(ValueError, match=r"^s:"):
        dataclasses.replace(op, s="x")
    ex = next(e for e in EXAMPLES if e["op"] == "propagate" and "frames" in e)
    p = Op.from_json(ex)
    assert dataclasses.replace(p, sigma=0.5) == Op.from_json(dict(ex, sigma=0.5))


HOSTILE = [
    ({"op": "nope"}, "op"),
    ({"op": 3}, "op"),
    ([], ""),
    ({"op": "cull"}, "percent"),
    ({"op": "cull", "percent": 10, "keep": [1]}, "keep"),
    ({"op": "cull", "percent": 10 ** 400}, "percent"),
    ({"op": "cull", "percent": 0}, "percent"),
    ({"op": "cull", "count": 1}, "count"),
    ({"op": "cull", "keep": [0, -1]}, r"keep\[1\]"),
    ({"op": "succession", "root": "Hips"}, "s"),
    ({"op": "succession", "root": "", "s": 0.1}, "root"),
    ({"op": "succession", "root": "Hips", "s": True}, "s"),
    ({"op": "succession", "root": "Hips", "s": float("nan")}, "s"),
    ({"op": "succession", "root": "Hips", "s": 0.1, "speed": 1}, "speed"),
    ({"op": "succession", "root": "Hips", "s": 0.1, "joints": "Hips"}, "joints"),
    ({"op": "succession", "root": "Hips", "s": 0.1, "joints": ["Hips", 3]}, r"joints\[1\]"),
    ({"op": "random_timing", "tau": 0.1, "seed": 1.5}, "seed"),
    ({"op": "random_timing", "tau": -0.1}, "tau"),
    ({"op": "exaggerate", "w_r": 1, "reference": "prev"}, "reference"),
    ({"op": "exaggerate", "w_r": 1, "reference": True}, "reference"),
    ({"op": "exaggerate", "w_r": 1, "mode": "both"}, "mode"),
    ({"op": "edit_pose", "pose": 1, "deltas": {"Hips": [1, 2]}}, "deltas.Hips"),
    ({"op": "edit_pose", "pose": 1, "deltas": [[1, 2, 3]]}, "deltas"),
    ({"op": "edit_pose", "pose": -1, "deltas": {}}, "pose"),
    ({"op": "edit_pose", "pose": 1}, "deltas"),
    ({"op": "edit_pose", "pose": 1, "deltas": {}, "targets": {}}, "targets"),
    ({"op": "edit_pose", "pose": 1, "targets": {"Hips": [0, 0, 0, 0]}}, "targets.Hips"),
    ({"op": "edit_pose", "pose": 1, "targets": {"Hips": [0, 0, 1]}}, "targets.Hips"),
    ({"op": "retime", "pose": 1, "time": "1"}, "time"),
    ({"op": "insert_pose"}, "time"),
    ({"op": "ik_pose", "pose": 1, "joint": "LeftHand", "target": [1, 2]}, "target"),
    ({"op": "ik_pose", "pose": 1, "joint": "LeftHand", "target": [1, 2, float("inf")]}, r"target\[2\]"),
    ({"op": "keep_contacts", "strength": 1}, "strength"),
    ({"op": "edit_frame", "frame": "2", "deltas": {}}, "frame"),
    ({"op": "propagate", "deltas": D}, "frame"),
    ({"op": "propagate", "frame": 1, "frames": [1], "deltas": D}, "frame"),
    ({"op": "propagate", "frames": [1, 2], "deltas": D}, "deltas"),
    ({"op": "propagate", "frames": [1, 1], "deltas": [D, D]}, "frames"),
    ({"op": "propagate", "frame": 1, "deltas": [D]}, "deltas"),
    ({"op": "propagate", "frame": 1, "deltas": D, "frame_range": [5, 5]}, "frame_range"),
    ({"op": "propagate", "frame": 1, "deltas": D, "repetitions": "drop"}, "repetitions"),
    ({"op": "guided_warp"}, "duration"),
    ({"op": "guided_warp", "duration": 1, "free_length": True}, "duration"),
    ({"op": "guided_warp", "free_length": True, "keytimes": [[0.1, 0.1]]}, "keytimes"),
    ({"op": "guided_warp", "duration": 1, "skip": 0}, "skip"),
    ({"op": "guided_warp", "duration": 1, "skip": 1000}, "skip"),
    ({"op": "guided_warp", "duration": 1, "backward": 1}, "backward"),
    ({"op": "guided_warp", "duration": 1, "reference": {"segment": [2, 1]}}, "reference.segment"),
    ({"op": "guided_warp", "duration": 1, "reference": {"path": "a", "segment": [0, 1]}}, "reference"),
    ({"op": "guided_warp", "duration": 1, "keytimes": [[0.1]]}, r"keytimes\[0\]"),
    ({"op": "linear_warp", "duration": -1}, "duration"),
    ({"op": "resample", "frame_time": 0}, "frame_time"),
    ({"op": "edit_pose", "pose": 1, "deltas": D, "propagate": 1}, "propagate"),
    ({"op": "edit_pose", "pose": 1, "deltas": D, "sigma": 0.5}, "sigma"),             # without propagate
    ({"op": "edit_pose", "pose": 1, "deltas": D, "propagate": True, "sigma": 0}, "sigma"),
    ({"op": "ik_pose", "pose": 1, "joint": "LeftHand", "target": [1, 2, 3], "frame_range": [0, 9]}, "frame_range"),
    ({"op": "exaggerate", "w_r": 1, "propagate": True}, "poses"),                       # every pose: nothing to spread
    ({"op": "exaggerate", "w_r": 1, "poses": [2, 2], "propagate": True}, "poses"),
    ({"op": "succession", "root": "Hips", "s": 0.1, "falloff": 30}, "falloff"),
    ({"op": "succession", "root": "Hips", "s": 0.1, "falloff": {"sigma": 1.0}}, "falloff.frame"),
    ({"op": "succession", "root": "Hips", "s": 0.1, "falloff": {"frame": 3, "width": 1}}, "falloff.width"),
    ({"op": "random_timing", "tau": 0.1, "falloff": {"frame": 3, "sigma": -1}}, "falloff.sigma"),
    ({"op": "random_timing", "tau": 0.1, "falloff": {"frame": 30, "frame_range": [0, 9]}}, "falloff.frame"),
    ({"op": "guide_poses", "free_length": True, "duration": 2.0}, "duration"),
    ({"op": "guide_poses", "free_length": True, "keytimes": [[0.1, 0.1]]}, "keytimes"),
    ({"op": "guide_poses", "reference": {"segment": [2, 1]}}, "reference.segment"),
    ({"op": "guide_poses", "backward": True}, "backward"),                              # pose times keep their order
    ({"op": "guide_poses", "skip": 0}, "skip"),
]


@pytest.mark.parametrize("data, field", HOSTILE, ids=[str(i) for i in range(len(HOSTILE))])
def test_hostile_ops_name_the_field(data, field):
    where = "ops[7]"
    pattern = "^" + re.escape(where) + (rf"\.{field}(?![\w.\[])" if field else ":")
    with pytest.raises(ValueError, match=pattern):
        Op.from_json(data, where)


@pytest.mark.parametrize("options, field", [
    ({"iterations": 1e9}, "iterations"),
    ({"iterations": 2.5}, "iterations"),
    ({"filter_width": 1e9}, "filter_width"),
    ({"filter_width": 0}, "filter_width"),
    ({"smoothing_iterations": 10 ** 9}, "smoothing_iterations"),
    ({"smoothing_lambda": 2}, "smoothing_lambda"),
    ({"continuity": "C2"}, "continuity"),
    ({"contacts": [["LeftFoot", 0]]}, r"contacts\[0\]"),
    ({"min_prominence": "0.1"}, "min_prominence"),
    ({"bogus": 1}, "bogus"),
])
def test_extract_options_are_checked(options, field):
    with pytest.raises(ValueError, match=rf"^extract_options\.{field}"):
        check_extract_options(options)


def test_extract_options_accepted_values_pass_through():
    opts = {"iterations": 3, "filter_width": 0.2, "smoothing_iterations": None, "contacts": [["LeftFoot", 0, 10]]}
    assert check_extract_options(opts) == opts
    assert check_extract_options(None) == {}


def test_huge_lists_are_refused_by_size_before_their_items_are_checked():
    n = O.MAX_ITEMS + 1
    with pytest.raises(ValueError, match=r"^ops\[0\]\.keytimes: 100001 items is over the limit"):
        Op.from_json({"op": "linear_warp", "duration": 1.0, "keytimes": [[0.1, 0.1]] * n}, "ops[0]")
    with pytest.raises(ValueError, match=r"^ops\[0\]\.joints: 100001 items"):
        Op.from_json({"op": "random_timing", "tau": 0.1, "joints": ["x"] * n}, "ops[0]")
    with pytest.raises(ValueError, match=r"^ops\[0\]\.deltas: 100001 items"):
        Op.from_json({"op": "edit_frame", "frame": 1, "deltas": {str(i): [0, 0, 0] for i in range(n)}}, "ops[0]")
