// PlotView: one plotly figure drawn by plotly.js, fed from the widget model (anywidget ESM).
// - plotly.js is the installed plotly package's bundle, sent by the kernel once per page on request (a
//   binary message), never from a CDN and never in the widget state;
// - every view draws the model's current `figure` (so a new view, e.g. after a page reload, shows the
//   current data) and redraws with Plotly.react on every change;
// - `frame` is drawn as a vertical line (the playhead) and moved with one relayout;
// - a click sets `frame` (seek) and tells the kernel {event: "click", x, y, curve, frame};
// - the plot takes the width of its container (ResizeObserver), drawing only once it has a width.
const LIB_KEY = Symbol.for("stagger_nb.plotly.js");

function loadPlotly(model) {
  // plotly.js is asked from the kernel (a binary message), once per page: it never sits in the widget
  // state, so restoring the widgets after a page reload stays small. Every view that waits registers its
  // model; the request is repeated (after 15 s, 30 s, 60 s, ... round robin over those models) until one answer
  // arrives: after a reload a model's comm may be dead (JupyterLab's restore race), another's is not.
  let g = globalThis[LIB_KEY];
  if (!g) {
    g = globalThis[LIB_KEY] = { askers: [], timer: null, delay: 15000, next: 0 };
    g.promise = new Promise((resolve, reject) => { g.resolve = resolve; g.reject = reject; });
    const retry = () => {
      if (g.done || !g.askers.length) return;
      const m = g.askers[g.next++ % g.askers.length];
      try { m.send({ event: "need_plotly" }); } catch (err) { console.warn("stagger_nb PlotView:", err); }
      g.delay = Math.min(2 * g.delay, 60000);
      g.timer = setTimeout(retry, g.delay);
    };
    g.timer = setTimeout(retry, g.delay);
  }
  if (g.done) return g.promise;
  const onMsg = (msg, buffers) => {
    if (!msg || msg.event !== "plotly.js" || g.done) return;
    g.done = true;
    clearTimeout(g.timer);
    for (const [m, cb] of g.askers.map((m, i) => [m, g.listeners[i]])) m.off("msg:custom", cb);
    try {
      const src = new TextDecoder().decode(buffers[0]);
      const module = { exports: {} };
      // the bundle is UMD: given `module` it returns Plotly as module.exports
      new Function("module", "exports", src)(module, module.exports);
      g.resolve(module.exports);
    } catch (err) {
      g.reject(err);
    }
  };
  g.listeners = g.listeners || [];
  g.askers.push(model);
  g.listeners.push(onMsg);
  model.on("msg:custom", onMsg);
  if (g.askers.length === 1) model.send({ event: "need_plotly" });
  return g.promise;
}

function playheadShape(model) {
  const f = model.get("frame");
  const xs = model.get("playhead_x") || [];
  const x = xs.length ? xs[Math.max(0, Math.min(xs.length - 1, f))] : f * model.get("frame_time");
  return {
    type: "line", name: "playhead", xref: model.get("playhead_xref") || "x", yref: "paper",
    x0: x, x1: x, y0: 0, y1: 1, line: { color: "#e53e3e", width: 2 },
    visible: !!model.get("show_playhead"), layer: "above",
  };
}

function frameOfX(model, x) {
  const xs = model.get("playhead_x") || [];
  if (xs.length) {
    let best = 0;
    for (let i = 1; i < xs.length; i++) if (Math.abs(xs[i] - x) < Math.abs(xs[best] - x)) best = i;
    return best;
  }
  const ft = model.get("frame_time");
  return Math.max(0, Math.round(x / ft));
}

async function render({ model, el }) {
  el.classList.add("sn-plot-view");
  const div = document.createElement("div");
  div.className = "sn-plot";
  el.appendChild(div);
  let Plotly = null, drawn = false, running = false, disposed = false;
  let dirty = 2;   // 0 nothing, 1 playhead, 2 whole figure
  let draws = 0;
  const config = { responsive: true, displaylogo: false, modeBarButtonsToRemove: ["select2d", "lasso2d"] };

  function figureArgs() {
    const fig = model.get("figure") || {};
    // own copies: plotly.js annotates the objects it is given, and other views share the model's
    const data = structuredClone(fig.data || []);
    const layout = structuredClone(fig.layout || {});
    delete layout.width;   // the container decides the width
    layout.autosize = true;
    layout.shapes = (layout.shapes || []).concat([playheadShape(model)]);
    return [data, layout];
  }

  function onClick(ev) {
    const p = ev && ev.points && ev.points[0];
    if (!p || typeof p.x !== "number") return;
    const frame = frameOfX(model, p.x);
    model.send({ event: "click", x: p.x, y: typeof p.y === "number" ? p.y : null, curve: p.curveNumber, frame });
    if (model.get("seek_on_click")) {
      model.set("frame", frame);
      model.save_changes();
    }
  }

  async function pump() {
    if (running || disposed) return;
    running = true;
    try {
      while (dirty && !disposed && Plotly && div.clientWidth > 0) {
        const what = drawn ? dirty : 2;
        dirty = 0;
        if (what === 2) {
          const [data, layout] = figureArgs();
          await Plotly.react(div, data, layout, config);
          if (!drawn) {
            drawn = true;
            div.on("plotly_click", onClick);
          }
          el.dataset.draws = String(++draws);   // browser tests wait on this
          el.dataset.status = "drawn";
        } else {
          // attribute-wise: replacing the whole shape object leaves the old line drawn (a trail)
          const n = (((model.get("figure") || {}).layout || {}).shapes || []).length;
          const s = playheadShape(model);
          await Plotly.relayout(div, { [`shapes[${n}].x0`]: s.x0, [`shapes[${n}].x1`]: s.x1,
                                       [`shapes[${n}].xref`]: s.xref, [`shapes[${n}].visible`]: s.visible });
        }
        el.dataset.frame = String(model.get("frame"));
      }
    } catch (err) {
      el.dataset.error = String(err);
      console.error("stagger_nb PlotView:", err);
    } finally {
      running = false;
    }
  }

  const onFigure = () => { dirty = 2; pump(); };
  const onPlayhead = () => { dirty = Math.max(dirty, 1); pump(); };
  model.on("change:figure", onFigure);
  for (const k of ["frame", "frame_time", "playhead_x", "playhead_xref", "show_playhead"]) {
    model.on(`change:${k}`, onPlayhead);
  }
  let lastWidth = 0;
  const ro = new ResizeObserver(() => {
    const w = div.clientWidth;
    const changed = w !== lastWidth;
    lastWidth = w;
    if (!w) return;   // hidden: changes wait until it is shown again
    if (drawn && changed && Plotly) Plotly.Plots.resize(div);
    pump();
  });
  ro.observe(div);

  el.dataset.status = "loading plotly.js";
  try {
    Plotly = await loadPlotly(model);
  } catch (err) {
    el.dataset.error = String(err);
    div.textContent = "stagger_nb: plotly.js could not be loaded: " + err;
    return;
  }
  el.dataset.status = div.clientWidth > 0 ? "drawing" : "waiting for a width";
  pump();

  return () => {
    disposed = true;
    ro.disconnect();
    model.off("change:figure", onFigure);
    for (const k of ["frame", "frame_time", "playhead_x", "playhead_xref", "show_playhead"]) {
      model.off(`change:${k}`, onPlayhead);
    }
    if (Plotly) Plotly.purge(div);
  };
}

export default { render };
