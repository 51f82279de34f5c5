"""The sweep of issue "Edits an animator would keep": every clip x edit, with the contact layer off and on,
measured by sn.quality.compare against the issue's goals.

Clips: every real clip in ../shared/mocap (or STAGGER_NB_SHARED_MOCAP) and the set-up clips of data/
(cmu_01_01, walk, run, jump, mocapbank_get_down, freebvh_step), each scaled to a 170 cm body
(sn.quality.scaled). Edits (root = the pelvis unless said): ``unedited`` (the extraction itself),
``mild`` succession s=0.02 l=1 + random_timing tau=0.05, ``moderate`` (0.03, 2, 0.1), ``strong`` (0.05, 3, 0.1),
the slider extremes ``s+0.1`` / ``s-0.1`` (l=4, tau=0.15) and ``shoulder`` (root = the left shoulder, s=0.1, l=4,
tau=0.15). Layer off: ``staggered.evaluate``; on: ``staggered.keep_contacts(edited, source)`` (its defaults).
Contacts: the source's detect_contacts carried on the pelvis's timing (compare's default and the layer's: one carry,
staggered.plants_carry.carry_windows).

Columns (cm of a 170 cm body, degrees): travel (held feet inside carried contacts, against the source's own
motion), height (vs the source plant), floor (below the source's floor), pelvis (vs the source at the same
time), p-off (vs the same edit without the layer: the layer's own change), pop (added), knots (joints out of
order), detail (high-frequency energy ratio), moved (largest joint displacement vs the source), CPU (ms: the
edit, evaluation and layer; compare not included), then the failures against the edit's bounds (presets
unedited / mild / moderate / strong; the extremes are judged as strong). A failing figure is marked ``*``.
An exception is a row, not a crash.

Run: OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/bench_edit_quality.py
     [--clip SUBSTRING] [--edit NAME[,NAME]] [--layer on|off|both] [--raw] [--json PATH]
     [--derived all|VARIANT[,VARIANT]] [--derived-only]
(``--raw``: the paper's raw timing offsets, ``limit=None``, instead of the saturated default; ``--derived``:
also each clip as derived_clips.py derives it (resampled to 24 / 60 / 120 Hz, sliced mid-stance / mid-swing,
units x100 / x0.01, Z-up), named ``clip@variant``, for the held-out check's clips we have not seen).
"""
from __future__ import annotations

import argparse
import json
import os
import time
import traceback
from pathlib import Path

import derived_clips

import stagger_nb as sn
from stagger_nb import data, staggered
from stagger_nb.core.body import pelvis_joint

HERE = Path(__file__).resolve()
SHARED = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or HERE.parents[2] / "shared" / "mocap")
SETUP = ["cmu_01_01", "walk", "run", "jump", "mocapbank_get_down", "freebvh_step"]

# name: (root, s, l, tau, bounds preset); root "pelvis" / "shoulder"; None: the unedited extraction
EDITS = {
    "unedited": (None, 0.0, 1.0, 0.0, "unedited"),
    "mild": ("pelvis", 0.02, 1.0, 0.05, "mild"),
    "moderate": ("pelvis", 0.03, 2.0, 0.1, "moderate"),
    "strong": ("pelvis", 0.05, 3.0, 0.1, "strong"),
    "s+0.1": ("pelvis", 0.1, 4.0, 0.15, "strong"),
    "s-0.1": ("pelvis", -0.1, 4.0, 0.15, "strong"),
    "shoulder": ("shoulder", 0.1, 4.0, 0.15, "strong"),
}
COLS = ("travel", "height", "floor", "pelvis", "p-off", "pop", "knots", "detail", "moved")


def clips(pattern: str | None, derived=(), derived_only: bool = False):
    """(name, loader) of every clip, real ones first, each loader returning the clip scaled to a 170 cm body
    (None: a derived variant that does not apply); then ``clip@variant`` for each of ``derived``."""
    base = []
    if SHARED.is_dir():
        base += [(p.stem, (lambda p=p: sn.read_bvh(p))) for p in sorted(SHARED.glob("*.bvh"))]
    for name in SETUP:
        base.append((name, (lambda name=name: data.load(name))))
    base = [(n, (lambda f=f: sn.quality.scaled(f(), height=sn.quality.BODY_CM))) for n, f in base]
    out = [] if derived_only else list(base)
    for v in derived:
        out += [(f"{n}@{v}", (lambda f=f, v=v: derived_clips.derive(f(), v))) for n, f in base]
    return [(n, f) for n, f in out if pattern is None or pattern.lower() in n.lower()]


