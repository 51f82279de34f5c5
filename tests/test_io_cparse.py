"""The optional C accelerator of the BVH reader (stagger_nb/io/_cparse.c): bit-identical to ``float`` and
to the numpy + pyarrow path, "not handled" (-1) on anything else, never past its bounds; ``read_bvh`` gives
the same motions and the same errors with and without it (``STAGGER_NB_NO_ACCEL=1`` forces the fallback)."""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_MOCAP

import stagger_nb as sn
from stagger_nb.io import bvh_block
from stagger_nb.io import bvh_read as bvh

cparse = bvh_block._cparse
needs_c = pytest.mark.skipif(cparse is None, reason="the C accelerator was not built here (no compiler at install)")
DATA = Path(os.environ.get("STAGGER_NB_DATA") or Path(__file__).resolve().parents[1] / "data")


def test_the_accelerator_is_built_on_ci():
    """CI installs with a compiler: a silent fallback there must not pass as the fast path."""
    if os.environ.get("CI", "").lower() not in ("1", "true", "yes"):
        pytest.skip("not on CI (CI=true): a machine without a compiler may run the fallback")
    assert cparse is not None, "stagger_nb.io._cparse did not build: read_bvh runs the slow fallback"
    assert bvh.accelerated()


def test_the_env_var_forces_the_fallback(monkeypatch):
    monkeypatch.setenv(bvh.NO_ACCEL_ENV, "1")
    assert not bvh.accelerated()
    monkeypatch.setenv(bvh.NO_ACCEL_ENV, "0")
    assert bvh.accelerated() == (cparse is not None)


def _parse(text: bytes, rows: int, cols: int, start: int = 0, stop: int | None = None, module=None):
    """(return value, (rows, cols) table) of parse_rows (of ``module``, else the built one) laid out row-major."""
    out = np.full(rows * cols, np.nan)
    res = (module or cparse).parse_rows(text, start, len(text) if stop is None else stop, rows, out,
                            np.arange(cols, dtype=np.int64), np.full(cols, cols, np.int64))
    return res, out.reshape(rows, cols)


def _random_tokens(rng, n: int) -> list[str]:
    """Decimal strings of every shape the grammar allows: signs, leading/trailing dots, 1-25 digits
    (past the fast path's 2^53 and 19-digit limits), exponents up to +-400 (past +-22: the slow path,
    subnormals, underflow to zero), leading zeros."""
    out = []
    for _ in range(n):
        digits = "".join(rng.choice(list("0123456789"), size=int(rng.integers(1, 26))))
        cut = int(rng.integers(0, len(digits) + 1))
        kind = rng.integers(0, 4)
        mant = digits if kind == 0 else (digits[:cut] + "." + digits[cut:] if kind < 3 else "." + digits)
        if mant == ".":
            mant = "0."
        sign = rng.choice(["", "-", "+"])
        exp = ""
        if rng.random() < 0.4:
            e = int(rng.integers(-30, 31)) if rng.random() < 0.8 else int(rng.integers(-400, 400))
            exp = rng.choice(["e", "E"]) + (rng.choice(["", "+"]) if e >= 0 else "-") + str(abs(e)).zfill(
                int(rng.integers(1, 4)))
        out.append(sign + mant + exp)
    return out


