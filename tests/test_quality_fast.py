"""sn.quality's fast path: quality.prepare(source) computed once, compare(..., prepared=, edited_positions=,
baseline_positions=) vectorised. The report is the uncached one bit for bit, and the naive reference's
(tests/quality_reference.py: the straightforward loops) to rounding; the carried contacts are
staggered.carry_contacts' exactly; the one-line summary's structured parts."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from quality_reference import compare_reference

import stagger_nb as sn
from stagger_nb import data, quality, staggered
from stagger_nb.core.body import pelvis_joint
from stagger_nb.quality.report import _part


def _edits(m):
    """(name, edited, kwargs) on ``m``: unedited, a mild timing edit with the contact layer and its baseline,
    a strong raw edit whose knots cross, the same without a StaggeredMotion, and a resampled copy."""
    sm = staggered.extract(m)
    root = m.skeleton.names[pelvis_joint(m.skeleton)]
    mild = staggered.random_timing(staggered.succession(sm, root=root, s=0.02, l=1.0), tau=0.05, seed=0)
    raw = staggered.random_timing(staggered.succession(sm, root=root, s=0.08, l=3.0, limit=None), tau=0.15,
                                  seed=1, limit=None)
    layer = staggered.keep_contacts(mild, m)
    return [("unedited", sm, {}),
            ("mild + layer", layer, {"staggered": mild, "baseline": staggered.evaluate(mild)}),
            ("raw strong", staggered.evaluate(raw), {"staggered": raw}),
            ("no staggered", staggered.evaluate(mild), {}),
            ("resampled", m.resample(m.frame_time / 2), {})]


def _close(a, b, path=""):
    """Paths where the report dicts ``a`` and ``b`` differ beyond rounding (floats: 1e-9 absolute + 1e-7
    relative, the vectorised sums and the argmin-then-angle order of operations; the rest exactly)."""
    out = []
    if isinstance(a, dict):
        for k in a:
            out += _close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} vs {len(b)} items"]
        for i, (x, y) in enumerate(zip(a, b)):
            out += _close(x, y, f"{path}[{i}]")
    elif isinstance(a, float) and isinstance(b, float):
        if not abs(a - b) <= 1e-9 + 1e-7 * abs(b):
            out.append(f"{path}: {a!r} vs {b!r}")
    elif a != b:
        out.append(f"{path}: {a!r} vs {b!r}")
    return out


@pytest.fixture(scope="module", params=["walk", "cmu_01_01[0:700]", "jump", "freebvh_step"])
def clip(request):
    name = request.param
    m = data.load("cmu_01_01").slice(0, 700) if name.startswith("cmu") else data.load(name)
    return name, m, quality.prepare(m), _edits(m)


def test_prepared_is_the_uncached_report_bit_for_bit(clip):
    _, m, prep, edits = clip
    for name, edited, kw in edits:
        a = quality.compare(m, edited, **kw).to_dict()
        b = quality.compare(m, edited, prepared=prep, **kw).to_dict()
        assert a == b, name
        ev = edited if isinstance(edited, sn.Motion) else staggered.evaluate(edited)
        c = quality.compare(m, edited, prepared=prep, edited_positions=sn.forward_kinematics(ev)[0], **kw)
        assert c.to_dict() == a, name
        if "baseline" in kw:   # the baseline's legs by their chains' FK: the full FK's numbers there
            d = quality.compare(m, edited, prepared=prep, edited_positions=sn.forward_kinematics(ev)[0],
                                baseline_positions=sn.forward_kinematics(kw["baseline"])[0], **kw)
            assert d.to_dict() == a, name


def test_the_fast_figures_are_the_naive_reference_figures(clip):
    clip_name, m, prep, edits = clip
    for name, edited, kw in edits:
        fast = quality.compare(m, edited, prepared=prep, **kw).to_dict()
        ref = compare_reference(m, edited, **kw).to_dict()
        for k in ("items", "summary", "pelvis_vs_baseline_drop"):   # new in the fast version
            fast.pop(k)
            ref.pop(k)
        assert not _close(fast, ref), (clip_name, name, _close(fast, ref)[:5])
    # the edits measure something (not all zeros)
    mild = quality.compare(m, edits[1][1], prepared=prep, **edits[1][2])
    assert mild.moved > 0 and mild.pelvis_vs_baseline is not None


def test_the_carried_contacts_are_carry_contacts(clip):
    """compare carries every contact at once; the frames are those staggered.carry_contacts (its default, the
    contact layer's carry) gives each."""
    _, m, prep, edits = clip
    for name, edited, kw in edits:
        sm = kw.get("staggered", edited if isinstance(edited, staggered.StaggeredMotion) else None)
        if sm is None:
            continue
        r = quality.compare(m, edited, prepared=prep, **kw)
        want = []
        for c in prep.contacts:
            got = staggered.carry_contacts(sm, [c], m.frame_time)
            ev_frames = (edited if isinstance(edited, sn.Motion) else staggered.evaluate(edited)).num_frames
            if got and min(got[0][2], ev_frames) > got[0][1]:
                want.append((c[0], (c[1], c[2]), (got[0][1], min(got[0][2], ev_frames))))
        assert [(c.joint, c.source_frames, c.frames) for c in r.contacts] == want, name


def test_source_figures_are_frozen_and_read_only():
    m = data.load("walk")
    prep = quality.prepare(m)
    with pytest.raises(dataclasses.FrozenInstanceError):
        prep.floor = 0.0
    for name in ("positions", "up", "step_angles", "step_lengths", "velocity", "detail"):
        with pytest.raises(ValueError):
            getattr(prep, name)[...] = 0.0
    assert np.array_equal(prep.positions, sn.forward_kinematics(m)[0])
    assert prep.contacts == tuple(staggered.detect_contacts(m))
    assert prep.body_height == quality.body_height(m) and prep.scale == quality.BODY_CM / prep.body_height
    # what it was given is what it holds
    p2 = quality.prepare(m, contacts=[("LeftFoot", 0, 10)], body_height=85.0)
    assert p2.contacts == (("LeftFoot", 0, 10),) and p2.scale == 2.0


def test_compare_arguments_override_the_prepared_ones():
    m = data.load("walk")
    e = staggered.succession(staggered.extract(m), root="Hips", s=0.03, l=2.0)
    prep = quality.prepare(m)
    kw = {"contacts": [("LeftFoot", 20, 60)], "body_height": 90.0}
    assert (quality.compare(m, e, prepared=prep, **kw).to_dict()
            == quality.compare(m, e, prepared=quality.prepare(m, **kw)).to_dict())


def test_fast_path_errors_name_the_parameter():
    m = data.load("walk")
    other = data.load("run")
    prep = quality.prepare(m)
    with pytest.raises(ValueError, match="prepared: computed for another source motion"):
        quality.compare(other, other, prepared=prep)
    with pytest.raises(ValueError, match="prepared must be quality.prepare"):
        quality.compare(m, m, prepared=object())
    with pytest.raises(ValueError, match=r"edited_positions must be finite, of shape \(361, 31, 3\)"):
        quality.compare(m, m, prepared=prep, edited_positions=np.zeros((3, 31, 3)))
    bad = np.array(sn.forward_kinematics(m)[0])
    bad[0, 0, 0] = np.inf
    with pytest.raises(ValueError, match="edited_positions must be finite"):
        quality.compare(m, m, edited_positions=bad)
    with pytest.raises(ValueError, match="baseline_positions: given without a baseline"):
        quality.compare(m, m, baseline_positions=bad)
    with pytest.raises(ValueError, match="baseline_positions must be finite"):
        quality.compare(m, m, baseline=m, baseline_positions=bad)
    with pytest.raises(ValueError, match="source must be a Motion"):
        quality.prepare("clip.bvh")


# -- the one-line summary ----------------------------------------------------------------------------------

def test_summary_items_are_the_line_and_say_what_is_out_of_bounds():
    from quality_figures import FEET, F, standing  # the hand-built 170 cm figure (Y up, cm)
    fine = quality.compare(standing(), standing(), contacts=FEET)
    assert fine.summary == "feet held · pelvis ±0.0 cm · no pops"
    assert [(i.figure, i.ok) for i in fine.items] == [("foot_travel", True), ("pelvis", True), ("added_pop", True)]
    assert fine.summary == " · ".join(i.text for i in fine.items)
    # the whole body 6 cm lower and the left foot 3.2 cm forward over the contact: the left foot slides
    # (3.2 cm > 1), both feet sit 6 cm below their plants and the floor, the pelvis drops 6 cm
    rp = np.tile([0.0, 84.0, 0.0], (F, 1))
    r = quality.compare(standing(), standing(root=rp), contacts=FEET, bounds={"height": 10, "floor": 10})
    assert r.summary == "feet held · pelvis drops 6.0 cm · no pops"
    item = r.items[1]
    assert (item.figure, item.value, item.bound, item.ok, item.unit) == ("pelvis", pytest.approx(6.0), 3.0, False, "cm")
    ramp = np.tile([0.0, 90.0, 0.0], (F, 1))
    ramp[:, 2] += np.linspace(0.0, 3.2, F)
    moved = standing(root=ramp)
    only_left = [("LeftFoot", 0, F)]
    r = quality.compare(standing(), moved, contacts=only_left)
    assert r.summary == "left foot slides 3.2 cm · pelvis ±0.0 cm · no pops"
    assert r.items[0].joint == "LeftFoot" and not r.items[0].ok and r.items[0].bound == 1.0
    # a rise is said as one
    up = quality.compare(standing(), standing(root=np.tile([0.0, 95.0, 0.0], (F, 1))), contacts=FEET,
                         bounds={"height": 10})
    assert "pelvis rises 5.0 cm" in up.summary and not up.ok
    # JSON: the items are in to_dict
    d = json.loads(json.dumps(r.to_dict()))
    assert [i["text"] for i in d["items"]] == [i.text for i in r.items]
    assert d["items"][0] == {"figure": "foot_travel", "text": "left foot slides 3.2 cm", "value": pytest.approx(3.2),
                             "bound": 1.0, "ok": False, "unit": "cm", "joint": "LeftFoot"}


def test_summary_says_the_layer_own_pelvis_change_and_plural_parts():
    from quality_figures import FEET, F, standing
    base = standing(root=np.tile([0.0, 88.0, 0.0], (F, 1)))
    layer = standing(root=np.tile([0.0, 84.0, 0.0], (F, 1)))
    r = quality.compare(standing(), layer, contacts=FEET, baseline=base, bounds={"height": 10, "floor": 10})
    assert r.pelvis_vs_baseline == pytest.approx(4.0) and r.pelvis_vs_baseline_drop == pytest.approx(4.0)
    assert r.items[1].figure == "pelvis_vs_baseline" and r.items[1].text == "pelvis drops 4.0 cm"
    # a plural body part takes a plural verb; a joint with no body-part name keeps its name
    assert _part("RightToeBase") == ("right toes", "")
    assert _part("LeftFoot") == ("left foot", "s")
    assert _part("Prop7") == ("Prop7", "s")


def test_summary_names_crossed_knots_and_lost_detail():
    m = data.load("walk")
    sm = staggered.extract(m)
    r = np.array(sm.refinements)
    for name in ("LeftForeArm", "RightHand"):
        j = sm.skeleton.index(name)
        r[3, j] = sm.pose_times[4] - sm.pose_times[3] + 0.01
    rep = quality.compare(m, dataclasses.replace(sm, refinements=r))
    knots = [i for i in rep.items if i.figure == "knots_out_of_order"][0]
    assert knots.text == "poses out of order in left arm, right hand" and knots.value == 2.0 and not knots.ok
    from scipy.ndimage import gaussian_filter1d
    q = gaussian_filter1d(np.array(m.local_quats), 6.0, axis=0, mode="nearest")
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    smooth = quality.compare(m, m.replace(local_quats=q))
    item = [i for i in smooth.items if i.figure == "detail"][0]
    assert item.text.startswith("detail lost (×0.") and item.bound == (0.5, 2.0) and not item.ok
    assert item.to_dict()["bound"] == [0.5, 2.0]