def shoulder_of(skeleton) -> str:
    names = skeleton.names
    for key in ("leftshoulder", "l_clavicle", "shoulder_l", "leftcollar", "lclavicle", "leftarm", "l_upperarm"):
        for n in names:
            if key in n.lower().replace("cc_base_", "").replace("mixamorig:", ""):
                return n
    return names[min(3, len(names) - 1)]


def edit(sm, skeleton, spec, raw: bool):
    root, s, l, tau, _ = spec
    if root is None:
        return sm
    joint = skeleton.names[pelvis_joint(skeleton)] if root == "pelvis" else shoulder_of(skeleton)
    limit = {"limit": None} if raw else {}
    out = staggered.succession(sm, root=joint, s=s, l=l, **limit)
    return staggered.random_timing(out, tau=tau, seed=0, **limit)


def figures(r) -> dict:
    return {"travel": r.foot_travel, "height": r.foot_height, "floor": r.floor, "pelvis": r.pelvis,
            "p-off": r.pelvis_vs_baseline, "pop": r.added_pop, "knots": len(r.knots_out_of_order or ()),
            "detail": r.detail, "moved": r.moved}


def marks(r) -> set:
    """Columns whose figure is out of the report's bounds."""
    b, bad = r.bounds, set()
    for col, value, bound in (("travel", r.foot_travel, b.travel), ("height", r.foot_height, b.height),
                              ("floor", r.floor, b.floor), ("pop", r.added_pop, b.pop), ("moved", r.moved, b.moved)):
        if bound is not None and value > bound + 1e-9:
            bad.add(col)
    pel = "p-off" if r.pelvis_vs_baseline is not None else "pelvis"
    if b.pelvis is not None and getattr(r, "pelvis_vs_baseline" if pel == "p-off" else "pelvis") > b.pelvis + 1e-9:
        bad.add(pel)
    if b.knots is not None and r.knots_out_of_order and len(r.knots_out_of_order) > b.knots:
        bad.add("knots")
    if b.detail is not None and not b.detail[0] <= r.detail <= b.detail[1]:
        bad.add("detail")
    if any("without the layer" in f for f in r.failures):
        bad.add("travel")
    return bad


def fmt(col, v, bad):
    if v is None:
        s = "-"
    elif col == "knots":
        s = f"{v:d}"
    elif col == "detail":
        s = f"{v:.2f}"
    else:
        s = f"{v:.1f}"
    return (s + ("*" if col in bad else " ")).rjust(8)


def goals_line(name):
    b = sn.quality.PRESETS[EDITS[name][4]]
    parts = [f"travel <= {b.travel:g}", f"height <= {b.height:g}", f"floor <= {b.floor:g}",
             f"pelvis (vs no layer) <= {b.pelvis:g}", f"pop <= {b.pop:g}°", "knots 0"]
    if b.moved is not None:
        parts.append(f"moved <= {b.moved:g}")
    if b.no_worse_than_baseline:
        parts.append("no more travel than without the layer")
    return f"  goals for {name} ({EDITS[name][4]}): " + ", ".join(parts)


def condensed(rows, edits):
    """The two tables quoted in reports: layer on (travel / pelvis vs no layer / added pop; unedited: moved /
    travel / pop) and the timing edit alone (added pop / knots out of order / detail); ``!`` = fails."""
    idx = {(r["clip"], r.get("edit"), r.get("layer")): r for r in rows}
    names = list(dict.fromkeys(r["clip"] for r in rows))

    def cell(fmt):
        """A table cell of a row: ``-`` without one, ``EXC`` where it raised, else ``fmt(report, row)``."""
        return lambda r: "-" if r is None else "EXC" if "error" in r else fmt(r["report"], r)

    def _on(d, r):
        p = d["pelvis_vs_baseline"] if d["pelvis_vs_baseline"] is not None else d["pelvis"]
        first = d["moved"] if r["edit"] == "unedited" else d["foot_travel"]
        second = d["foot_travel"] if r["edit"] == "unedited" else p
        return f"{first:.1f}/{second:.1f}/{d['added_pop']:.0f}" + ("" if d["ok"] else "!")

    on = cell(_on)
    off = cell(lambda d, r: f"{d['added_pop']:.1f}/{len(d['knots_out_of_order'] or ())}/{d['detail']:.2f}")

    for title, layer, fn in (("layer on: travel/pelvis vs no layer/added pop (unedited: moved/travel/pop), "
                              "! = fails its preset", "on", on),
                             ("timing edit alone (layer off): added pop/knots out of order/detail", "off", off)):
        if not any(k[2] == layer for k in idx):
            continue
        print()
        print(title)
        print(f"{'clip':26s}" + "".join(f"{e:>16s}" for e in edits))
        for c in names:
            print(f"{c[:26]:26s}" + "".join(f"{fn(idx.get((c, e, layer))):>16s}" for e in edits))


