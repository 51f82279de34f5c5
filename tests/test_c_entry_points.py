"""The C entry points (``io/_cparse.c``, ``staggered/_cspline.c``, ``timewarp/_cdp.c``) called directly with hostile
sizes, shapes, dtypes and values (issue 21): each call returns or raises ValueError / TypeError, and never crashes the
interpreter. No public call reaches them with such arguments; a C function must check what it indexes anyway.

Each batch of calls runs in a forked child that announces every call before making it, so a crash (SIGSEGV,
SIGFPE) fails the test naming the call; a child still running after 120 s is killed. Before: the size check of
``rotations_block`` (``(3 * so + n) * 8``) overflowed into an out-of-bounds write, and ``make_continuous(q,
2**62)`` divided by ``4 * joints`` wrapped to zero."""
from __future__ import annotations

import os

import numpy as np
import pytest
from conftest import run_forked

from stagger_nb.io import bvh_block
from stagger_nb.staggered import _kernels
from stagger_nb.timewarp import dp

cparse = bvh_block._cparse
cspline = _kernels._cspline
needs_c = pytest.mark.skipif(cparse is None or cspline is None, reason="the C extensions are not built here")

BIG = [2**62, 2**63 - 1, -2**63, 2**61 + 1, 2**31, -1, 0, 1]
OK_ERRORS = ("ValueError", "TypeError")


def run_calls(calls, timeout=120) -> dict:
    """``{outcome: count}`` of ``calls`` (``(description, thunk)``) run in a forked child; fails the test when
    the child dies or hangs, naming the call it was making."""
    def body(send):
        for k, (_, thunk) in enumerate(calls):
            send(f"call {k}\n")
            try:
                thunk()
                outcome = "ok"
            except Exception as e:
                outcome = type(e).__name__
            send(f"done {k} {outcome}\n")
    text, status = run_forked(body, timeout)
    lines = text.splitlines()
    if os.WIFSIGNALED(status) or not lines or not lines[-1].startswith(f"done {len(calls) - 1} "):
        last = next((int(ln.split()[1]) for ln in reversed(lines) if ln.startswith("call ")), None)
        pytest.fail(f"the child died (status {status}) during "
                    f"{calls[last][0] if last is not None else 'before the first call'}")
    counts: dict = {}
    for ln in lines:
        if ln.startswith("done "):
            counts[ln.split()[2]] = counts.get(ln.split()[2], 0) + 1
    return counts


# -- rotations_block ----------------------------------------------------------------------------------------
def _valid_block(P=3, M=4, n=5, seed=0):
    rng = np.random.default_rng(seed)
    ctrl = rng.normal(size=(16, P))
    ctrl /= np.linalg.norm(ctrl.reshape(4, 4, P), axis=1).repeat(4, axis=0)
    return dict(stage=0, ctrl=ctrl, arcp=np.abs(rng.normal(size=(9, P))) % 1.0,
                table=rng.normal(size=(3, P * M)) * 0.1, counts=np.full(P, M, np.int64), M=M,
                idx=rng.integers(0, P, n).astype(np.int64), t=rng.uniform(0, 1, n), out=np.zeros((4, n)), so=n,
                work=np.zeros((56, n)), taylor=_kernels._TAYLOR_ARR.copy(), limits=_kernels._LIMITS_ARR.copy())


ORDER = ["stage", "ctrl", "arcp", "table", "counts", "M", "idx", "t", "out", "so", "work", "taylor", "limits"]


def _block_call(kw):
    return lambda: cspline.rotations_block(*[kw[k] for k in ORDER])


