"""Slider key press -> first change of the plot's DOM and of the 3D view, in Chromium, measured in the page's clock.

Set-up (issue 22 item 3): headless Chromium at 1280x800, JupyterLab with the file browser open, two CPU-bound
processes started beside it (``--burners``, default 2), a StaggerEditor on CMU 01_01 (data/cmu_01_01.bvh, 2,751
frames, the editor's defaults) scrolled to its top, its warm-up finished. For each slider (``--sliders``,
default the cull %, s, τ and w_r sliders) the handle is focused and ``--presses`` (default 32) arrow-key presses
are made one at a time; for each press the page records, with ``performance.now()``:

- ``key``: the keydown (capture listener on the document);
- ``send``: the first websocket message the page sends after it (the slider's new value to the kernel);
- ``recv``: the first message the page receives after that (the kernel's first answer);
- ``figure``: the first plot's new figure arriving (``PlotView``'s ``data-figure-at``), ``react``: how long
  its ``Plotly.react`` took (``data-react-ms``), or ``fast``: its fast redraw (new x/y of line traces written
  into their SVG paths on the drawn axes, ``data-fast-ms``; the Plotly.react follows once the figure rests);
- ``plot``: the first mutation inside the first plot's plotly element (a MutationObserver: what a user sees);
- ``data3d``: the 3D view's new points arriving (the conductor's ``data-data-at``: the shown frame's points,
  ``SkeletonView.preview``, sent before the clip's), ``gl``: the first WebGL draw call after it
  (``drawElements`` / ``drawArrays`` wrapped by an init script): the 3D view redrawn;

then waits until the kernel is idle and every plot shows its store's figure before the next press. The kernel
side is timed too (the editor's replay ``session.edited`` and its ``_update_views``, wrapped in the notebook:
wall and CPU ms per press). Printed: median / p90 / max of key->plot and key->3D per slider, and the median of
each step (where the time goes), the load average; ``--json PATH`` writes every sample.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/browser_latency.py`` (needs /usr/bin/chromium and
playwright; about 3-6 minutes). ``--prepare cull=19,s=20 --sliders tau,w_r`` times the τ and w_r sliders from the
state the default run reaches them in (cull 5 %, s 0.1), without the cull and s presses that change nothing. The
burners are this script's own child processes, stopped by their pids.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
import browser_harness as bh

SLIDERS = {"cull": (".sn-cull", "ArrowLeft"), "s": (".sn-s", "ArrowRight"), "tau": (".sn-tau", "ArrowRight"),
           "w_r": (".sn-w-r", "ArrowRight")}

# wraps the WebGL draw calls and the page's websocket before any page script runs
INIT = """(() => {
  const W = window.__snLat = { key: null, send: null, recv: null, plot: null, gl: null, draws: 0, armed: false };
  for (const C of [window.WebGLRenderingContext, window.WebGL2RenderingContext]) {
    if (!C) continue;
    for (const f of ['drawElements', 'drawArrays']) {
      const orig = C.prototype[f];
      C.prototype[f] = function (...a) {
        W.draws++;
        if (W.armed && W.gl === null && W.cond && W.cond.dataset.dataAt !== W.data0) W.gl = performance.now();
        return orig.apply(this, a);
      };
    }
  }
  const Orig = window.WebSocket;
  window.WebSocket = function (...a) {
    const ws = new Orig(...a);
    ws.addEventListener('message', () => {
      if (W.armed && W.send !== null && W.recv === null) W.recv = performance.now();
    });
    const send = ws.send.bind(ws);
    ws.send = (d) => { if (W.armed && W.key !== null && W.send === null) W.send = performance.now(); return send(d); };
    return ws;
  };
  window.WebSocket.prototype = Orig.prototype;
  Object.assign(window.WebSocket, { CONNECTING: 0, OPEN: 1, CLOSING: 2, CLOSED: 3 });
  document.addEventListener('keydown', () => { if (W.armed && W.key === null) W.key = performance.now(); }, true);
})();"""

ARM = """([sel]) => {
  const W = window.__snLat;
  const ed = document.querySelector(sel);
  const plot = ed.querySelector('.sn-plot-view');
  const gd = plot.querySelector('.js-plotly-plot');
  const conductor = ed.querySelector('.sn-conductor');
  Object.assign(W, { key: null, send: null, recv: null, plot: null, gl: null, data3d: null, figure: null,
                     figure0: plot.dataset.figureAt || null, data0: conductor ? conductor.dataset.dataAt : null,
                     cond: conductor, fast0: +(plot.dataset.fastDraws || 0) });
  if (W.observer) W.observer.disconnect();
  W.observer = new MutationObserver(() => { if (W.key !== null && W.plot === null) W.plot = performance.now(); });
  W.observer.observe(gd, { subtree: true, childList: true, attributes: true, characterData: true });
  W.poll = () => {   // the arrival marks the views leave on their elements
    if (plot.dataset.figureAt && plot.dataset.figureAt !== W.figure0) W.figure = +plot.dataset.figureAt;
    const at = conductor && conductor.dataset.dataAt;
    if (at && at !== W.data0) W.data3d = +at;
    W.react = +(plot.dataset.reactMs || 0);
    W.fast = +(plot.dataset.fastDraws || 0) !== W.fast0 ? +(plot.dataset.fastMs || 0) : null;
  };
  if (!W.timer) W.timer = setInterval(() => W.poll && W.poll(), 5);
  W.armed = true;
}"""

DONE = """() => { const W = window.__snLat; W.poll && W.poll(); return W.plot !== null && W.gl !== null; }"""
READ = """() => { const W = window.__snLat; W.poll && W.poll(); W.armed = false;
  const r = {}; for (const k of ['key', 'send', 'recv', 'figure', 'react', 'fast', 'plot', 'data3d', 'gl']) r[k] = W[k];
  return r; }"""

KERNEL_TIMING = """
import time as _t
_lat = []
def _timed(name, fn):
    def run(*a, **k):
        w, c = _t.perf_counter(), _t.process_time()
        try:
            return fn(*a, **k)
        finally:
            _lat.append((name, 1000 * (_t.perf_counter() - w), 1000 * (_t.process_time() - c)))
    return run