# the slider grid for the timing edit alone (layer off): every corner and interior points of the editor's
# sliders (s in [-0.1, 0.1], l in [0.25, 4], tau in [0, 0.15]), succession from the pelvis and the left shoulder,
# also scaled by a region falloff (compose's weights: a raised-cosine bump over the middle half of the poses)
GRID_S = (-0.1, -0.05, -0.02, 0.0, 0.02, 0.05, 0.1)
GRID_L = (0.25, 1.0, 2.0, 4.0)
GRID_TAU = (0.0, 0.05, 0.15)
QUICK_S, QUICK_L, QUICK_TAU = (-0.1, 0.03, 0.1), (0.25, 2.0, 4.0), (0.0, 0.15)


def _falloff(K):
    import numpy as np
    x = np.linspace(0.0, 1.0, K)
    return np.where(np.abs(x - 0.5) < 0.25, 0.5 + 0.5 * np.cos(np.pi * (x - 0.5) / 0.25), 0.0)


def grid(sm, m, raw: bool, quick: bool):
    """Worst figures of the timing edit alone over the slider grid: (cells, worst pop, its setting, joints
    with knots out of order, the worst setting for them, cells that fail their preset's pop bound)."""
    import numpy as np
    S, L, TAU = (QUICK_S, QUICK_L, QUICK_TAU) if quick else (GRID_S, GRID_L, GRID_TAU)
    prep = sn.quality.prepare(m)
    limit = {"limit": None} if raw else {}
    pel, sh = m.skeleton.names[pelvis_joint(m.skeleton)], shoulder_of(m.skeleton)
    w = _falloff(sm.num_poses)
    n, worst_pop, worst_at, worst_knots, knots_at, fails = 0, 0.0, "", 0, "", 0
    for root in (pel, sh):
        for s in S:
            for l in L:
                for tau in TAU:
                    for weights in ((None, w) if not quick or (s, tau) == (S[0], TAU[-1]) else (None,)):
                        e = staggered.succession(sm, root=root, s=s, l=l, weights=weights, **limit) if s else sm
                        if tau:
                            e = staggered.random_timing(e, tau=tau, seed=0, weights=weights, **limit)
                        T = staggered.knot_times(e)
                        bad = int((~np.all(np.diff(T, axis=0) > 0, axis=0)).sum())
                        preset = "mild" if abs(s) <= 0.02 and l <= 1 and tau <= 0.05 else (
                            "moderate" if abs(s) <= 0.03 and l <= 2 and tau <= 0.1 else "strong")
                        r = sn.quality.compare(m, staggered.evaluate(e), staggered=e, prepared=prep, bounds=preset)
                        n += 1
                        at = (f"{'pelvis' if root == pel else 'shoulder'} s={s:g} l={l:g} tau={tau:g}"
                              + (" region" if weights is not None else ""))
                        if r.added_pop > worst_pop:
                            worst_pop, worst_at = r.added_pop, at
                        if bad > worst_knots:
                            worst_knots, knots_at = bad, at
                        fails += r.added_pop > sn.quality.PRESETS[preset].pop + 1e-9 or bad > 0
    return n, worst_pop, worst_at, worst_knots, knots_at, fails


