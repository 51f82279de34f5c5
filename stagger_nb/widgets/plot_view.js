// PlotView: one plotly figure drawn by plotly.js, fed from the kernel (anywidget ESM).
// - the figure and playhead settings live on the view's `store`, a plain @jupyter-widgets/base WidgetModel:
//   anywidget drops every kernel message to a model whose module did not load within 2 s (a busy page, a
//   reload restoring many models at once), a base WidgetModel never does, so updates and plotly.js arrive;
// - plotly.js is the installed plotly package's bundle, sent by the kernel once per page on request (a
//   binary message to a store), never from a CDN and never in the widget state;
// - every view draws the store's current `figure` (so a new view, e.g. after a page reload, shows the
//   current data) and redraws with Plotly.react on every change; until plotly.js and a figure are there it
//   shows a placeholder line saying what it waits for (never empty axes);
// - `frame` (the store's, set by the kernel, or the view model's, set by a browser-side jsdlink) is drawn
//   as a vertical line (the playhead) and moved with one relayout;
// - a click sets `frame` (seek) and tells the kernel {event: "click", x, y, curve, frame};
// - `storeOf` (the view's store) is _store_view.js's, put before this module by _store_view.py.
// - the plot takes the width of its container (ResizeObserver), drawing only once it has a width.
// - live edits: a new figure that differs from the drawn one only in the x/y arrays of scatter traces (lines,
//   on any y axis; markers, points added or removed as their number changes), in a trace's name (the legend's
//   text) or in the title's text is drawn at once by rewriting those SVG paths and text nodes on the current
//   axes (~1 ms, where Plotly.react re-runs supplyDefaults, calc, legend and autorange: 10-40x that): a cull
//   move (knots and pose lines, the kept poses and the title's count) as much as an s or τ move; the full
//   Plotly.react follows once the figure has rested SETTLE_MS (the axes' ranges, hover data), so a drag shows
//   every value the kernel sends and the plot ends exactly as plotly draws it.
const LIB_KEY = Symbol.for("stagger_nb.plotly.js");
const SETTLE_MS = 250;

function decodeArray(a) {
  // a plotly.js typed-array spec {dtype, bdata} (what the kernel sends) or a plain list, as numbers
  if (!a || Array.isArray(a) || ArrayBuffer.isView(a)) return a || [];
  if (typeof a.bdata !== "string") return null;
  const bin = atob(a.bdata);
  const u8 = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
  const T = { f4: Float32Array, f8: Float64Array, i4: Int32Array, u4: Uint32Array, u1: Uint8Array }[a.dtype];
  return T ? new T(u8.buffer) : null;
}

function styleKey(trace) {
  // a trace without its data arrays and its name: equal keys = same drawing but for the points (and the
  // legend's text)
  const { x, y, name, ...rest } = trace;
  return JSON.stringify(rest);
}

function plainText(t) {
  // text plotly draws as it is (no <sub>, no entities): the fast path may write it into a text node
  return typeof t === "string" && !/[<>&]/.test(t);
}

function layoutKey(layout) {
  // the layout without its title's text: equal keys = same axes, legend and shapes
  const { title, ...rest } = layout || {};
  const { text, ...style } = (title && typeof title === "object") ? title : { text: title };
  return JSON.stringify([rest, style]);
}

function titleText(layout) {
  const t = (layout || {}).title;
  return (t && typeof t === "object") ? t.text : t;
}

