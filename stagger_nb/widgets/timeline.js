// Timeline: the dope sheet of the staggered poses (anywidget ESM; Python: stagger_nb/widgets/timeline.py).
// - the numbers (joints, limb groups, pose times, knot times t_k + r[k, j]) live on the view's `store`, a plain
//   @jupyter-widgets/base WidgetModel (as PlotView's: kernel updates always arrive, also to a view whose
//   anywidget module loaded late);
// - one SVG: a label column, one row per joint grouped by limb (a group's header toggles it; a collapsed
//   group is one row holding all its knots), a column per pose (its header a draggable tab), a mark per knot,
//   the playhead across it;
// - a drag of a knot sends {event: "refine", pose, joint, time}, of a pose tab {event: "retime", pose, time}
//   (on release: one op per drag); a click on a knot, a tab or a row label {event: "select", pose, joint};
//   a click on the empty sheet seeks (sets `frame`); the kernel checks every request and answers with a new
//   table or a message (shown under the sheet);
// - data-* attributes on the element say what is drawn (browser tests wait on them).
// - `storeOf` (the view's store) is _store_view.js's, put before this module by _store_view.py.
const SVG = "http://www.w3.org/2000/svg";
const ROW = 15, HEAD = 30, FOOT = 4, LABEL = 118, RIGHT = 16;
const COLOURS = { pose: "#dd6b20", knot: "#2b6cb0", onPose: "#718096", sel: "#e53e3e", grid: "#e2e8f0",
                  text: "#2d3748", faint: "#a0aec0", playhead: "rgba(26, 32, 44, 0.75)", bad: "#c53030" };

function node(tag, attrs, parent) {
  const e = document.createElementNS(SVG, tag);
  for (const k in attrs) e.setAttribute(k, attrs[k]);
  if (parent) parent.appendChild(e);
  return e;
}

const shortName = (n) => String(n).split(":").pop();

