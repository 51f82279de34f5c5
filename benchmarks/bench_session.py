"""Session replay cost against the number of ops (issue 13 item 5: replay must be linear).

Prints, for n edit_frame ops on the procedural walk (361 frames x 31 joints): the full replay time, the time
to replay after changing the last op, CPU time and peak RSS. The baseline is the same replay with n/4 ops in
this process: a linear replay gives a time ratio near 4, a quadratic one near 16.

    PYTHONPATH=$PWD STAGGER_NB_DATA=/work/main/data python benchmarks/bench_session.py [N]
"""
from __future__ import annotations

import os
import resource
import sys
import time

import stagger_nb as sn
from stagger_nb.session import Session


def replay(m, n):
    names = m.skeleton.names
    ops = [{"op": "edit_frame", "frame": i % m.num_frames, "deltas": {names[1 + i % 20]: [0.01, 0.0, 0.0]}}
           for i in range(n)]
    t0, c0 = time.perf_counter(), time.process_time()
    s = Session(m, ops)
    s.edited()
    full, cpu = time.perf_counter() - t0, time.process_time() - c0
    t0 = time.perf_counter()
    s.replace(-1, {"op": "edit_frame", "frame": 0, "deltas": {names[1]: [0.02, 0.0, 0.0]}})
    s.edited()
    return full, cpu, time.perf_counter() - t0


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 4000
    m = sn.data.load("walk")
    print(f"clip: {m}; load average {os.getloadavg()[0]:.1f} at start (other jobs slow every figure)")
    base = replay(m, n // 4)
    big = replay(m, n)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    for k, (full, cpu, tail) in ((n // 4, base), (n, big)):
        print(f"{k:6d} ops: full replay {full:6.2f} s wall, {cpu:6.2f} s CPU; last op changed: {1000 * tail:7.1f} ms")
    print(f"ratio {n} / {n // 4} ops: wall x{big[0] / base[0]:.1f}, CPU x{big[1] / base[1]:.1f} "
          f"(linear ~4, quadratic ~16); peak RSS {rss:.0f} MB")


if __name__ == "__main__":
    main()
