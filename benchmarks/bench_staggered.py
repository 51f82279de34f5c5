"""Benchmark and report figures for staggered-pose extraction, fitting and evaluation (issue 3).

Run: ``.venv/bin/python benchmarks/bench_staggered.py`` (about a minute; ``--quick`` skips the per-clip
report). Prints, against baselines run in this process:

* extraction + fitting on CMU 01_01 (``data/cmu_01_01.bvh``; if absent, CMU 131_01 looped to 2752 frames);
* ``evaluate()`` of a 900-frame clip, against a straightforward per-joint evaluation with
  ``core.rotations.quat_bezier`` (also a correctness cross-check) and against ``Motion.sample`` (slerp);
* the paper's Nelder–Mead fitting (Appendix A, straight port) timed on a seeded subset of (segment, joint)
  pairs, extrapolated to the whole clip, as a ratio, with its accuracy next to ours on the same pairs;
* per clip (the shared clips, CMU 01_01, the procedural walk and run): mean and max angular residual of the
  spline before displacement, reconstruction error, tangent jumps at segment joins; on the walks: median distance
  (frames) from pose times to foot contact/release events.
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from stagger_nb import (
    read_bvh,
    staggered,
)
from stagger_nb.core.kinematics import skeleton_height
from stagger_nb.core.motion import concatenate
from stagger_nb.core.rotations import quat_angle, quat_bezier
from stagger_nb.staggered.extraction import locate_poses
from stagger_nb.staggered.fitting import fit_staggered
from stagger_nb.staggered.representation import knot_times
from stagger_nb.staggered.rotation_fit_c1 import velocity_jumps
from stagger_nb.staggered.sampling import sample_segments

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the naive references live beside the tests
from references import evaluate_reference, fit_rotation_tangents_nelder_mead
from timing_helpers import min_median

# ../shared/mocap and data/ beside/in the repository; STAGGER_NB_SHARED_MOCAP and STAGGER_NB_DATA point
# elsewhere (as tests/conftest.py and stagger_nb.data), e.g. from a git worktree
SHARED = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or REPO.parent / "shared" / "mocap")
DATA = Path(os.environ.get("STAGGER_NB_DATA") or REPO / "data")


def best(f, repeat=5):
    """(min, median) wall time in seconds of ``f()`` over ``repeat`` runs after one warm-up."""
    return min_median(f, repeat)


def long_clip():
    p = DATA / "cmu_01_01.bvh"
    if p.is_file():
        return read_bvh(p), "data/cmu_01_01.bvh"
    m = read_bvh(SHARED / "cmu_131_01_walk_startstop.bvh")
    reps = int(np.ceil(2752 / m.num_frames))
    return concatenate([m] * reps).slice(0, 2752), "cmu_131_01 looped to 2752 frames (cmu_01_01 absent)"


def tangent_jumps(sm):
    """Relative angular-velocity jumps |w_out - w_in| / max(|w_in|, |w_out|) at interior joins, for
    (join, joint) pairs moving faster than 0.1 rad/s."""
    jump, speed = velocity_jumps(sm)
    ok = speed > 0.1
    return jump[ok] / speed[ok]


def foot_event_distance(sm, m):
    ev = foot_events(sm.contacts, m.num_frames)
    if ev.size == 0:
        return float("nan"), 0
    frames = np.rint(sm.pose_times / m.frame_time).astype(int)[1:-1]
    return float(np.median(np.abs(frames[:, None] - ev[None]).min(axis=1))), ev.size


def main(quick=False):
    import os
    m, label = long_clip()
    ref = np.random.default_rng(1).uniform(size=1_000_000)
    t_ref, _ = best(lambda: np.sqrt(ref) * ref + ref, 5)
    print(f"# staggered-poses benchmark   clip: {label}: {m}")
    print(f"# machine: load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; reference numpy op "
          f"(sqrt*x+x on 1e6 floats) {1e3 * t_ref:.2f} ms: figures below are wall time, min over runs")

    # -- extraction + fitting --------------------------------------------------------------------
    t_ext, t_ext_med = best(lambda: staggered.extract(m), 3)
    t_loc, _ = best(lambda: locate_poses(m), 3)
    sm = staggered.extract(m)
    print(f"extract (locate + fit), all candidates: {t_ext:.3f} s (median {t_ext_med:.3f} s) "
          f"[target <= 2 s]; locate only {t_loc:.3f} s; K = {sm.num_poses} poses")
    out = staggered.evaluate(sm)
    print(f"  reconstruction: max {quat_angle(m.local_quats, out.local_quats).max():.2e} rad, root "
          f"{np.abs(out.root_positions - m.root_positions).max() / skeleton_height(m):.2e} x height")

    # -- Nelder–Mead straight port on a subset, extrapolated ---------------------------------------
    J = m.num_joints
    ft = m.frame_time
    knots = knot_times(sm)
    pair, mm, counts, tn, frames = sample_segments(knots, ft)
    P = counts.size
    c0 = fit_staggered(m, sm.pose_times, sm.refinements, sm.root_refinements, continuity="C0")
    rng = np.random.default_rng(0)
    subset = np.sort(rng.choice(P, size=min(12, P), replace=False))
    nm_time, nm_res, our_res = 0.0, [], []
    for p in subset:
        sel = pair == p
        q = m.local_quats[np.rint(frames[sel]).astype(int), p % J]
        t0 = time.perf_counter()
        tang = fit_rotation_tangents_nelder_mead(tn[sel], q, q[0], q[-1])
        nm_time += time.perf_counter() - t0
        k, i = divmod(p, J)
        s_nm = quat_bezier(q[0], tang[0], tang[1], q[-1], tn[sel])
        s_us = quat_bezier(c0.values[k, i], c0.tangents[k, i, 0], c0.tangents[k, i, 1], c0.values[k + 1, i], tn[sel])
        nm_res.append(quat_angle(s_nm, q)[1:-1])
        our_res.append(quat_angle(s_us, q)[1:-1])
    t_fit, _ = best(lambda: fit_staggered(m, sm.pose_times, sm.refinements, sm.root_refinements), 3)
    t_fit0, _ = best(lambda: fit_staggered(m, sm.pose_times, sm.refinements, sm.root_refinements,
                                           continuity="C0"), 3)
    nm_total = nm_time / subset.size * P
    print(f"fit only, all {P} segment-joint pairs: C1 (default) {t_fit:.3f} s, mean residual "
          f"{sm.metadata['fit']['mean_residual_rad']:.4f} rad; C0 per-segment {t_fit0:.3f} s, mean residual "
          f"{c0.metadata['fit']['mean_residual_rad']:.4f} rad")
    print(f"Nelder-Mead port (App. A, w_f = 1000 w_c, scipy defaults): {nm_time / subset.size:.3f} s per pair on "
          f"{subset.size} pairs -> {nm_total:.0f} s extrapolated to {P} pairs; "
          f"ratio NM / ours(C0) = {nm_total / t_fit0:.0f}x, "
          f"NM / ours(C1) = {nm_total / t_fit:.0f}x")
    a, b = np.concatenate(nm_res), np.concatenate(our_res)
    print(f"  same pairs, same per-segment problem, mean residual angle: NM {a.mean():.5f} rad, "
          f"ours (C0) {b.mean():.5f} rad "
          f"(RMS {np.sqrt((a ** 2).mean()):.5f} vs {np.sqrt((b ** 2).mean()):.5f})")

    # -- evaluate() of a 900-frame clip ---------------------------------------------------------------
    m9 = m.slice(0, 900)
    sm9 = staggered.extract(m9)
    ts = m9.times
    t_ev, t_ev_med = best(lambda: staggered.evaluate(sm9), 30)
    t_naive, _ = best(lambda: evaluate_reference(sm9, ts), 3)
    t_sample, _ = best(lambda: m9.sample(np.arange(900) * 0.999), 30)
    diff = quat_angle(evaluate_reference(sm9, ts), staggered.evaluate(sm9).local_quats).max()
    print(f"evaluate() 900 frames x {J} joints, K = {sm9.num_poses}: {1e3 * t_ev:.2f} ms (median "
          f"{1e3 * t_ev_med:.2f} ms) [target <= 10 ms]")
    print(f"  baselines: naive per-joint core.quat_bezier {1e3 * t_naive:.1f} ms (ratio {t_naive / t_ev:.1f}x, "
          f"max diff {diff:.1e} rad); Motion.sample (slerp only) {1e3 * t_sample:.2f} ms (ratio {t_ev / t_sample:.2f})")

    print(f"# load average at the end of timing: {os.getloadavg()[0]:.1f}")
    if quick:
        return
    # -- per clip report ----------------------------------------------------------------------------
    print("\nclip                              F    K  Kcull50  residual C1 / C0 (rad)  recon(rad)  |r|max(s)  "
          "velocity jump at joins C1 | C0 (median rel.)  max residual C1 / C0 (deg)")
    from stagger_nb import data
    clips = ([(p.name, read_bvh(p)) for p in sorted(SHARED.glob("*.bvh"))] + [(label.split(":")[0], m)]
             + [(f"procedural {n} (60 Hz)", data.load(n)) for n in ("walk", "run")])
    for name, mo in clips:
        s = staggered.extract(mo)
        e = quat_angle(mo.local_quats, staggered.evaluate(s).local_quats).max()
        s0 = fit_staggered(mo, s.pose_times, s.refinements, s.root_refinements, continuity="C0")
        j1, j0 = tangent_jumps(s), tangent_jumps(s0)
        jj = f"{np.median(j1):.1e} | {np.median(j0):.2f}" if j1.size else "n/a"
        print(f"{name[:32]:32s} {mo.num_frames:5d} {s.num_poses:4d} {staggered.cull(s, 50).num_poses:6d}   "
              f"{s.metadata['fit']['mean_residual_rad']:.4f} / {s0.metadata['fit']['mean_residual_rad']:.4f}        "
              f"{e:.1e}    {np.abs(s.refinements).max():.3f}"
              f"      {jj:24s}  {np.degrees(s.metadata['fit']['max_residual_rad']):5.1f} / "
              f"{np.degrees(s0.metadata['fit']['max_residual_rad']):5.1f}")

    print("\npose times vs foot contact/release events (median distance in frames over interior poses)")
    for name in ("cmu_131_01_walk_startstop.bvh", "xia_neutral_walk.bvh"):
        mo = read_bvh(SHARED / name)
        full = staggered.extract(mo)
        d_all, nev = foot_event_distance(full, mo)
        d_half, _ = foot_event_distance(staggered.cull(full, 50), mo)
        no_c = staggered.extract(mo, contacts=[])
        d_noc, _ = foot_event_distance(dataclass_with_contacts(no_c, full.contacts), mo)
        K = full.num_poses
        uni = np.rint(np.linspace(0, mo.num_frames - 1, K)).astype(int)[1:-1]
        feet = foot_events(full.contacts, mo.num_frames)
        d_uni = float(np.median(np.abs(uni[:, None] - feet[None]).min(axis=1)))
        print(f"  {name}: {nev} events; all {K} candidates {d_all:.1f} frames; culled 50% {d_half:.1f}; "
              f"without contact evidence {d_noc:.1f}; uniform {K} poses (reference) {d_uni:.1f}  "
              f"[{mo.frame_time * 1e3:.2f} ms/frame]")


def foot_events(contacts, F):
    import re
    feet = [(a, b) for n, a, b in contacts if re.search("foot|toe|ankle|heel", n, re.I)]
    return np.array(sorted({a for a, _ in feet} | {b for _, b in feet if b < F}))


def dataclass_with_contacts(sm, contacts):
    import dataclasses
    return dataclasses.replace(sm, contacts=contacts)


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
