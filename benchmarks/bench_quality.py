"""How fast sn.quality.compare measures one edit (issue "Edits an animator would keep", item 3).

Targets: ``compare`` with the source's figures prepared once (``prepared=quality.prepare(source)``) costs
<= 10 ms CPU on 900 frames and <= 30 ms on CMU 01_01's 2,751 frames (31 joints, 120 Hz), warm.

The edit: succession(pelvis, s=0.02, l=1) + random_timing(tau=0.05, seed=0), then the contact layer
(``staggered.keep_contacts``), judged against the same edit without the layer (``baseline``). Rows, all in this
process on the same edit:

- ``naive reference``: tests/quality_reference.py (the first version's straightforward loops over contacts and
  joints, scipy's two Gaussian filters);
- ``compare (uncached)``: ``compare(source, edited, staggered=, baseline=)``, the source's figures computed in
  the call;
- ``prepared``: ``compare(..., prepared=prep)``: one FK of the edited motion and one of the baseline's legs;
- ``+ edited_positions``: the edited motion's FK given (the editor has it);
- ``+ baseline_positions``: both FKs given;
- ``no baseline``: ``prepared`` + ``edited_positions`` without a baseline (no keep_contacts op);
- ``prepare()``: the once-per-source part.

CPU milliseconds (``time.process_time``), the minimum over repeats (the machine is shared: the minimum is the
least noisy figure) and the median; ratios against the uncached call. ``equal`` says whether the report is the
uncached one bit for bit (``to_dict()`` equal).

Run: OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_quality.py [--repeat N] [--clip SUBSTRING]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))   # the naive reference lives beside the tests

from quality_reference import compare_reference
from timing_helpers import min_median

import stagger_nb as sn
from stagger_nb import data, quality, staggered
from stagger_nb.core.body import pelvis_joint

SHARED = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or REPO.parent / "shared" / "mocap")


def cpu_ms(fn, repeat: int) -> tuple[float, float]:
    """(minimum, median) CPU milliseconds of ``fn()`` over ``repeat`` calls after one warm-up call."""
    lo, med = min_median(fn, repeat, time.process_time)
    return 1e3 * lo, 1e3 * med


def clips(pattern):
    out = [("cmu_01_01[0:900]", lambda: data.load("cmu_01_01").slice(0, 900)),
           ("cmu_01_01", lambda: data.load("cmu_01_01")),
           ("freebvh_step (55 joints)", lambda: data.load("freebvh_step"))]
    big = sorted(SHARED.glob("iclone*.bvh")) if SHARED.is_dir() else []
    if big:
        out.append((f"{big[0].stem} (101 joints)", lambda p=big[0]: sn.read_bvh(p)))
    return [(n, f) for n, f in out if pattern is None or pattern.lower() in n.lower()]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=30)
    ap.add_argument("--clip", default=None)
    args = ap.parse_args(argv)
    print(f"# load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; CPU ms, min / median of "
          f"{args.repeat}")
    for name, load in clips(args.clip):
        m = load()
        sm = staggered.extract(m)
        root = m.skeleton.names[pelvis_joint(m.skeleton)]
        e = staggered.random_timing(staggered.succession(sm, root=root, s=0.02, l=1.0), tau=0.05, seed=0)
        out = staggered.keep_contacts(e, m)
        base = staggered.evaluate(e)
        prep = quality.prepare(m)
        ep = sn.forward_kinematics(out)[0]
        bp = sn.forward_kinematics(base)[0]
        ref = quality.compare(m, out, staggered=e, baseline=base).to_dict()
        rows = [
            ("naive reference", lambda: compare_reference(m, out, staggered=e, baseline=base), None),
            ("compare (uncached)", lambda: quality.compare(m, out, staggered=e, baseline=base), ref),
            ("prepared", lambda: quality.compare(m, out, staggered=e, baseline=base, prepared=prep), ref),
            ("+ edited_positions", lambda: quality.compare(m, out, staggered=e, baseline=base, prepared=prep,
                                                           edited_positions=ep), ref),
            ("+ baseline_positions", lambda: quality.compare(m, out, staggered=e, baseline=base, prepared=prep,
                                                             edited_positions=ep, baseline_positions=bp), ref),
            ("no baseline", lambda: quality.compare(m, out, staggered=e, prepared=prep, edited_positions=ep), None),
            ("prepare()", lambda: quality.prepare(m), None),
        ]
        print(f"\n## {name}: {m.num_frames} frames x {m.num_joints} joints at {1 / m.frame_time:.0f} Hz, "
              f"{len(prep.contacts)} contacts; {quality.compare(m, out, staggered=e, baseline=base).summary!r}")
        print(f"{'':24s} {'min ms':>8s} {'median':>8s} {'x uncached':>11s}  equal")
        base_ms = None
        for label, fn, want in rows:
            lo, med = cpu_ms(fn, args.repeat if label != "naive reference" else max(3, args.repeat // 5))
            if label == "compare (uncached)":
                base_ms = lo
            ratio = "" if base_ms is None else f"{base_ms / lo:10.1f}x"
            eq = "" if want is None else str(fn().to_dict() == want)
            print(f"{label:24s} {lo:8.2f} {med:8.2f} {ratio:>11s}  {eq}")


if __name__ == "__main__":
    main()