function fastRedraw(gd, fig, last) {
  // draws `fig` over the drawn figure when only the x/y of scatter traces (lines; markers, whose points are
  // added or removed as their number changes), a trace's name (its legend text) or the title's text changed;
  // returns false (nothing touched) when anything else did
  const data = fig.data || [];
  if (!last || data.length !== last.styles.length || layoutKey(fig.layout) !== last.layout) return false;
  const full = gd._fullLayout, groups = [];
  if (!full) return false;
  const title = titleText(fig.layout), titleNode = gd.querySelector("text.gtitle");
  if (title !== last.title && !(plainText(title) && plainText(last.title) && titleNode)) return false;
  for (const g of gd.querySelectorAll("g.trace.scatter")) {   // each drawn trace by its index
    const cd = g.__data__;
    if (cd && cd[0] && cd[0].trace) groups[cd[0].trace.index] = g;
  }
  const legend = [];   // each legend entry's text node by its trace's index
  for (const g of gd.querySelectorAll("g.legend g.traces")) {
    const d = g.__data__, tr = d && d[0] && d[0].trace, t = g.querySelector("text.legendtext");
    if (tr && t) legend[tr.index] = t;
  }
  const todo = [], names = [];
  for (let i = 0; i < data.length; i++) {
    const tr = data[i];
    if (styleKey(tr) !== last.styles[i]) return false;
    if ((tr.name || "") !== last.names[i]) {
      if (!plainText(tr.name || "") || (tr.showlegend !== false && !legend[i])) return false;
      if (legend[i]) names.push([i, legend[i], tr.name || ""]);
    }
    const xy = JSON.stringify([tr.x, tr.y]);
    if (xy === last.xy[i]) continue;
    if ((tr.type || "scatter") !== "scatter" || (tr.xaxis && tr.xaxis !== "x")) return false;
    const ya = full["yaxis" + (tr.yaxis || "y").slice(1)];
    const g = groups[i], mode = tr.mode || "lines";
    if (!g || !ya) return false;
    const x = decodeArray(tr.x), y = decodeArray(tr.y);
    if (!x || !y || x.length !== y.length) return false;
    if (mode === "lines") {
      // plotly draws one path per run of points between gaps (NaN: e.g. the pose lines, one run per line)
      if (tr.connectgaps || tr.line && tr.line.shape && tr.line.shape !== "linear") return false;
      if (!g.querySelector("path.js-line") && x.length) return false;
      todo.push([i, xy, "lines", g, x, y, ya]);
    } else if (mode === "markers") {
      // one point path per point; a marker style held per point (arrays) is in styleKey, so every point of
      // the trace is drawn alike: a new point is a copy of a drawn one
      const pts = g.querySelectorAll("path.point");
      if (!pts.length && x.length) return false;
      todo.push([i, xy, "markers", g, x, y, ya]);
    } else {
      return false;
    }
  }
  const xa = full.xaxis;
  if (!xa) return false;
  for (const [i, xy, mode, node, x, y, ya] of todo) {
    if (mode === "lines") {
      const runs = [];
      let d = "";
      for (let k = 0; k < x.length; k++) {
        const px = xa.c2p(x[k]), py = ya.c2p(y[k]);
        if (!Number.isFinite(px) || !Number.isFinite(py)) { if (d) runs.push(d); d = ""; continue; }
        d += (d ? "L" : "M") + px.toFixed(2) + "," + py.toFixed(2);
      }
      if (d) runs.push(d);
      const paths = [...node.querySelectorAll("path.js-line")];
      const parent = paths.length ? paths[0].parentNode : null;
      while (paths.length > Math.max(runs.length, 1)) paths.pop().remove();
      while (paths.length < runs.length) { const q = paths[0].cloneNode(true); parent.appendChild(q); paths.push(q); }
      paths.forEach((q, k) => q.setAttribute("d", runs[k] || "M0,0"));
    } else {
      let pts = [...node.querySelectorAll("path.point")];
      const parent = pts.length ? pts[0].parentNode : null;
      while (pts.length > x.length) pts.pop().remove();
      while (pts.length < x.length) { const p = pts[0].cloneNode(true); parent.appendChild(p); pts.push(p); }
      pts.forEach((p, k) => p.setAttribute("transform",
        `translate(${xa.c2p(x[k]).toFixed(2)},${ya.c2p(y[k]).toFixed(2)})`));
    }
    last.xy[i] = xy;
  }
  for (const [i, node, name] of names) { node.textContent = name; last.names[i] = name; }
  if (title !== last.title) { titleNode.textContent = title; last.title = title; }
  return true;
}

