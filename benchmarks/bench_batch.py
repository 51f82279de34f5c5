"""Batch throughput on Dask (issue 15): one saved session over 1,000+ short clips, serial vs 2 local worker
processes (dask.bag, multiprocessing scheduler) vs a 2-worker ``distributed.LocalCluster``, in one process run.

    nice .venv/bin/python benchmarks/bench_batch.py [--clips 1008] [--frames 24]

Clips: the real clips (../shared/mocap/*.bvh, data/*.bvh) cut into deterministic variants written to a temp
folder: ``--frames``-frame slices at evenly spaced starts, alternately as they are, time-reversed, and resampled
to 1.25x the frame time. The session: cull 50 % + succession from Hips (staggered extraction, §4, is the
expensive head). Prints clips/s of each executor and its ratio to serial (same process, same clips, so
machine load hits all alike), each worker's peak resident memory, CPU time and load average, the CPU of the
driver alone (a re-run where every clip is skipped: input hashes, output checks, manifest, reports), then the
projection to a 100-node cluster: per-frame cost measured on one full-length clip, for the CMU database
(~2,600 trials) and AMASS (~11,000 motions).
"""
from __future__ import annotations

import argparse
import glob
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ["PYTHONPATH"] = str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")  # workers import this tree

import stagger_nb as sn
from stagger_nb import batch
from stagger_nb.session import Session

OPS = [{"op": "cull", "percent": 50}, {"op": "succession", "root": "Hips", "s": 0.03, "l": 2.0}]
SHARED = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or REPO.parent / "shared" / "mocap")
DATA = Path(os.environ.get("STAGGER_NB_DATA") or REPO / "data")


def sources() -> list[Path]:
    return sorted(Path(p) for p in glob.glob(str(SHARED / "*.bvh")) + glob.glob(str(DATA / "*.bvh")))


def make_clips(folder: Path, count: int, frames: int) -> int:
    srcs = [sn.read_bvh(p) for p in sources()]
    srcs = [m for m in srcs if "Hips" in m.skeleton.names]
    per = -(-count // len(srcs))
    total = 0
    for i, m in enumerate(srcs):
        sub = folder / f"src{i:02d}"
        sub.mkdir(parents=True)
        slow = m.resample(m.frame_time * 1.25)
        for v in range(per):
            kind = v % 3
            base = slow if kind == 2 else m
            starts = np.linspace(0, max(base.num_frames - frames, 0), per).astype(int)
            clip = base.slice(int(starts[v]), int(starts[v]) + frames)
            if kind == 1:
                clip = clip.sample(np.arange(clip.num_frames)[::-1])
            sn.write_bvh(clip, sub / f"v{v:04d}.bvh")
            total += 1
    return total


def cpu_total() -> float:
    """CPU seconds of this process and of its children that have ended (the worker processes)."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + ru.ru_utime + ru.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--clips", type=int, default=1008)
    ap.add_argument("--frames", type=int, default=24)
    args = ap.parse_args()
    cpu0, t_all = time.process_time(), time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        n = make_clips(tmp / "in", args.clips, args.frames)
        session = tmp / "s.json"
        Session(sn.data.load("walk").slice(0, 30), ops=OPS).save(session)
        print(f"{n} clips of {args.frames} frames from {len(sources())} real clips; ops: cull 50 %, succession")
        rows = []
        for name, kw in [("serial (1 process)", dict(executor="serial")),
                         ("dask.bag, 2 processes", dict(executor="processes", workers=2)),
                         ("distributed.LocalCluster, 2 workers", dict(executor="distributed", workers=2))]:
            out = tmp / name.split()[0].strip(",.")
            t0, c0 = time.perf_counter(), cpu_total()
            res = batch.run_session_batch(session, tmp / "in", out, progress=False, timeout=1800, **kw)
            dt, cpu = time.perf_counter() - t0, cpu_total() - c0
            assert not res.failed, res.failed[:3]
            rows.append((name, dt, n / dt, res.worker_peak_mb, cpu))
        base = rows[0][2]
        print(f"\n{'executor':38s} {'wall s':>8s} {'clips/s':>8s} {'x serial':>8s} {'CPU s':>7s} "
              f"{'CPU/wall':>8s}  peak RSS per worker (MB)")
        for name, dt, rate, mem, cpu in rows:
            peaks = ", ".join(f"{v:.0f}" for v in sorted(mem.values()))
            print(f"{name:38s} {dt:8.1f} {rate:8.2f} {rate / base:8.2f} {cpu:7.1f} {cpu / dt:8.2f}  {peaks}")
        print("(CPU s: this process + its finished child processes; CPU/wall well under 1 per worker means the "
              "shared machine's load, not the executor, set the wall time)")
        same = all(open(p, "rb").read() == open(str(p).replace("/serial/", "/distributed.LocalCluster/"), "rb")
                   .read() for p in glob.glob(str(tmp / "serial" / "**" / "*.bvh"), recursive=True))
        print(f"distributed outputs == serial outputs byte for byte: {same}")
        # the driver alone (input hashes under the input policy, manifest checks of each output, reports): a
        # re-run over the finished serial output, where every clip is skipped; best of 3, CPU of this process
        cpu = []
        for _ in range(3):
            c0 = time.process_time()
            again = batch.run_session_batch(session, tmp / "in", tmp / "serial", executor="serial", progress=False)
            cpu.append(time.process_time() - c0)
            assert len(again.skipped) == n and not again.done
        print(f"re-run, every clip skipped (the driver alone): best {min(cpu) * 1e3:.0f} ms CPU "
              f"({min(cpu) / n * 1e3:.2f} ms a clip; a clip's edit costs {rows[0][4] / n * 1e3:.0f} ms CPU)")

        # projection: per-frame cost of one full-length clip, one worker
        long = sn.read_bvh(SHARED / "cmu_131_01_walk_startstop.bvh") if (SHARED / "cmu_131_01_walk_startstop.bvh") \
            .is_file() else sn.data.load("walk")
        t0 = time.perf_counter()
        Session(long, ops=OPS).edited()
        per_frame = (time.perf_counter() - t0) / long.num_frames
        eff = rows[2][2] / base / 2  # parallel efficiency of the 2-worker cluster on this machine
        print(f"\nfull-length clip: {long.num_frames} frames in {per_frame * long.num_frames:.1f} s "
              f"({per_frame * 1e3:.2f} ms/frame, one worker); 2-worker efficiency {eff:.2f}")
        workers = 100 * 2
        for db, trials, frames in [("CMU (~2,600 trials, ~9 h at 120 fps: ~1,500 frames each)", 2600, 1500),
                                   ("AMASS (~11,000 motions, ~42 h at 120 fps: ~1,650 frames each)", 11000, 1650)]:
            serial_h = trials * frames * per_frame / 3600
            wall_min = trials * frames * per_frame / (workers * eff) / 60
            print(f"{db}: serial {serial_h:.1f} h; 100 nodes x 2 workers at efficiency {eff:.2f}: "
                  f"{wall_min:.1f} min (>= one clip: {frames * per_frame:.0f} s)")
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"\nbenchmark wall {time.perf_counter() - t_all:.0f} s; CPU this process {time.process_time() - cpu0:.0f} s, "
          f"children {ru.ru_utime + ru.ru_stime:.0f} s; load average {os.getloadavg()}")


if __name__ == "__main__":
    main()
