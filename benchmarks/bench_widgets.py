"""Kernel-side latency of the editors: a model trait change (what a slider move does) to the return of the last
view update it caused, warm (every value visited once before timing).

Targets (issue 11): every StaggerEditor / WarpEditor slider <= 50 ms warm on 900 frames, σ <= 100 ms on 600 frames;
first paint of a StaggerEditor on CMU 01_01 (2,751 frames) <= 2 s; first visits of the cull slider <= 100 ms on
900 frames.

Baseline, same process: the bare session replay of the same op lists (a second Session, warmed the same way, no
views): ``views/bare`` is what the editor adds (``views cpu`` = editor CPU - bare replay CPU: the 3D view's
``set_motion``, the plots and the controls); ``memo``: the same values revisited, the replay answered by the
session's memo, i.e. the views' own CPU measured directly. Wall and CPU time (``time.process_time``) are
printed with the load average: the machine is shared, so the wall figures move with the load.

Run: ``nice .venv/bin/python benchmarks/bench_widgets.py`` (uses data/cmu_01_01.bvh).
"""
from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.widgets import StaggerEditor, WandEditor, WarpEditor


def timed(fn):
    w, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w, time.process_time() - c


def sweep(editor, name, warm_values, values, bare: Session):
    """``warm_values`` set once (fills the heads: extraction, cull, pose graph, tables), then each of ``values``
    (not visited before, so the session's memo of whole op lists does not answer) timed; the bare session
    replays the same op lists, warmed the same way."""
    for v in warm_values:
        setattr(editor.model, name, v)
        bare.set_ops(editor.session.ops)
        bare.edited()
    ed, cpu, base = [], [], []
    for v in values:
        w, c = timed(lambda: setattr(editor.model, name, v))
        ed.append(w)
        cpu.append(c)
        bare.set_ops(editor.session.ops)
        base.append(timed(bare.edited))
    assert not editor.error, editor.error
    # the same values again: the session's memo of whole op lists answers, so this is the views' own cost
    # (3D view, plots, controls, message), measured directly rather than as editor minus bare replay
    memo = [timed(lambda: setattr(editor.model, name, v))[1] for v in values[:-1]]   # each a change
    return ed, cpu, base, memo


def report(label, ed, cpu, base, memo, target_ms):
    """Wall median/max and CPU median of the editor; the bare replay's wall and CPU; the ratio on CPU (the load
    of the shared machine inflates wall times, CPU much less); ``views (memo)``: the CPU median of revisiting
    the same values (replay answered from the session's memo: the views alone); the target judged on CPU."""
    med, worst = 1000 * statistics.median(ed), 1000 * max(ed)
    cmed = 1000 * statistics.median(cpu)
    bmed, bcpu = 1000 * statistics.median([w for w, _ in base]), 1000 * statistics.median([c for _, c in base])
    ok = "OK" if cmed <= target_ms else "MISSED"
    print(f"{label:<36} wall {med:7.1f} ms (max {worst:7.1f}) cpu {cmed:6.1f} | bare replay wall {bmed:7.1f} "
          f"cpu {bcpu:6.1f} | views cpu {cmed - bcpu:6.1f} (memo {1000 * statistics.median(memo):5.1f}) | "
          f"editor/bare cpu x{cmed / max(bcpu, 1e-3):5.1f} | load {os.getloadavg()[0]:4.1f} | "
          f"target <= {target_ms} ms cpu: {ok}")
    return cmed