def variant_table(rows, edits):
    """Clips meeting the goals per edit (layer on; off where only off ran), one row per kind of clip: the real
    and set-up clips, then each derived variant (``clip@variant``)."""
    layer = "on" if any(r.get("layer") == "on" for r in rows) else "off"
    count: dict = {}
    for r in rows:
        if r.get("layer", layer) != layer or "edit" not in r:
            continue
        kind = r["clip"].split("@")[1] if "@" in r["clip"] else "clips"
        c = count.setdefault((kind, r["edit"]), [0, 0])
        c[1] += 1
        c[0] += "report" in r and r["report"]["ok"]
    kinds = list(dict.fromkeys(k for k, _ in count))
    print()
    print(f"clips meeting the goals per kind of clip (layer {layer}): ok/clips")
    print(f"{'kind':10s}" + "".join(f"{e:>10s}" for e in edits))
    for k in kinds:
        print(f"{k:10s}" + "".join(f"{'%d/%d' % tuple(count.get((k, e), (0, 0))):>10s}" for e in edits))


def goals_table(rows, edits):
    """The issue's goals per clip: unedited / mild / moderate / strong, layer off and on, ``pass`` or the
    failing figures (travel, height, floor, pelvis, pop, knots, moved, sliding more than without the layer)."""
    if not edits or not rows:
        return
    idx = {(r["clip"], r.get("edit"), r.get("layer")): r for r in rows}
    names = list(dict.fromkeys(r["clip"] for r in rows))
    print()
    print("the issue's goals per clip (pass, or the figures that fail the edit's bounds; EXC = exception)")
    cols = [(e, lay) for e in edits for lay in ("off", "on")]
    print(f"{'clip':26s}" + "".join(f"{e[:8] + ' ' + lay:>20s}" for e, lay in cols))
    for c in names:
        cells = []
        for e, lay in cols:
            r = idx.get((c, e, lay))
            if r is None:
                cells.append("-")
            elif "error" in r:
                cells.append("EXC")
            elif r["report"]["ok"]:
                cells.append("pass")
            else:
                words = []
                for f in r["report"]["failures"]:
                    key = ("slides more" if "without the layer" in f else
                           next((k for k in ("travel", "height", "floor", "pelvis", "pop", "knot", "moved", "detail")
                                 if k in f.lower()), f.split()[0]))
                    if key not in words:
                        words.append(key)
                cells.append("FAIL " + ",".join(words))
        print(f"{c[:26]:26s}" + "".join(f"{x[:19]:>20s}" for x in cells))