function drawnKey(fig) {
  // what fastRedraw compares a new figure with: the drawn one's layout, styles, names, title and data
  const data = fig.data || [];
  return { layout: layoutKey(fig.layout), title: titleText(fig.layout), styles: data.map(styleKey),
           names: data.map((tr) => tr.name || ""), xy: data.map((tr) => JSON.stringify([tr.x, tr.y])) };
}

function loadPlotly(model) {
  // plotly.js is asked from the kernel (a binary message), once per page: it never sits in the widget
  // state, so restoring the widgets after a page reload stays small. Every view that waits registers its
  // model (a store); the request is repeated (after 6 s, 12 s, 24 s, then every 30 s, round robin over those
  // models) until one answer arrives: an answer to a closed or slow comm is not waited for forever.
  let g = globalThis[LIB_KEY];
  if (!g) {
    g = globalThis[LIB_KEY] = { askers: [], timer: null, delay: 6000, next: 0 };
    g.promise = new Promise((resolve, reject) => { g.resolve = resolve; g.reject = reject; });
    const retry = () => {
      if (g.done || !g.askers.length) return;
      const m = g.askers[g.next++ % g.askers.length];
      try { m.send({ event: "need_plotly" }); } catch (err) { console.warn("stagger_nb PlotView:", err); }
      g.delay = Math.min(2 * g.delay, 30000);
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

function playheadShape(model, f) {
  const xs = model.get("playhead_x") || [];
  const x = xs.length ? xs[Math.max(0, Math.min(xs.length - 1, f))] : f * model.get("frame_time");
  return {
    type: "line", name: "playhead", xref: model.get("playhead_xref") || "x", yref: "paper",
    x0: x, x1: x, y0: 0, y1: 1, line: { color: "rgba(26, 32, 44, 0.75)", width: 2 },
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
  const note = document.createElement("div");   // what the view waits for, until the first draw
  note.className = "sn-plot-note";
  note.style.cssText = "color:#718096;font:12px sans-serif;padding:8px 4px;min-height:120px;";
  const div = document.createElement("div");
  div.className = "sn-plot";
  el.append(note, div);
  let Plotly = null, store = null, drawn = false, running = false;
  const life = { disposed: false };
  let dirty = 2;   // 0 nothing, 1 playhead, 2 whole figure
  let draws = 0;
  let last = null;   // the figure drawn by the last Plotly.react: {layout, styles, xy} (the fast path's base)
  let settle = 0, force = false;   // the full Plotly.react a fast redraw owes (timer), and its flag
  let frame = model.get("frame") || 0;
  const config = { responsive: true, displaylogo: false, modeBarButtonsToRemove: ["select2d", "lasso2d"] };
  const status = (text) => { el.dataset.status = text; if (!drawn) note.textContent = text; };

  function hasData() {
    const fig = store.get("figure") || {};
    return Array.isArray(fig.data) && fig.data.length > 0;
  }

  function figureArgs() {
    const fig = store.get("figure") || {};
    // own copies: plotly.js annotates the objects it is given, and other views share the model's
    const data = structuredClone(fig.data || []);
    const layout = structuredClone(fig.layout || {});
    delete layout.width;   // the container decides the width
    layout.autosize = true;
    layout.shapes = (layout.shapes || []).concat([playheadShape(store, frame)]);
    return [data, layout];
  }

  function onClick(ev) {
    const p = ev && ev.points && ev.points[0];
    if (!p || typeof p.x !== "number") return;
    const f = frameOfX(store, p.x);
    store.send({ event: "click", x: p.x, y: typeof p.y === "number" ? p.y : null, curve: p.curveNumber, frame: f });
    if (store.get("seek_on_click")) {
      frame = f;
      store.set("frame", f);
      store.save_changes();
      dirty = Math.max(dirty, 1);
      pump();
    }
  }

  async function pump() {
    if (running || life.disposed || !Plotly || !store) return;
    if (!hasData()) { status("waiting for the plot's data"); return; }
    if (div.clientWidth <= 0) { status("waiting for a width"); return; }
    running = true;
    try {
      while (dirty && !life.disposed && div.clientWidth > 0) {
        const what = drawn ? dirty : 2;
        dirty = 0;
        if (what === 2 && drawn && !force) {
          const t0 = performance.now();
          const fig = store.get("figure") || {};
          if (fastRedraw(div, fig, last)) {
            el.dataset.fastMs = (performance.now() - t0).toFixed(1);   // benchmarks read it
            el.dataset.fastDraws = String(+(el.dataset.fastDraws || 0) + 1);
            clearTimeout(settle);
            settle = setTimeout(() => { settle = 0; force = true; dirty = 2; pump(); }, SETTLE_MS);
            continue;
          }
        }
        if (what === 2) {
          force = false;
          clearTimeout(settle);
          settle = 0;
          const fig = store.get("figure") || {};
          const [data, layout] = figureArgs();
          const t0 = performance.now();
          await Plotly.react(div, data, layout, config);
          el.dataset.reactMs = (performance.now() - t0).toFixed(1);   // what a redraw costs (benchmarks read it)
          last = drawnKey(fig);
          if (!drawn) {
            drawn = true;
            note.remove();
            div.on("plotly_click", onClick);
          }
          el.dataset.draws = String(++draws);   // browser tests wait on this
          el.dataset.status = "drawn";
          el.dataset.title = ((layout.title || {}).text) || "";
        } else {
          // attribute-wise: replacing the whole shape object leaves the old line drawn (a trail)
          const n = (((store.get("figure") || {}).layout || {}).shapes || []).length;
          const s = playheadShape(store, frame);
          await Plotly.relayout(div, { [`shapes[${n}].x0`]: s.x0, [`shapes[${n}].x1`]: s.x1,
                                       [`shapes[${n}].xref`]: s.xref, [`shapes[${n}].visible`]: s.visible });
        }
        el.dataset.frame = String(frame);
      }
      // the store's current figure and frame are drawn (tests wait on it, not on sleeps)
      el.dataset.synced = dirty || !drawn || settle ? "0" : "1";
    } catch (err) {
      el.dataset.error = String(err);
      console.error("stagger_nb PlotView:", err);
    } finally {
      running = false;
    }
  }

  const onFigure = () => {
    el.dataset.figureAt = performance.now().toFixed(1);   // when the figure arrived, page clock
    dirty = 2; el.dataset.synced = "0"; pump();
  };
  const onPlayhead = () => { dirty = Math.max(dirty, 1); el.dataset.synced = "0"; pump(); };
  // the playhead: the kernel's frame (store) or a browser-side link's (this view's model), latest wins
  const onStoreFrame = () => { frame = store.get("frame"); onPlayhead(); };
  const onViewFrame = () => { frame = model.get("frame"); onPlayhead(); };
  const KEYS = ["frame_time", "playhead_x", "playhead_xref", "show_playhead"];
  model.on("change:frame", onViewFrame);
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

  const dispose = () => {
    life.disposed = true;
    clearTimeout(settle);
    ro.disconnect();
    model.off("change:frame", onViewFrame);
    if (store) {
      store.off("change:figure", onFigure);
      store.off("change:frame", onStoreFrame);
      for (const k of KEYS) store.off(`change:${k}`, onPlayhead);
    }
    if (Plotly) Plotly.purge(div);
  };
  try {
    status("connecting to the plot's data");
    store = await storeOf(model, life);
    if (life.disposed) return dispose;
    frame = store.get("frame");
    store.on("change:figure", onFigure);
    store.on("change:frame", onStoreFrame);
    for (const k of KEYS) store.on(`change:${k}`, onPlayhead);
    status("loading plotly.js");
    Plotly = await loadPlotly(store);
  } catch (err) {
    el.dataset.error = String(err);
    note.textContent = "stagger_nb: the plot could not be drawn: " + err;
    return dispose;
  }
  pump();
  return dispose;
}

export default { render };