@needs_c
@pytest.mark.parametrize("build", ["default", "scalar"])
def test_random_decimals_are_bit_identical_to_float(build, request):
    """20k random decimals (see _random_tokens) in random spacing, CRLF and LF lines: bit for bit float()."""
    module = request.getfixturevalue("scalar_build") if build == "scalar" else cparse
    rng = np.random.default_rng(13)
    toks = [t for t in _random_tokens(rng, 20_000) if np.isfinite(float(t))]
    cols = 6
    toks = toks[: len(toks) // cols * cols]
    rows = len(toks) // cols
    seps = rng.choice([" ", "  ", "\t", " \t"], size=len(toks))
    lines = ["".join(t + s for t, s in zip(toks[r * cols:(r + 1) * cols], seps[r * cols:(r + 1) * cols]))
             for r in range(rows)]
    text = ("\r\n".join(lines[: rows // 2]) + "\n" + "\n".join(lines[rows // 2:])).encode()
    res, table = _parse(text, rows, cols, module=module)
    assert res == len(text)
    ref = np.array([float(t) for t in toks]).reshape(rows, cols)
    assert np.array_equal(table.view(np.int64), ref.view(np.int64))  # bit for bit, -0.0 included


@needs_c
@pytest.mark.parametrize("tok", ["0", "-0", "-0.0", "+.5", "5.", "1e22", "9007199254740993", "9007199254740992",
                                 "123456789012345678901234567890", "0.1", "1.7976931348623157e308",
                                 "4.9e-324", "2.4703282292062328e-324", "1e-400", "0." + "0" * 40 + "1",
                                 "8.98846567431158e307", "1" * 19 + ".5", "0000000000000000000000012.5e-1"])
def test_hard_tokens_round_like_float(tok):
    res, table = _parse((tok + " " + tok + "\n").encode(), 1, 2)
    assert res > 0
    assert table[0, 0].tobytes() == table[0, 1].tobytes() == np.float64(float(tok)).tobytes()


@needs_c
@pytest.mark.parametrize("text", [
    b"nan 1", b"inf 1", b"1_0 1", b"0x1 1", b"1e 1", b"+ 1", b". 1", b"-. 1", b"1.2.3 1", b"1e+ 1", b"--1 1",
    b"1- 1", b"1e5.0 1", b"1,5 1", b"\xef\xbc\x91 1", b"1\x0b1", b"1\x0c1", b"1 \x001", b"1 2 3", b"1",
    b"1e999 1", b"-1e400 1", b"1" * 65 + b" 1", b"\n1 1", b"1 1\n\n1 1"])
def test_anything_else_is_not_handled(text):
    rows = 2 if text.count(b"\n") > 1 else 1
    assert _parse(text, rows, 2)[0] == -1


@needs_c
def test_line_structure_and_bounds():
    assert _parse(b"1 2\n3 4", 2, 2)[0] == 7
    assert _parse(b"1 2\n3 4\n", 2, 2)[0] == 8
    assert _parse(b"1 2\n3 4\n5 6", 2, 2)[0] == 8  # stops after its rows: the caller sees more data
    assert _parse(b"1 2\n3", 2, 2)[0] == -1  # short last line
    assert _parse(b"1 2\n", 2, 2)[0] == -1  # too few lines
    # stop is respected: "45" cut to "4" (and a later byte that would be refused is never read)
    res, table = _parse(b"1 2\n3 45x", 2, 2, stop=7)
    assert res == 7 and table[1, 1] == 4.0
    res, table = _parse(b"zz1 2\n3 4", 2, 2, start=2)
    assert res == 9 and np.array_equal(table, [[1, 2], [3, 4]])


@needs_c
def test_layout_and_bad_arguments():
    out = np.zeros(12)
    # channel-major (cols, rows) via base = c * rows, stride = 1
    text = b"1 2 3\n4 5 6\n7 8 9\n10 11 12"
    res = cparse.parse_rows(text, 0, len(text), 4, out, np.array([0, 4, 8], np.int64), np.ones(3, np.int64))
    assert res == len(text) and np.array_equal(out.reshape(3, 4), np.arange(1, 13).reshape(4, 3).T)
    with pytest.raises(ValueError, match="leaves out"):  # an index past the end of out is refused up front
        cparse.parse_rows(b"1 2\n3 4", 0, 7, 2, np.zeros(3), np.array([0, 1], np.int64), np.array([2, 2], np.int64))
    with pytest.raises(ValueError, match="stop"):
        cparse.parse_rows(b"1 2", 0, 99, 1, np.zeros(2), np.arange(2, dtype=np.int64), np.ones(2, np.int64))
    with pytest.raises(TypeError):  # out must be writable
        cparse.parse_rows(b"1 2", 0, 3, 1, b"x" * 16, np.arange(2, dtype=np.int64), np.ones(2, np.int64))


def _clips() -> list[Path]:
    paths = sorted(DATA.glob("*.bvh"))
    if SHARED_MOCAP.is_dir():
        paths += sorted(SHARED_MOCAP.glob("*.bvh"))
    return paths


def _both(read, monkeypatch):
    """(result or error message) of ``read()`` with the accelerator, then with the fallback forced."""
    out = []
    for env in ("", "1"):
        monkeypatch.setenv(bvh.NO_ACCEL_ENV, env)
        try:
            out.append(read())
        except bvh.BVHError as e:
            out.append(str(e))
    monkeypatch.delenv(bvh.NO_ACCEL_ENV)
    return out


def _same_motion(a, b) -> bool:
    return all((x is None and y is None) or (x is not None and y is not None and x.shape == y.shape
                                              and np.array_equal(x.view(np.int64), y.view(np.int64)))
               for x, y in ((a.root_positions, b.root_positions), (a.local_quats, b.local_quats),
                            (a.local_translations, b.local_translations)))


@needs_c
def test_every_clip_reads_bit_identically_with_and_without_it(monkeypatch, tmp_path):
    clips = _clips()
    if not clips:
        pytest.skip(f"no clips in {DATA} or {SHARED_MOCAP} (make data writes data/*.bvh)")
    used = []
    real = bvh_block._Layout.read_accelerated
    monkeypatch.setattr(bvh_block._Layout, "read_accelerated", lambda *a: used.append(real(*a)) or used[-1])
    for p in clips:
        written = tmp_path / p.name
        sn.write_bvh(sn.read_bvh(p), written)
        for path in (p, written):
            used.clear()
            a, b = _both(lambda: sn.read_bvh(path), monkeypatch)
            assert used == [True], f"{path}: the C parser did not certify the block"
            assert _same_motion(a, b), path


def _tiny(block: bytes, frames: int = 3) -> bytes:
    head = ("HIERARCHY\nROOT hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation "
            "Xrotation Yrotation\n JOINT knee\n {\n  OFFSET 0 -1 0\n  CHANNELS 2 Xrotation Zrotation\n"
            "  JOINT foot\n  {\n   OFFSET 0 -1 0\n   CHANNELS 4 Yrotation Xrotation Zrotation Xposition\n"
            "   End Site\n   {\n    OFFSET 0 0 1\n   }\n  }\n }\n}\n"
            f"MOTION\nFrames: {frames}\nFrame Time: 0.0333333\n").encode()
    return head + block


def test_mixed_rigs_and_mutated_blocks_agree_with_the_fallback(monkeypatch):
    """Channel layouts the fast conversion treats apart (a two-axis joint, a translated joint, several
    orders) and ~300 seeded mutations of the block: the same Motion, or the same BVHError (file, line,
    message), with and without the accelerator."""
    rng = np.random.default_rng(7)
    rows = [" ".join(f"{v:.6f}" for v in rng.uniform(-200, 200, 12)) for _ in range(3)]
    good = _tiny(("\n".join(rows) + "\n").encode())
    a, b = _both(lambda: bvh.parse_bvh(good, "tiny.bvh"), monkeypatch)
    assert isinstance(a, sn.Motion) and _same_motion(a, b)
    start = good.index(b"Frame Time")
    junk = [b" ", b"\n", b"\t", b"x", b"e", b".", b"-", b"+", b"1", b"\r", b"\x0b", b"nan", b"\n\n", b"1e999", b"\x00"]
    for k in range(300):
        text = bytearray(good)
        for _ in range(int(rng.integers(1, 4))):
            at = int(rng.integers(start, len(text)))
            if rng.random() < 0.5:
                text[at:at + 1] = junk[int(rng.integers(len(junk)))]
            else:
                text[at:at] = junk[int(rng.integers(len(junk)))]
        a, b = _both(lambda: bvh.parse_bvh(bytes(text), "mutant.bvh"), monkeypatch)
        if isinstance(a, str) or isinstance(b, str):
            assert a == b, (k, bytes(text[start:]))
            assert re.search(r"mutant\.bvh.*line \d+", a), a
        else:
            assert _same_motion(a, b), k


def test_quaternions_match_the_reference_conversion(monkeypatch):
    """The accelerated path writes quaternions straight into the output; they equal a plain
    per-joint euler_to_quat of the parsed angles (x, y, z, w), to rounding (the half-angle
    identity and the product order are the same, so in practice bit for bit)."""
    from stagger_nb.core.rotations import euler_to_quat
    rng = np.random.default_rng(3)
    vals = rng.uniform(-400, 400, (5, 12))
    m = bvh.parse_bvh(_tiny(("\n".join(" ".join(repr(float(v)) for v in r) for r in vals) + "\n").encode(), 5))
    ref = np.stack([euler_to_quat(vals[:, 3:6], "ZXY"), euler_to_quat(vals[:, 6:8], "XZ"),
                    euler_to_quat(vals[:, 8:11], "YXZ")], axis=1)
    ref *= np.where(np.sum(ref * m.local_quats, axis=-1, keepdims=True) < 0, -1.0, 1.0)  # q and -q: same
    np.testing.assert_allclose(m.local_quats, ref, rtol=0, atol=4e-16)  # a few ulps of 1
    np.testing.assert_array_equal(m.root_positions, vals[:, :3])
    np.testing.assert_array_equal(m.local_translations[:, 2, 0], vals[:, 11])


@pytest.fixture(scope="module")
def scalar_build(tmp_path_factory):
    """_cparse.c compiled with -DCPARSE_SCALAR: the portable path other machines (big-endian, no SSE2) run."""
    import importlib.util
    import shutil
    import subprocess
    import sysconfig
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler here")
    src = Path(__file__).resolve().parents[1] / "stagger_nb" / "io" / "_cparse.c"
    so = tmp_path_factory.mktemp("scalar") / ("_cparse" + sysconfig.get_config_var("EXT_SUFFIX"))
    subprocess.run([cc, "-O2", "-shared", "-fPIC", "-DCPARSE_SCALAR", f"-I{sysconfig.get_paths()['include']}",
                    str(src), "-o", str(so)], check=True, capture_output=True)
    spec = importlib.util.spec_from_file_location("_cparse", so)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@needs_c
@pytest.mark.parametrize("build", ["default", "scalar"])
def test_mutated_tables_are_refused_or_parsed_exactly(build, request):
    """Seeded tables in several number formats, 0-2 bytes replaced or inserted, each in a buffer of its
    exact size (so a read past it would show under an ASan build): parse_rows either refuses the block or
    returns exactly float() of its tokens, never a position outside the block."""
    module = request.getfixturevalue("scalar_build") if build == "scalar" else cparse
    rng = np.random.default_rng(2)
    junk = [b" ", b"\n", b"\t", b"x", b"e", b".", b"-", b"+", b"1", b"\r", b"\x0b", b"\n\n", b"123456789012", b""]
    accepted = 0
    for _ in range(1500):
        cols, rows = int(rng.integers(1, 8)), int(rng.integers(1, 12))
        vals = rng.uniform(-1e3, 1e3, (rows, cols)) * 10.0 ** rng.integers(-8, 8, (rows, cols))
        fmt = str(rng.choice(["%.6f", "%.3f", "%g", "%.17g", "%.2e"]))
        text = bytearray("\n".join(" ".join(fmt % v for v in row) for row in vals).encode())
        for _ in range(int(rng.integers(0, 3))):
            at = int(rng.integers(0, len(text) + 1))
            text[at:at + int(rng.integers(0, 2))] = junk[int(rng.integers(len(junk)))]
        buf = np.frombuffer(bytes(text), np.uint8).copy()
        res, table = _parse(buf, rows, cols, module=module)
        assert res == -1 or 0 < res <= len(buf)
        if res > 0:
            accepted += 1
            ref = np.array([float(t) for t in bytes(buf[:res]).split()])
            assert np.array_equal(ref.view(np.int64), table.ravel().view(np.int64)), bytes(buf[:res])
    assert accepted > 300  # most mutations keep a valid table: the comparison above ran


@needs_c
def test_c_continuity_is_quat_continuous_bit_for_bit():
    """make_continuous (the reader's one-pass hemisphere continuity) against quat_continuous: random
    quaternions with random sign flips, dot products at rounding level of zero (where the summation
    order decides), exact zeros and signed zeros, one frame, one joint; bit for bit, -0.0 included."""
    from stagger_nb.core.rotations import quat_continuous
    if not bvh_block._c_continuity():
        pytest.skip("numpy sums einsum's dot products in another order on this machine: the reader keeps numpy's")
    rng = np.random.default_rng(11)
    for F, J in ((1, 3), (2, 1), (257, 1), (300, 31), (41, 7)):
        q = rng.normal(size=(F, J, 4))
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
        near = rng.random((F, J)) < 0.5  # half the frames: nearly orthogonal to the previous one
        for f in range(1, F):
            a, b = q[f - 1], q[f]
            ortho = b - np.sum(a * b, -1, keepdims=True) * a
            q[f] = np.where(near[f][:, None], ortho, b)
        q[rng.random((F, J)) < 0.05] = [0.0, -0.0, 0.0, 1.0]  # exact zero dots against (x, y, z, 0) frames
        q[rng.random((F, J)) < 0.05] = [1.0, 0.0, -0.0, 0.0]
        q *= np.where(rng.random((F, J, 1)) < 0.3, -1.0, 1.0)
        ref = quat_continuous(q)
        mine = q.copy()
        cparse.make_continuous(mine, J)
        assert np.array_equal(ref.view(np.int64), mine.view(np.int64)), (F, J)
    with pytest.raises(ValueError, match="make_continuous"):
        cparse.make_continuous(np.zeros(6), 1)
    cparse.make_continuous(np.zeros((0, 2, 4)), 2)  # no frames: nothing read or written


@needs_c
def test_wrapping_angles_read_as_motion_would_build_them(monkeypatch):
    """Angles far past +-180 (each 360 negates the half-angle pair, so the raw quaternions flip sign
    often): read_bvh's quaternions are bit for bit Motion(...)'s from the same raw quaternions, with
    and without the accelerator."""
    from stagger_nb.core.rotations import euler_to_quat
    rng = np.random.default_rng(5)
    vals = rng.uniform(-2000, 2000, (40, 12)).round(6)
    text = _tiny(("\n".join(" ".join(f"{v:.6f}" for v in r) for r in vals) + "\n").encode(), 40)
    m = bvh.parse_bvh(text, "wrap.bvh")
    raw = np.stack([euler_to_quat(vals[:, 3:6], "ZXY"), euler_to_quat(vals[:, 6:8], "XZ"),
                    euler_to_quat(vals[:, 8:11], "YXZ")], axis=1)
    ref = sn.Motion(m.skeleton, m.frame_time, m.root_positions, raw, m.local_translations)
    assert np.array_equal(m.local_quats.view(np.int64), ref.local_quats.view(np.int64))
    a, b = _both(lambda: bvh.parse_bvh(text, "wrap.bvh"), monkeypatch)
    assert _same_motion(a, b)


@needs_c
@pytest.mark.parametrize("axes", ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"])
def test_c_quaternions_from_tangents_are_euler_components_bit_for_bit(axes):
    """quats_from_tangents (the reader's conversion after numpy's tan) against euler_components on the same
    angles: uniform, +-180 / +-360 / +-720 exactly, signed zeros, subnormal and huge angles, wraps; bit for bit."""
    from stagger_nb.core.rotations import euler_components, quarter_tan
    rng = np.random.default_rng(sum(map(ord, axes)))
    special = np.array([0.0, -0.0, 180.0, -180.0, 360.0, -360.0, 720.0, 90.0, -90.0, 5e-324, -1e-310, 1e-300,
                        179.999999, -180.000001, 1e6 + 0.5, -3.0e7, 540.0, 45.0])
    for ang in (rng.uniform(-180, 180, (3, 5000)), rng.uniform(-5000, 5000, (3, 5000)),
                rng.choice(special, (3, 4000)), np.where(rng.random((3, 3000)) < 0.5, rng.choice(special, (3, 3000)),
                                                          rng.uniform(-180, 180, (3, 3000)))):
        ref = np.ascontiguousarray(euler_components(ang.copy(), axes).T)
        t = quarter_tan(ang.copy(), np.empty_like(ang))
        out = np.full((ang.shape[1], 4), np.nan)
        cparse.quats_from_tangents(t, axes, out)
        assert np.array_equal(ref.view(np.int64), out.view(np.int64)), axes
    for bad in (("XXY", np.empty((2, 4))), ("XYZ", np.empty((3, 4))), ("XY", np.empty((2, 4))),
                ("xyz", np.empty((2, 4)))):
        with pytest.raises(ValueError, match="quats_from_tangents"):
            cparse.quats_from_tangents(np.zeros(6), *bad)


@needs_c
def test_a_continuity_summing_in_another_order_is_not_used(monkeypatch):
    """Where numpy's einsum summed dot products in another order than the C pass, _c_continuity says no
    (simulated by a C stand-in that sums sequentially) and read_bvh keeps numpy's pass: same bits."""
    import types

    def sequential(q, joints):  # quat_continuous with ((x x' + y y') + z z') + w w'
        q4 = q.reshape(-1, joints, 4)
        p = q4[1:] * q4[:-1]
        neg = (((p[..., 0] + p[..., 1]) + p[..., 2]) + p[..., 3]) < 0
        q4[1:][np.logical_xor.accumulate(neg, axis=0)] *= -1.0

    fake = types.SimpleNamespace(parse_rows=cparse.parse_rows, quats_from_tangents=cparse.quats_from_tangents,
                                 make_continuous=sequential)
    monkeypatch.setattr(bvh_block, "_cparse", fake)
    monkeypatch.setattr(bvh_block, "_C_CONTINUITY", [])
    assert not bvh_block._c_continuity()
    rng = np.random.default_rng(9)
    vals = rng.uniform(-2000, 2000, (30, 12)).round(6)
    text = _tiny(("\n".join(" ".join(f"{v:.6f}" for v in r) for r in vals) + "\n").encode(), 30)
    a, b = _both(lambda: bvh.parse_bvh(text, "order.bvh"), monkeypatch)
    assert _same_motion(a, b)
    monkeypatch.setattr(bvh_block, "_C_CONTINUITY", [])
    monkeypatch.setattr(bvh_block, "_cparse", cparse)
    assert bvh_block._c_continuity()


# -- the sign of zero (issue 21): "bit-identical" includes np.signbit of every component -------------------
def _same_bits(a, b) -> bool:
    """Every component the same float64 bits, and (said apart, since it is what once differed) the same
    sign of zero."""
    return all(np.array_equal(x.view(np.int64), y.view(np.int64)) and np.array_equal(np.signbit(x), np.signbit(y))
               for x, y in ((a.local_quats, b.local_quats), (a.root_positions, b.root_positions)))


def _cut_small(monkeypatch, cpus=4):
    """The fallback's block cut into many small pieces over ``cpus`` threads (another machine's cut)."""
    monkeypatch.setattr(bvh_block, "_cpus", lambda: cpus)
    monkeypatch.setattr(bvh_block, "_MIN_PIECE_BYTES", 512)
    monkeypatch.setattr(bvh_block, "_PIECE_BYTES", 2000)


@pytest.mark.parametrize("cpus", [1, 2, 4])
def test_the_sign_of_zero_does_not_depend_on_how_the_block_is_cut(monkeypatch, cpus):
    """An angle of -0 in a piece that holds an angle beyond 180 degrees: that piece was wrapped to [-180, 180]
    (a - rint(a / 360) 360, and -0 - -0 is +0), a piece without one was not, so the C path (its pieces) and
    the fallback (pieces cut by bytes and CPUs) gave quaternions differing in the sign of zero (960 of 2,000
    components here before; 24 and 5,099 on two real clips on a 4-CPU machine)."""
    head = ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
            "Yrotation\nJOINT b\n{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\nEnd Site\n{\nOFFSET 0 1 0"
            "\n}\n}\n}\n")
    rows = [f"0 0 0 {200 if f == 0 else 10} -0 -0.0 -0 5 -0" for f in range(250)]
    text = (head + "MOTION\nFrames: 250\nFrame Time: 0.01\n" + "\n".join(rows) + "\n").encode()
    whole = bvh.parse_bvh(text, "zero.bvh")       # one piece (the C path where built)
    assert np.count_nonzero(whole.local_quats == 0) >= 250    # zeros whose sign could differ
    _cut_small(monkeypatch, cpus)
    monkeypatch.setenv(bvh.NO_ACCEL_ENV, "1")
    assert _same_bits(bvh.parse_bvh(text, "zero.bvh"), whole)


@needs_c
def test_every_real_clip_reads_the_same_bits_signs_of_zero_included_however_it_is_cut(monkeypatch):
    clips = _clips()
    if not clips:
        pytest.skip(f"no clips in {DATA} or {SHARED_MOCAP} (make data writes data/*.bvh)")
    zeros = 0
    for p in clips:
        monkeypatch.delenv(bvh.NO_ACCEL_ENV, raising=False)
        accel = sn.read_bvh(p)
        q = accel.local_quats
        zeros += int(np.count_nonzero(q == 0))
        assert not np.any((q == 0) & np.signbit(q)), p        # no negative zeros: -0 components read as +0
        monkeypatch.setenv(bvh.NO_ACCEL_ENV, "1")
        assert _same_bits(sn.read_bvh(p), accel), p            # this machine's cut
        with monkeypatch.context() as m:
            _cut_small(m)
            assert _same_bits(sn.read_bvh(p), accel), p        # many small pieces on 4 threads
    if SHARED_MOCAP.is_dir() and any(SHARED_MOCAP.glob("*.bvh")):
        assert zeros > 0  # the real clips hold zero components (from -0 angles too): the comparison can fail