def grid_table(grid_rows, quick):
    S, L, TAU = (QUICK_S, QUICK_L, QUICK_TAU) if quick else (GRID_S, GRID_L, GRID_TAU)
    print()
    print(f"slider grid, timing edit alone (layer off): s in {S}, l in {L}, tau in {TAU}, root pelvis and left "
          "shoulder, with and without a region falloff; pop bound by the setting's preset (5/5/10 deg)")
    print(f"{'clip':26s}{'cells':>6s}{'worst pop':>10s}  {'at':44s}{'knots':>6s}  {'at':44s}{'fail':>5s}{'CPU s':>7s}")
    for name, g, cpu in grid_rows:
        if isinstance(g, str):
            print(f"{name[:26]:26s}  ERROR {g[:120]}")
            continue
        n, pop, at, knots, kat, fails = g
        print(f"{name[:26]:26s}{n:6d}{pop:10.1f}  {at[:44]:44s}{knots:6d}  {kat[:44]:44s}{fails:5d}{cpu:7.1f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--clip", help="only clips whose name contains this")
    ap.add_argument("--edit", help="comma-separated edits: " + ", ".join(EDITS))
    ap.add_argument("--layer", choices=("on", "off", "both"), default="both")
    ap.add_argument("--raw", action="store_true", help="the paper's raw timing offsets (limit=None)")
    ap.add_argument("--json", help="write every report's to_dict() here")
    ap.add_argument("--quick", action="store_true",
                    help="the four presets only and a coarse slider grid (a few minutes on every clip)")
    ap.add_argument("--grid", choices=("on", "off", "only"), default="on",
                    help="the slider-grid section for the timing edit alone (only: skip the preset sweep)")
    ap.add_argument("--derived", help="also derived clips: 'all' or variants " + ", ".join(derived_clips.VARIANTS))
    ap.add_argument("--derived-only", action="store_true", help="only the derived clips")
    a = ap.parse_args()
    derived = () if not a.derived else (derived_clips.VARIANTS if a.derived == "all"
                                         else tuple(v.strip() for v in a.derived.split(",")))
    unknown = [v for v in derived if v not in derived_clips.VARIANTS]
    if unknown:
        ap.error(f"--derived: unknown {unknown}; variants are {', '.join(derived_clips.VARIANTS)}")
    default = ["unedited", "mild", "moderate", "strong"] if a.quick else list(EDITS)
    edits = default if not a.edit else [e.strip() for e in a.edit.split(",")]
    bad = [e for e in edits if e not in EDITS]
    if bad:
        ap.error(f"--edit: unknown {bad}; edits are {', '.join(EDITS)}")
    layers = {"on": (True,), "off": (False,), "both": (False, True)}[a.layer]
    t_all = time.process_time()
    print(f"load average {os.getloadavg()[0]:.1f}; timing offsets: {'raw (limit=None)' if a.raw else 'saturated'}")
    for e in edits:
        print(goals_line(e))
    head = f"{'clip':28s} {'edit':9s} {'layer':5s}" + "".join(c.rjust(8) for c in COLS) + "   CPU ms  failures"
    print(head)
    print("-" * len(head))
    rows, tally, grid_rows = [], {}, []
    for name, load in clips(a.clip, derived, a.derived_only):
        try:
            m = load()
            if m is None:
                continue
            t = time.process_time()
            sm = staggered.extract(m)
            t_extract = time.process_time() - t
        except Exception as exc:
            print(f"{name[:28]:28s} {'-':9s} {'-':5s}  ERROR loading/extracting: {type(exc).__name__}: {exc}")
            rows.append({"clip": name, "error": f"{type(exc).__name__}: {exc}"})
            continue
        if a.grid != "off":
            t = time.process_time()
            try:
                grid_rows.append((name, grid(sm, m, a.raw, a.quick), time.process_time() - t))
            except Exception as exc:
                grid_rows.append((name, f"{type(exc).__name__}: {exc}", time.process_time() - t))
        for ename in (edits if a.grid != "only" else ()):
            spec = EDITS[ename]
            try:
                t = time.process_time()
                e = edit(sm, m.skeleton, spec, a.raw)
                off = staggered.evaluate(e)
                t_off = time.process_time() - t
            except Exception as exc:
                print(f"{name[:28]:28s} {ename:9s} {'-':5s}  ERROR in the edit: {type(exc).__name__}: {exc}")
                rows.append({"clip": name, "edit": ename, "error": f"{type(exc).__name__}: {exc}"})
                continue
            for on in layers:
                label = "on" if on else "off"
                try:
                    t = time.process_time()
                    out = staggered.keep_contacts(e, m) if on else off
                    cpu = t_off + (time.process_time() - t if on else 0.0)
                    r = sn.quality.compare(m, out, staggered=e, baseline=off if on else None, bounds=spec[4])
                except Exception as exc:
                    msg = f"{type(exc).__name__}: {exc}"
                    print(f"{name[:28]:28s} {ename:9s} {label:5s}  ERROR: {msg[:160]}")
                    rows.append({"clip": name, "edit": ename, "layer": label, "error": msg,
                                 "trace": traceback.format_exc(limit=3)})
                    tally.setdefault((ename, label), [0, 0, 0])[2] += 1
                    continue
                fig, bad_cols = figures(r), marks(r)
                cells = "".join(fmt(c, fig[c], bad_cols) for c in COLS)
                fails = "ok" if r.ok else "; ".join(r.failures)
                print(f"{name[:28]:28s} {ename:9s} {label:5s}{cells} {cpu * 1000:8.0f}  {fails[:150]}", flush=True)
                rows.append({"clip": name, "edit": ename, "layer": label, "cpu_s": cpu, "extract_s": t_extract,
                             "report": r.to_dict()})
                c = tally.setdefault((ename, label), [0, 0, 0])
                c[0 if r.ok else 1] += 1
    print()
    print("clips meeting the goals (ok / failing / exceptions):")
    for (ename, label), (ok, fail, err) in tally.items():
        print(f"  {ename:9s} layer {label:3s}: {ok:2d} ok, {fail:2d} failing, {err:2d} exceptions")
    if derived:
        variant_table(rows, edits)
    condensed(rows, edits)
    goals_table(rows, [e for e in edits if e in ("unedited", "mild", "moderate", "strong")])
    if grid_rows:
        grid_table(grid_rows, a.quick)
    print(f"total CPU {time.process_time() - t_all:.1f} s; load average {os.getloadavg()[0]:.1f}")
    if a.json:
        tmp = Path(a.json).with_suffix(".tmp")
        tmp.write_text(json.dumps(rows, indent=1))
        tmp.replace(a.json)


if __name__ == "__main__":
    main()