def main():
    full = sn.data.load("cmu_01_01")
    m900, m600 = full.slice(0, 900), full.slice(0, 600)
    print(f"clip: cmu_01_01 {full}; sliders on {m900.num_frames} and {m600.num_frames} frames")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at start")

    # -- first paint on the whole clip ------------------------------------------------------------------
    w, c = timed(lambda: globals().__setitem__("_e", StaggerEditor(full)))
    e = globals().pop("_e")
    print(f"StaggerEditor first paint, {full.num_frames} frames: {w:.2f} s wall, {c:.2f} s cpu "
          f"(target <= 2 s: {'OK' if w <= 2 else 'MISSED'})")
    close(e)

    # -- StaggerEditor sliders, 900 frames ---------------------------------------------------------------
    e = StaggerEditor(m900, precompute=False)
    # the sliders are timed with the contact layer on (issue 20: "<= 50 ms with the layer on"), whatever the
    # editor's default (off since the layer does not yet meet the figures on every clip)
    e.model.keep_contacts = "keep_contacts" in _known_ops(e.session)
    cold = []
    for pc in (50.0, 30.0, 70.0):
        cold.append(timed(lambda: setattr(e.model, "percent", pc)))
    first_visits("cull % first visits (900 fr)", cold)
    bare = Session(m900)
    e.model.percent = 60.0
    e.model.s = 0.03
    results = {}
    for name, warm, values in [("l", [1.1], [1.25, 1.5, 2.0, 2.5, 3.0]), ("s", [0.035], [0.01, 0.02, 0.04, 0.05]),
                               ("tau", [0.005], [0.01, 0.02, 0.04, 0.06]), ("seed", [9], [1, 2, 3, 4]),
                               ("w_r", [0.1], [0.2, 0.4, 0.6]), ("frame", [5], [10, 200, 400, 800])]:
        results[name] = report(f"StaggerEditor {name} (900 fr)", *sweep(e, name, warm, values, bare), 50)
    # cull: every slider position cached first (what the editor's warm-up does), then visited anew
    pcs = [80.0, 65.0, 40.0, 20.0]
    warm_cull = getattr(e.session, "precompute_cull", None)
    if warm_cull is not None:
        warm_cull(pcs)
        bare.precompute_cull(pcs)
    results["percent"] = report("StaggerEditor percent (900 fr, warm)", *sweep(e, "percent", [], pcs, bare), 50)
    close(e)

    # -- cull first visits after the editor's own warm-up (precompute=True: refits, then the replay of the
    # current edit at every position), on a fresh editor; the warm-up's CPU is waited for and not counted
    e = StaggerEditor(m900)
    w0, c0 = time.perf_counter(), time.process_time()
    for f in e.warm_futures:
        f.result()
    print(f"{'  editor warm-up (900 fr)':<34} {time.perf_counter() - w0:.2f} s wall, "
          f"{time.process_time() - c0:.2f} s cpu (background, after first paint)")
    warm = []
    for pc in (50.0, 30.0, 70.0):
        warm.append(timed(lambda: setattr(e.model, "percent", pc)))
    first_visits("cull % first visits after warm-up", warm)
    close(e)

    # -- WandEditor: sigma on 600 frames --------------------------------------------------------------
    w = WandEditor(m600, frame=300, joint="LeftUpLeg", rotation=(20.0, 0.0, 0.0), precompute=False)
    bare = Session(m600)
    grid = [float(x) for x in w.model.sigma_grid[10:20:2]]
    warm_bases = getattr(w.session, "precompute_wand_bases", None)
    if warm_bases is not None:
        warm_bases(grid)
        bare.precompute_wand_bases(grid)
    results["sigma"] = report("WandEditor sigma (600 fr, warm)", *sweep(w, "sigma", [], grid, bare), 100)
    results["rx"] = report("WandEditor rotate x (600 fr)", *sweep(w, "rx", [], [5.0, 10.0, 15.0, 25.0], bare), 50)
    results["edit_frame"] = report("WandEditor edit_frame (600 fr)",
                                   *sweep(w, "edit_frame", [], [200, 250, 350, 400], bare), 50)
    close(w)

    # -- WarpEditor: duration, skip on 900 frames -------------------------------------------------------
    r = WarpEditor(m900)
    for f in r.warm_futures:   # the editor's warm-up (its skip slider's tables) runs after first paint: let it
        f.result()           # finish, or its CPU (process-wide) is counted in the first moves
    bare = Session(m900)
    D = m900.duration
    results["duration"] = report("WarpEditor duration (900 fr)",
                                 *sweep(r, "duration", [0.5 * D], [0.6 * D, 0.7 * D, 0.8 * D, 0.9 * D], bare), 50)
    # skip: the editor warms its slider's largest skip on open (smaller skips are sliced from it); the bare
    # session is warmed the same way (Session.warm), then each skip is visited anew
    for f in r.warm_futures:
        f.result()
    ops = [o for o in r.session.ops if o["op"] == "guided_warp"]
    op = dict(ops[-1]) if ops else {"op": "guided_warp", "duration": r.model.duration}
    bare.warm(("warp_tables", [dict(op, skip=16)])).result()
    results["skip"] = report("WarpEditor skip (900 fr, warm)", *sweep(r, "skip", [], [4, 6, 10, 12], bare), 50)
    close(r)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return results


def close(editor):
    """Close ``editor`` and wait until its session's running warm-up item has finished, so it is not counted
    in the next figures (an older session without ``close(wait=...)``: not waited for)."""
    editor.close()
    try:
        editor.session.close(wait=True)
    except TypeError:
        pass


def first_visits(label, times):
    """Wall and CPU of each first visit; the target (<= 100 ms) judged on CPU (wall moves with the load)."""
    cpu = max(c for _, c in times)
    print(f"{label:<34} wall {', '.join(f'{1000 * w:.0f}' for w, _ in times)} ms | cpu "
          f"{', '.join(f'{1000 * c:.0f}' for _, c in times)} ms | load {os.getloadavg()[0]:4.1f} | "
          f"target <= 100 ms cpu: {'OK' if cpu <= 0.1 else 'MISSED'}")


def _known_ops(session):
    try:
        from stagger_nb.session import OPS
        return set(OPS)
    except ImportError:   # an older session package: every op of the contract is known
        return {"keep_contacts"}


if __name__ == "__main__":
    main()