def _mutations(rng, kw):
    """One or two hostile changes to valid arguments."""
    out = dict(kw)
    for _ in range(rng.integers(1, 3)):
        key = ORDER[rng.integers(len(ORDER))]
        v = kw[key]
        choice = rng.integers(8)
        if key == "stage":  # a C int: a Python int beyond it is CPython's OverflowError, not ours to check
            out[key] = int(rng.choice([-1, 3, 4, 7, 2**31 - 1, -2**31]))
        elif key in ("M", "so"):
            out[key] = int(rng.choice(BIG + [4, 3, 2, kw["so"] - 1, 2**61, 2**60 // 3]))
        elif v.size == 0:
            out[key] = np.ones(3, v.dtype)
        elif choice == 0:
            out[key] = v.astype(np.float32) if v.dtype == np.float64 else v.astype(np.int32)
        elif choice == 1:
            out[key] = v.reshape(-1)[:-1] if v.size else np.zeros(1)
        elif choice == 2:
            out[key] = np.zeros((v.shape[0], 2 * v.shape[-1] + 2), v.dtype)[:, ::2] if v.ndim == 2 else v[::2]
        elif choice == 3:
            ro = v.copy()
            ro.setflags(write=False)
            out[key] = ro
        elif choice == 4:
            out[key] = v.tobytes()
        elif choice == 5:
            out[key] = None
        elif choice == 6 and v.dtype == np.int64:
            bad = v.copy()
            bad.reshape(-1)[rng.integers(bad.size)] = rng.choice(BIG + [kw["M"] + 1, len(kw["counts"])])
            out[key] = bad
        else:
            bad = np.array(v, dtype=float)
            bad.reshape(-1)[rng.integers(bad.size)] = rng.choice([np.nan, np.inf, -np.inf, -1.0, -0.5, 2.0, 1e300,
                                                                 -1e300, 4.7e18])
            with np.errstate(invalid="ignore"):
                out[key] = bad if v.dtype == np.float64 else bad.astype(np.int64)
    return out


@needs_c
def test_rotations_block_with_hostile_arguments_raises_or_returns_never_crashes():
    rng = np.random.default_rng(21)
    calls = []
    for M in (0, 4):
        base = _valid_block(M=M) if M else dict(_valid_block(M=4), M=0, table=np.zeros((3, 0)))
        calls.append((f"valid M={M}", _block_call(base)))
        for k in range(1500):
            kw = _mutations(rng, base)
            calls.append((f"M={M} mutation {k}: " + ", ".join(f"{n}={_short(kw[n])}" for n in ORDER
                                                              if kw[n] is not base[n]), _block_call(kw)))
    counts = run_calls(calls)
    assert set(counts) <= {"ok", *OK_ERRORS}, counts
    assert counts.get("ValueError", 0) > 500 and counts.get("TypeError", 0) > 300 and counts.get("ok", 0) >= 2


def _short(v):
    if isinstance(v, np.ndarray):
        return f"array{v.shape}{v.dtype}{'' if v.flags.writeable else ' readonly'}"
    return repr(v)[:40]


@needs_c
@pytest.mark.parametrize("change", ["so overflows 3 so + n", "so = 2**62", "M overflows P M 24", "t NaN",
                                    "t negative", "idx -1", "count 2**62", "stage 7", "t float32", "out readonly"])
def test_the_issue_cases_are_refused(change):
    kw = _valid_block()
    if change == "so overflows 3 so + n":
        kw["so"] = (2**63 - 1) // 3 + 1          # 3 so + n wraps negative: the old check passed, then wrote
    elif change == "so = 2**62":
        kw["so"] = 2**62
    elif change == "M overflows P M 24":
        kw["M"] = 2**64 // (24 * 3) + 1           # P M 24 wraps
    elif change == "t NaN":
        kw["t"][2] = np.nan
    elif change == "t negative":
        kw["t"][2] = -3.0                         # (int64)(t (M - 1)) < 0: a read before the table
    elif change == "idx -1":
        kw["idx"][0] = -1
    elif change == "count 2**62":
        kw["counts"][0] = 2**62
    elif change == "stage 7":
        kw["stage"] = 7
    elif change == "t float32":
        kw["t"] = kw["t"].astype(np.float32)
    else:
        kw["out"].setflags(write=False)
    (outcome,) = run_calls([(change, _block_call(kw))])
    assert outcome in OK_ERRORS and (outcome == "TypeError") == (change in ("t float32", "out readonly"))


# -- _cparse ------------------------------------------------------------------------------------------------
@needs_c
def test_make_continuous_with_hostile_arguments_raises_or_returns_never_crashes():
    arrays = [np.zeros(8), np.zeros(0), np.zeros(4), np.zeros(12), np.zeros((5, 3, 4)), np.zeros(8, np.float32),
              np.zeros(8, np.int64), np.zeros((4, 4))[:, ::2], np.zeros(8).tobytes(), bytearray(64), None,
              np.zeros(8, ">f8")]
    ro = np.zeros(8)
    ro.setflags(write=False)
    arrays.append(ro)
    calls = [(f"make_continuous({_short(a)}, {j})", (lambda a=a, j=j: cparse.make_continuous(a, j)))
             for a in arrays for j in BIG + [2, 3, 5]]
    counts = run_calls(calls)
    assert set(counts) <= {"ok", *OK_ERRORS}, counts
    got = run_calls([("2**62 joints", lambda: cparse.make_continuous(np.zeros(8), 2**62))])
    assert got == {"ValueError": 1}


@needs_c
def test_parse_rows_and_quats_from_tangents_with_hostile_arguments_never_crash():
    rng = np.random.default_rng(7)
    text = b"1 2 3\n4 5 6\n7 8 9\n"
    calls = []
    for _ in range(2000):
        C, rows = 3, int(rng.choice([3, 1, 0, -1, 2**62, 2**63 - 1]))
        out = np.zeros(int(rng.choice([9, 0, 1, 8])))
        base = np.array(rng.choice([0, 1, 2, -1, 8, 9, 2**62, -2**63], size=C), np.int64)
        stride = np.array(rng.choice([3, 1, 0, -1, 2**61, 2**62, 2**63 - 1], size=C), np.int64)
        start, stop = (int(rng.choice([0, 1, -1, len(text), len(text) + 1, 2**62])) for _ in range(2))
        if rng.integers(4) == 0:
            base = base.astype(np.int32)
        calls.append((f"parse_rows(start={start}, stop={stop}, rows={rows}, out={out.size}, base={base}, "
                      f"stride={stride})",
                      lambda s=start, e=stop, r=rows, o=out, b=base, st=stride:
                      cparse.parse_rows(text, s, e, r, o, b, st)))
    for axes in ("ZXY", "", "XX", "XYZW", "X\0Z", "\xc9XY", "xyz", "ZZZ"):
        for n_t, n_o in ((3, 1), (6, 2), (3, 2), (0, 0), (2, 1)):
            for dtype in (np.float64, np.float32):
                calls.append((f"quats_from_tangents({axes!r}, t {n_t} {dtype.__name__}, out {n_o})",
                              lambda a=axes, t=np.zeros(n_t, dtype), o=np.zeros((n_o, 4)):  # noqa: B008
                              cparse.quats_from_tangents(t, a, o)))
    counts = run_calls(calls)
    assert set(counts) <= {"ok", *OK_ERRORS}, counts
    assert counts.get("ok", 0) > 0 and counts.get("ValueError", 0) > 1000


# -- _cdp ---------------------------------------------------------------------------------------------------
DP_ORDER = ["Sab", "n", "s", "lo", "hi", "q0", "q1", "cur", "wmax", "back", "offsets"]


def _valid_forward(n=12, m=6, s=3):
    lo, hi = dp.warp_bounds(n, m, s)
    widths = hi - lo + 1
    sizes = np.zeros(m, np.int64)
    sizes[1:m - 1] = widths[1:m - 1] * s
    wmax = int(widths.max())
    return dict(Sab=np.random.default_rng(0).random((s, s, n)), n=n, s=s, lo=lo, hi=hi, q0=1, q1=m - 1,
                cur=np.zeros((s, wmax)), wmax=wmax, back=np.zeros(int(sizes.sum()), np.int8),
                offsets=np.cumsum(sizes) - sizes)


@pytest.mark.skipif(dp._cdp is None, reason="the C extension timewarp._cdp is not built here")
def test_the_dp_forward_pass_with_hostile_arguments_raises_or_returns_never_crashes():
    """Sizes that do not match, bands past the input, the buffer or the scratch width, offsets past the
    backpointers, wrong dtypes, read-only or strided buffers: ValueError / TypeError, never a crash."""
    rng = np.random.default_rng(26)
    base = _valid_forward()
    calls = [("valid", lambda: dp._cdp.forward(*[base[k] for k in DP_ORDER]))]
    for k in range(1500):
        kw = dict(base)
        for _ in range(rng.integers(1, 3)):
            key = DP_ORDER[rng.integers(len(DP_ORDER))]
            v = base[key]
            if isinstance(v, int):
                kw[key] = int(rng.choice(BIG + [v - 1, v + 1, 2, 127, 128]))
            elif rng.integers(5) == 0:
                kw[key] = rng.choice([None, "x", v.tobytes() if hasattr(v, "tobytes") else None])
            elif rng.integers(4) == 0:
                ro = v.copy()
                ro.setflags(write=False)
                kw[key] = [v.astype(np.float32) if v.dtype == np.float64 else v.astype(np.int32), ro,
                           v.reshape(-1)[::2], v.reshape(-1)[:-1]][rng.integers(4)]
            else:
                bad = v.copy()
                if bad.dtype == np.int64:   # a band, a size or an offset past what it indexes
                    bad.reshape(-1)[rng.integers(bad.size)] = rng.choice(BIG + [base["n"], base["wmax"] + 1])
                kw[key] = bad
        calls.append((f"mutation {k}: " + ", ".join(f"{n}={_short(kw[n])}" for n in DP_ORDER if kw[n] is not base[n]),
                      lambda kw=kw: dp._cdp.forward(*[kw[n] for n in DP_ORDER])))
    counts = run_calls(calls)
    assert set(counts) <= {"ok", *OK_ERRORS}, counts
    assert counts.get("ValueError", 0) > 300 and counts.get("TypeError", 0) > 100 and counts.get("ok", 0) >= 1