async function render({ model, el }) {
  el.classList.add("sn-timeline");
  const life = { disposed: false };
  const wrap = document.createElement("div");
  wrap.className = "sn-timeline-body";
  const note = document.createElement("div");
  note.className = "sn-timeline-message";
  el.append(wrap, note);
  let store = null, svg = null, playhead = null, draws = 0;
  let frame = model.get("frame") || 0;
  let rows = [];            // [{kind: "group"|"joint", label, joints: [j...], y}]
  let scale = null;         // {x0, x1, lo, hi}: time -> px
  let drag = null;

  const table = () => store.get("table") || {};
  const xOf = (t) => scale.x0 + (t - scale.lo) / (scale.hi - scale.lo) * (scale.x1 - scale.x0);
  const tOf = (x) => scale.lo + (x - scale.x0) / (scale.x1 - scale.x0) * (scale.hi - scale.lo);

  function layoutRows(tb) {
    const collapsed = new Set(store.get("collapsed") || []);
    const out = [];
    let y = HEAD;
    for (const [label, joints] of tb.groups || []) {
      const open = !collapsed.has(label);
      out.push({ kind: "group", label, joints, open, y });
      y += ROW;
      if (open) for (const j of joints) { out.push({ kind: "joint", label: tb.joints[j], joints: [j], y }); y += ROW; }
    }
    return [out, y + FOOT];
  }

  function draw() {
    if (life.disposed || !store) return;
    const tb = table();
    const width = wrap.clientWidth;
    if (!width || !tb.joints) {
      el.dataset.status = tb.joints ? "waiting for a width" : "waiting for the knots";
      return;
    }
    const K = (tb.pose_times || []).length;
    const xr = store.get("x_range") || [];
    const lo = xr.length === 2 ? xr[0] : 0, hi = xr.length === 2 ? xr[1] : Math.max(tb.duration || 1, 1e-3);
    scale = { x0: LABEL, x1: Math.max(LABEL + 40, width - RIGHT), lo, hi: hi > lo ? hi : lo + 1 };
    let height;
    [rows, height] = layoutRows(tb);
    const selJ = store.get("selected_joint"), selK = store.get("selected_pose");
    const s = node("svg", { width, height, class: "sn-timeline-svg" });
    s.style.display = "block";
    s.style.userSelect = "none";
    s.style.font = "11px sans-serif";
    const bg = node("rect", { x: 0, y: 0, width, height, fill: "#ffffff", class: "sn-timeline-bg" }, s);
    bg.addEventListener("click", onBackground);
    // rows: stripes, labels
    for (const r of rows) {
      const isSel = r.kind === "joint" && r.label === selJ;
      if (r.kind === "group" || isSel) {
        node("rect", { x: 0, y: r.y, width, height: ROW, fill: isSel ? "#fff5f5" : "#f7fafc",
                       "pointer-events": "none" }, s);
      }
      const t = node("text", { x: r.kind === "group" ? 4 : 16, y: r.y + ROW - 4,
                               fill: isSel ? COLOURS.sel : COLOURS.text,
                               "font-weight": r.kind === "group" ? "600" : "400",
                               class: r.kind === "group" ? "sn-group" : "sn-row-label", cursor: "pointer" }, s);
      t.textContent = r.kind === "group" ? `${r.open ? "▾" : "▸"} ${r.label} (${r.joints.length})`
                                         : shortName(r.label);
      if (r.kind === "group") {
        t.dataset.group = r.label;
        t.addEventListener("click", () => toggle(r.label));
      } else {
        t.dataset.joint = r.label;
        t.addEventListener("click", () => select(selK, r.label));
      }
      const title = node("title", {}, t);
      title.textContent = r.kind === "group" ? "click to open or close this limb" : r.label;
    }
    node("line", { x1: LABEL - 2, x2: LABEL - 2, y1: 0, y2: height, stroke: COLOURS.grid }, s);
    // time ticks (seconds) along the top
    const span = scale.hi - scale.lo, px = scale.x1 - scale.x0;
    const step = [0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 60].find((d) => px / (span / d) >= 48) || 60;
    for (let t = Math.ceil(scale.lo / step) * step; t <= scale.hi + 1e-9; t += step) {
      const x = xOf(t);
      node("line", { x1: x, x2: x, y1: 10, y2: 14, stroke: COLOURS.faint }, s);
      const lab = node("text", { x, y: 9, fill: COLOURS.faint, "text-anchor": "middle", "font-size": 9 }, s);
      lab.textContent = `${+t.toFixed(2)} s`;
    }
    // pose columns: a line down the sheet and a draggable tab
    const times = tb.pose_times || [];
    const region = store.get("region") || [];   // the timing edits' magic-wand region: a weight per pose
    // numbered tabs never overlap (43 poses on 848 px cut "17", "30" under their neighbours): the selected pose
    // keeps its number, then each pose from the left if its tab clears the last numbered one and the selected
    // one; the others are narrow unnumbered tabs (their number in the tooltip), still clicked and dragged
    const tabW = (k) => 8 + 5.5 * String(k).length, numbered = new Set();
    const clears = (k, j) => Math.abs(xOf(times[k]) - xOf(times[j])) >= (tabW(k) + tabW(j)) / 2 + 1;
    if (selK >= 0 && selK < K) numbered.add(selK);
    for (let k = 0, last = -1; k < K; k++) {
      if (k === selK) { last = k; continue; }
      if ((last < 0 || clears(k, last)) && !(numbered.has(selK) && !clears(k, selK))) { numbered.add(k); last = k; }
    }
    for (let k = 0; k < K; k++) {
      const x = xOf(times[k]);
      if (region.length === K && region[k] > 0) {
        node("rect", { x: x - 8, y: 27, width: 16, height: 3, fill: "#1b7837", opacity: Math.min(1, region[k]),
                       class: "sn-region", "pointer-events": "none" }, s);
      }
      node("line", { x1: x, x2: x, y1: HEAD - 4, y2: height, stroke: k === selK ? COLOURS.pose : "#fbd38d",
                     "stroke-width": k === selK ? 1.5 : 1, "pointer-events": "none" }, s);
      const g = node("g", { class: "sn-pose-col", cursor: k === 0 || k === K - 1 ? "pointer" : "ew-resize" }, s);
      g.dataset.pose = String(k);
      const w = numbered.has(k) ? tabW(k) : 5;
      g.dataset.numbered = numbered.has(k) ? "1" : "0";
      // the selected tab: white bold digits on a darker orange (dark digits on the orange were hard to read)
      node("rect", { x: x - w / 2, y: 15, width: w, height: 11, rx: 2, class: "sn-pose-tab",
                     fill: k === selK ? "#9c4221" : "#feebc8", stroke: COLOURS.pose }, g);
      if (numbered.has(k)) {
        const lab = node("text", { x, y: 24, "text-anchor": "middle", "font-size": 9, class: "sn-pose-label",
                                   "font-weight": k === selK ? "bold" : "normal",
                                   fill: k === selK ? "#ffffff" : COLOURS.text }, g);
        lab.textContent = String(k);
      }
      const tip = node("title", {}, g);
      tip.textContent = `pose ${k} at ${times[k].toFixed(2)} s: click to select, drag to retime`;
      g.addEventListener("pointerdown", (ev) => startDrag(ev, g, { kind: "pose", pose: k, t0: times[k] }));
    }
    // knots
    const knots = tb.knots || [];
    let nk = 0;
    for (const r of rows) {
      const cy = r.y + ROW / 2;
      for (const j of r.joints) {
        if (r.kind === "group" && r.open) break;   // an open group's header row holds no knots
        const name = tb.joints[j];
        for (let k = 0; k < K; k++) {
          const t = knots[k][j];
          const x = xOf(t);
          const off = Math.abs(t - times[k]) > 1e-6;
          if (r.kind === "joint" && off) {   // the refinement: a thin bar from the pose's column to its knot
            node("line", { x1: xOf(times[k]), x2: x, y1: cy, y2: cy, stroke: "#90cdf4", "stroke-width": 2,
                           "pointer-events": "none" }, s);
          }
          const sel = name === selJ && k === selK;
          const size = r.kind === "group" ? 3 : 4.5;
          const m = node("rect", { x: x - size, y: cy - size, width: 2 * size, height: 2 * size,
                                   transform: `rotate(45 ${x} ${cy})`,
                                   fill: sel ? COLOURS.sel : off ? COLOURS.knot : COLOURS.onPose,
                                   stroke: "#ffffff", "stroke-width": 0.8,
                                   class: r.kind === "group" ? "sn-knot-summary" : "sn-knot",
                                   cursor: r.kind === "joint" && k > 0 && k < K - 1 ? "ew-resize" : "pointer" }, s);
          m.dataset.pose = String(k);
          m.dataset.joint = name;
          m.dataset.time = String(t);
          nk++;
          if (r.kind === "joint") {
            const tip = node("title", {}, m);
            tip.textContent = `${name}, pose ${k}: ${t.toFixed(3)} s (pose at ${times[k].toFixed(3)} s)`;
            m.addEventListener("pointerdown", (ev) => startDrag(ev, m, { kind: "knot", pose: k, joint: name, t0: t }));
          }
        }
      }
    }
    playhead = node("line", { y1: 12, y2: height, stroke: COLOURS.playhead, "stroke-width": 2,
                              class: "sn-timeline-playhead", "pointer-events": "none" }, s);
    const readout = node("text", { class: "sn-drag-readout", y: HEAD - 16, "font-size": 10, fill: COLOURS.bad,
                                   "pointer-events": "none" }, s);
    readout.style.display = "none";
    if (svg) svg.replaceWith(s); else wrap.appendChild(s);
    svg = s;
    movePlayhead();
    el.dataset.draws = String(++draws);
    el.dataset.knots = String(nk);
    el.dataset.rows = String(rows.length);
    el.dataset.status = "drawn";
    note.textContent = store.get("message") || "";
    note.style.display = note.textContent ? "block" : "none";
  }

  function movePlayhead() {
    if (!playhead || !scale) return;
    const ft = (table().frame_time) || 1 / 30;
    const x = Math.min(Math.max(xOf(frame * ft), scale.x0), scale.x1);
    playhead.setAttribute("x1", x);
    playhead.setAttribute("x2", x);
    el.dataset.frame = String(frame);
  }

  function send(msg) {
    try { store.send(msg); } catch (err) { console.warn("stagger_nb Timeline:", err); }
  }

  function select(pose, joint) {
    send({ event: "select", pose: pose, joint: joint || "" });
  }

  function toggle(label) {
    const c = new Set(store.get("collapsed") || []);
    if (c.has(label)) c.delete(label); else c.add(label);
    store.set("collapsed", [...c]);
    store.save_changes();
    draw();
  }

  function onBackground(ev) {
    if (!scale) return;
    const x = ev.clientX - svg.getBoundingClientRect().left;
    if (x < scale.x0 || x > scale.x1) return;
    const ft = (table().frame_time) || 1 / 30;
    frame = Math.max(0, Math.round(tOf(x) / ft));
    store.set("frame", frame);
    store.save_changes();
    movePlayhead();
  }

  function startDrag(ev, target, what) {
    ev.preventDefault();
    ev.stopPropagation();
    target.setPointerCapture && target.setPointerCapture(ev.pointerId);
    const x0 = ev.clientX;
    drag = { ...what, target, x0, moved: false, t: what.t0 };
    const readout = svg.querySelector(".sn-drag-readout");
    const move = (e) => {
      const dx = e.clientX - x0;
      if (!drag.moved && Math.abs(dx) < 3) return;
      drag.moved = true;
      const left = svg.getBoundingClientRect().left;
      drag.t = tOf(Math.min(Math.max(e.clientX - left, scale.x0), scale.x1));
      const rest = what.kind === "knot" ? target.getAttribute("transform").replace(/translate\([^)]*\)\s*/, "") : "";
      target.setAttribute("transform", `translate(${xOf(drag.t) - xOf(what.t0)} 0) ${rest}`);
      readout.style.display = "block";
      readout.setAttribute("x", xOf(drag.t) + 8);
      readout.textContent = `${drag.t.toFixed(2)} s`;
      el.dataset.dragging = "1";
    };
    const up = () => {
      target.removeEventListener("pointermove", move);
      target.removeEventListener("pointerup", up);
      target.removeEventListener("pointercancel", up);
      const d = drag;
      drag = null;
      el.dataset.dragging = "0";
      if (!d) return;
      if (!d.moved) {
        select(d.pose, d.kind === "knot" ? d.joint : store.get("selected_joint"));
        return;
      }
      readout.style.display = "none";
      if (d.kind === "knot") send({ event: "refine", pose: d.pose, joint: d.joint, time: d.t });
      else send({ event: "retime", pose: d.pose, time: d.t });
      // until the kernel answers (a new table, or a message and the same table), show where it was dropped
      el.dataset.pending = "1";
    };
    target.addEventListener("pointermove", move);
    target.addEventListener("pointerup", up);
    target.addEventListener("pointercancel", up);
  }

  const onTable = () => { el.dataset.pending = "0"; draw(); };
  const onStoreFrame = () => { frame = store.get("frame"); movePlayhead(); };
  const onViewFrame = () => { frame = model.get("frame"); movePlayhead(); };
  const onMessage = () => { el.dataset.pending = "0"; draw(); };
  const KEYS = ["x_range", "selected_pose", "selected_joint", "collapsed", "region"];
  model.on("change:frame", onViewFrame);
  let lastWidth = 0;
  const ro = new ResizeObserver(() => {
    const w = wrap.clientWidth;
    if (w && w !== lastWidth && !drag) { lastWidth = w; draw(); }
  });
  ro.observe(wrap);
  const dispose = () => {
    life.disposed = true;
    ro.disconnect();
    model.off("change:frame", onViewFrame);
    if (store) {
      store.off("change:table", onTable);
      store.off("change:frame", onStoreFrame);
      store.off("change:message", onMessage);
      for (const k of KEYS) store.off(`change:${k}`, draw);
    }
  };
  try {
    el.dataset.status = "connecting to the knots";
    store = await storeOf(model, life);
  } catch (err) {
    el.dataset.error = String(err);
    return dispose;
  }
  if (life.disposed) return dispose;
  frame = store.get("frame") || 0;
  store.on("change:table", onTable);
  store.on("change:frame", onStoreFrame);
  store.on("change:message", onMessage);
  for (const k of KEYS) store.on(`change:${k}`, draw);
  draw();
  return dispose;
}

export default { render };