se.session.edited = _timed("replay", se.session.edited)
se.session.check_ops = _timed("replay", se.session.check_ops)
se._update_views = _timed("views", se._update_views)
"""


def _cells(clip: Path) -> list[str]:
    return [f"""import sys
sys.path.insert(0, {str(REPO)!r})
import stagger_nb as sn
from stagger_nb.widgets import StaggerEditor
m = sn.read_bvh({str(clip)!r})
se = StaggerEditor(m)
se.view.frame = m.num_frames // 3
se""", KERNEL_TIMING, f"print({bh.DONE!r})"]


def _stats(xs):
    xs = sorted(x for x in xs if x is not None)
    if not xs:
        return None
    p90 = xs[min(len(xs) - 1, int(round(0.9 * (len(xs) - 1))))]
    return {"median": round(statistics.median(xs), 1), "p90": round(p90, 1), "max": round(xs[-1], 1), "n": len(xs)}


def _burn() -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", "while True: pass"], start_new_session=True)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--presses", type=int, default=32)
    ap.add_argument("--burners", type=int, default=2)
    ap.add_argument("--sliders", default="cull,s,tau,w_r")
    ap.add_argument("--prepare", default="", help="presses made first and not timed, e.g. 'cull=19,s=20' (cull to "
                    "5 %%, s to 0.1: the state the default run's tau and w_r sliders start from)")
    ap.add_argument("--clip", default=str(REPO / "data" / "cmu_01_01.bvh"))
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    reason = bh.skip_reason()
    if reason:
        print("SKIP:", reason)
        return {}
    burners = [_burn() for _ in range(args.burners)]
    out: dict = {"presses": args.presses, "burners": args.burners, "clip": args.clip, "sliders": {}}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            bh.write_notebook(folder / "latency.ipynb", _cells(Path(args.clip)))
            with bh.jupyter_lab(folder) as url, bh.chromium_page() as (page, log):
                page.add_init_script(INIT)
                bh.open_notebook(page, url, "latency.ipynb", timeout=180)
                assert bh.sidebar_open(page), "the file browser should be open"
                bh.run_all_cells(page, timeout=300)
                sel = ".sn-stagger-editor"
                page.wait_for_selector(f"{sel} canvas", timeout=120000)
                bh.wait_plots_drawn(page, sel, timeout=180)
                runtime = bh.runtime_dir(folder)
                bh.wait_kernel(runtime, "all(f.done() for f in se.warm_futures)", timeout=600, every=1.0)
                bh.wait_kernel_idle(page)
                bh.wait_plots_synced(page, sel)
                kernel = bh.Kernel(runtime)
                page.locator(sel).first.scroll_into_view_if_needed()
                idle0 = page.evaluate("() => window.__snLat.draws")
                page.wait_for_timeout(1000)
                out["idle_draws_per_s"] = page.evaluate("() => window.__snLat.draws") - idle0
                for item in filter(None, args.prepare.split(",")):
                    name, n = item.split("=")
                    css, key = SLIDERS[name]
                    handle = page.locator(f"{sel} {css} .noUi-handle").first
                    handle.focus()
                    for _ in range(int(n)):
                        handle.press(key)
                        page.wait_for_timeout(100)
                        bh.wait_kernel_idle(page)
                        bh.wait_plots_synced(page, sel)
                    shown = page.locator(f"{sel} {css} .widget-readout").first.inner_text()
                    out.setdefault("prepared", {})[name] = shown
                    print(f"prepared {name}: {out['prepared'][name]}", flush=True)
                for name in args.sliders.split(","):
                    css, key = SLIDERS[name]
                    handle = page.locator(f"{sel} {css} .noUi-handle").first
                    handle.focus()
                    samples = []
                    kernel.run("_lat.clear()")
                    for _ in range(args.presses):
                        page.evaluate(ARM, [sel])
                        handle.press(key)
                        try:
                            page.wait_for_function(DONE, timeout=15000, polling=10)
                        except Exception:
                            pass
                        r = page.evaluate(READ)
                        bh.wait_kernel_idle(page)
                        bh.wait_plots_synced(page, sel)
                        lat = kernel.eval("_lat[:]")
                        kernel.run("_lat.clear()")
                        r["kernel"] = {k: [round(sum(w for n, w, c in lat if n == k), 1),
                                           round(sum(c for n, w, c in lat if n == k), 1)] for k in ("replay", "views")}
                        r["readout"] = page.locator(f"{sel} {css} .widget-readout").first.inner_text()
                        r["load"] = round(os.getloadavg()[0], 1)
                        samples.append(r)
                        page.wait_for_timeout(150)
                    out["sliders"][name] = _summarise(samples)
                    out["sliders"][name]["samples"] = samples
                    _print(name, out["sliders"][name])
                kernel.close()
                bh.screenshot(page, "browser_latency")
                out["console_errors"] = bh.console_errors(log)
    finally:
        for b in burners:
            os.killpg(b.pid, signal.SIGTERM)
            b.wait(timeout=10)
    out["load_average_end"] = os.getloadavg()
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    return out


def _d(r, a, b):
    return None if r.get(a) is None or r.get(b) is None else r[b] - r[a]


def _summarise(samples) -> dict:
    moved = [r for r in samples if r["plot"] is not None]
    return {"key_to_plot": _stats([_d(r, "key", "plot") for r in moved]),
            "key_to_3d": _stats([_d(r, "key", "gl") for r in moved]),
            "steps": {"key->send": _stats([_d(r, "key", "send") for r in moved]),
                      "send->first answer": _stats([_d(r, "send", "recv") for r in moved]),
                      "send->figure": _stats([_d(r, "send", "figure") for r in moved]),
                      "plotly.react": _stats([r["react"] for r in moved if r.get("fast") is None]),
                      "fast redraw": _stats([r["fast"] for r in moved if r.get("fast") is not None]),
                      "figure->plot DOM": _stats([_d(r, "figure", "plot") for r in moved]),
                      "3D data->WebGL draw": _stats([_d(r, "data3d", "gl") for r in moved]),
                      "kernel replay wall": _stats([r["kernel"]["replay"][0] for r in moved]),
                      "kernel replay cpu": _stats([r["kernel"]["replay"][1] for r in moved]),
                      "kernel views wall": _stats([r["kernel"]["views"][0] for r in moved]),
                      "kernel views cpu": _stats([r["kernel"]["views"][1] for r in moved])},
            "presses_that_changed_the_plot": len(moved), "load": [r["load"] for r in samples][::8]}


def _print(name, s) -> None:
    def f(x):
        return "-" if not x else f"{x['median']:.0f} / {x['p90']:.0f} / {x['max']:.0f}"
    print(f"{name:>5}: key->plot {f(s['key_to_plot'])} ms, key->3D {f(s['key_to_3d'])} ms (median / p90 / max, "
          f"{s['presses_that_changed_the_plot']} presses changed the plot; load {s['load']})", flush=True)
    steps = "; ".join(f"{k} {v['median']:.0f}" for k, v in s["steps"].items() if v)
    print(f"       {steps} (medians, ms)", flush=True)


if __name__ == "__main__":
    main()
