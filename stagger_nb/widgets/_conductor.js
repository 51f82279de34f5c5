// Browser-side clock and mesh builder for SkeletonView (an anywidget, model-level: one per view model, whether or
// not the conductor itself is displayed).
//
// The kernel sends, once per edit, binary buffers: `points` (F, P, 3) float32 world points (joints, then End
// Sites), `states` (F, J) uint8 joint states (0 plain, 1 staggered pose, 2 contact), `rig_path` (F, 3) float32,
// and once the ghost is shown `ghost_points`. For each shown frame (fractional: linear between frames) this clock
// rewrites the vertices of the ONE skeleton mesh (a unit-sphere template per joint, a unit-tube template per bone:
// _skeleton_mesh.js, prepended to this file by skeleton_view.py, the only builder of the mesh), the ghost mesh,
// the trail segments and the rig position of the pythreejs models it holds, then asks the scene to re-render.
//   * playing (the ipywidgets Play's `playing`): a requestAnimationFrame loop on performance.now() runs the
//     clip at its real rate; the Play's coarse ticks (value += step every interval) are kept near the clock:
//     when the Play lags by a step or more (late timers on a loaded machine) its value is set to the clock's
//     frame, so the slider advances at real time too. A jump that is not a tick (the user scrubbed) re-bases
//     the clock there.
//   * stopped: every value change of the Play (scrub, seek from Python) shows that exact frame.
// Nothing here is sent to the kernel except the rare Play correction above.
const PREFIX = "IPY_MODEL_";

async function resolve(model, ref) {
  if (!ref || typeof ref !== "string" || !ref.startsWith(PREFIX)) return null;
  const m = await model.widget_manager.get_model(ref.slice(PREFIX.length));
  if (m && m.initPromise) await m.initPromise;
  return m;
}

function floats(dv) {   // a DataView / ArrayBuffer / typed array from the comm -> Float32Array (aligned copy if needed)
  if (!dv) return new Float32Array(0);
  const buf = dv.buffer || dv;
  const off = dv.byteOffset || 0;
  const len = dv.byteLength !== undefined ? dv.byteLength : buf.byteLength;
  if (off % 4 === 0) return new Float32Array(buf, off, Math.floor(len / 4));
  return new Float32Array(buf.slice(off, off + len));
}

function bytes(dv) {
  if (!dv) return new Uint8Array(0);
  const buf = dv.buffer || dv;
  return new Uint8Array(buf, dv.byteOffset || 0, dv.byteLength !== undefined ? dv.byteLength : buf.byteLength);
}

function initialize({ model }) {
  const st = {
    player: null, scene: null, rig: null, skeleton: null, ghost: null, trails: null,
    playing: false, baseFrame: 0, baseWall: 0, raf: 0, lastTick: null, bound: 0, correcting: null,
    data: null, pending: 0, lastSync: 0,
  };

  // the model's buffers decoded once per change (not per frame)
  function decode() {
    const F = Math.max(1, model.get("num_frames") || 1);
    const P = Math.max(1, model.get("num_points") || 1);
    st.data = {
      F, P, J: model.get("num_joints") || 1,
      points: floats(model.get("points")),
      ghost: floats(model.get("ghost_points")),
      ghostF: model.get("ghost_frames") || 0,
      states: bytes(model.get("states")),
      rig: floats(model.get("rig_path")),
      segs: model.get("segments") || [],
      tpl: floats(model.get("template")),
      vs: model.get("sphere_vertices") || 0,
      vt: model.get("tube_vertices") || 0,
      jr: model.get("joint_radius"),
      br: model.get("bone_radius"),
      selected: new Set(model.get("selected") || []),
      scale: model.get("selected_scale") || 1,
      palette: model.get("palette") || [],
      trailJoints: model.get("trail_joints") || [],
      buf: new Float32Array(P * 3),
      gbuf: new Float32Array(P * 3),
      colourKey: null,
    };
  }

  const frameTime = () => Math.max(model.get("frame_time") || 1 / 60, 1e-4);
  const maxFrame = () => (st.player ? st.player.get("max") : 0);

  // The attribute this clock writes: its own copy of the pythreejs one (same class, data, item size), put on the
  // geometry once; the kernel's holds the constant parts only (the spheres' normals, the bones' colours).
  function own(g, name) {
    const a = g.attributes[name];
    if (!a || a.snOwn) return a;
    const fresh = new a.constructor(new Float32Array(a.array), a.itemSize, a.normalized);
    fresh.snOwn = true;
    fresh.dynamic = true;
    g.addAttribute(name, fresh);
    return fresh;
  }

  // the merged mesh of one frame (_skeleton_mesh.js: spheres, then tubes)
  function writeMesh(obj, pts, selected) {
    const g = obj && obj.geometry;
    if (!g || !g.attributes.position || !g.attributes.normal) return;
    const fresh = !g.attributes.normal.snOwn;
    const pa = own(g, "position"), na = own(g, "normal");
    if (fresh) snSphereNormals(st.data, na.array);
    if (!snMeshVertices(st.data, pts, selected, pa.array, na.array)) return;
    pa.needsUpdate = true;
    na.needsUpdate = true;
    g.computeBoundingSphere();   // the Picker's raycast tests it first
  }

  function writeColours(obj, fi) {
    const d = st.data;
    const g = obj && obj.geometry;
    const c = g && own(g, "color");
    if (!c || d.palette.length < 4) return;
    const row = d.states.length >= d.F * d.J ? d.states.subarray(Math.min(fi, d.F - 1) * d.J) : null;
    const key = snJointColours(d, row, d.selected, d.palette, c.array, d.colourKey);
    if (key === d.colourKey) return;
    d.colourKey = key;
    c.needsUpdate = true;
  }

  function writeTrails(obj, fi) {
    const d = st.data;
    const g = obj && obj.geometry;
    if (!g || !g.attributes.position || !d.trailJoints.length) return;
    const pos = g.attributes.position.array;
    const w = Math.floor(pos.length / (d.trailJoints.length * 12));   // 2 w segments x 2 ends x 3 per joint
    let v = 0;
    for (const p of d.trailJoints) {
      for (let k = 0; k < 2 * w; k++) {
        for (const f of [fi - w + k, fi - w + k + 1]) {
          const o = (Math.min(Math.max(f, 0), d.F - 1) * d.P + p) * 3;
          pos[v++] = d.points[o]; pos[v++] = d.points[o + 1]; pos[v++] = d.points[o + 2];
        }
      }
    }
    g.attributes.position.needsUpdate = true;
    g.computeBoundingSphere();
  }

  function show(f) {
    if (!st.data) decode();
    const d = st.data;
    const fi = Math.min(Math.max(Math.round(f), 0), d.F - 1);
    const sk = st.skeleton && st.skeleton.obj;
    if (sk && snPointsAt(d.points, d.F, d.P, f, d.buf)) {
      writeMesh(sk, d.buf, d.selected);
      writeColours(sk, fi);
    }
    const gh = st.ghost && st.ghost.obj;
    if (gh && gh.visible && d.ghostF > 0 && snPointsAt(d.ghost, d.ghostF, d.P, f, d.gbuf)) {
      writeMesh(gh, d.gbuf, new Set());
    }
    const rig = st.rig && st.rig.obj;
    if (rig && d.rig.length >= d.F * 3) {
      const fc = Math.min(Math.max(f, 0), d.F - 1), f0 = Math.floor(fc), f1 = Math.min(f0 + 1, d.F - 1);
      const u = fc - f0;
      rig.position.set(...[0, 1, 2].map((k) => d.rig[3 * f0 + k] + u * (d.rig[3 * f1 + k] - d.rig[3 * f0 + k])));
    }
    if (st.trails && st.trails.obj) writeTrails(st.trails.obj, fi);
    if (st.scene) st.scene.trigger("rerender", st.scene, {});
    // local only (not saved): what is drawn, for checks; the root's drawn position is published on the
    // (hidden) conductor element by render() below
    model.set("shown", { frame: fi, root: [d.buf[0], d.buf[1], d.buf[2]], frames: d.F, at: performance.now(),
                         dataAt: st.dataAt });
    model.set("shown_frame", fi);
  }

  function redraw() {
    if (!st.player) return;
    if (st.playing) show(clockFrame());
    else show(st.player.get("value"));
  }

  const clockFrame = () => st.baseFrame + (performance.now() - st.baseWall) / (1000 * frameTime());

  function rebase(f) {
    st.baseFrame = f;
    st.baseWall = performance.now();
  }

  function loop() {
    if (!st.playing) return;
    let f = clockFrame();
    const max = maxFrame();
    if (f >= max) {
      f = max;
      show(f);
      st.raf = 0;
      if (st.player && st.player.get("value") !== max) {   // land the Play on the last frame too
        st.player.set("value", max);
        st.player.save_changes();
      }
      return;
    }
    show(f);
    // the Play's own ticks (setInterval) run late on a loaded machine: keep its value (the slider, the kernel's
    // playhead) within a step of the clock from here too, at most every 200 ms (<= 5 extra messages a second)
    const now = performance.now();
    const step = (st.player && st.player.get("step")) || 1;
    if (st.player && now - st.lastSync >= 200 && Math.floor(f) - st.player.get("value") >= step) {
      st.lastSync = now;
      st.correcting = Math.floor(f);
      st.lastTick = st.correcting;
      st.player.set("value", st.correcting);
      st.player.save_changes();
      st.correcting = null;
    }
    st.raf = requestAnimationFrame(loop);
  }

  function onValue() {
    const v = st.player.get("value");
    if (v === st.correcting) {   // our own correction (below), already on the clock
      st.lastTick = v;
      return;
    }
    if (!st.playing) {
      show(v);
      st.lastTick = v;
      return;
    }
    const step = st.player.get("step") || 1;
    const expected = st.lastTick === null ? null : st.lastTick + step;
    st.lastTick = v;
    if (expected === null || v === expected) {
      // an ordinary tick: keep the Play within a step of the clock
      const c = Math.floor(clockFrame());
      if (c - v >= step && c <= maxFrame()) {
        st.lastTick = c;
        setTimeout(() => {
          if (st.playing && st.player.get("value") === v) {
            st.correcting = c;
            st.player.set("value", c);
            st.player.save_changes();
            st.correcting = null;
          }
        }, 0);
      }
    } else {
      rebase(v);   // a scrub, a seek or the Play's repeat while playing
      if (!st.raf) st.raf = requestAnimationFrame(loop);
    }
  }

  function onPlaying() {
    const playing = !!st.player.get("playing");
    if (playing === st.playing) return;
    st.playing = playing;
    st.lastTick = null;
    if (playing) {
      rebase(st.player.get("value"));
      if (!st.raf) st.raf = requestAnimationFrame(loop);
    } else {
      if (st.raf) cancelAnimationFrame(st.raf);
      st.raf = 0;
      // pause keeps the frame shown: the Play's coarse ticks lag the clock, so its value becomes the clock's
      // frame (a stop sets the value back to the start right after this, as the Play does)
      const f = Math.min(Math.max(Math.round(clockFrame()), st.player.get("min") || 0), maxFrame());
      if (Number.isFinite(f) && f !== st.player.get("value")) {
        st.correcting = f;
        st.player.set("value", f);
        st.player.save_changes();
        st.correcting = null;
      }
      show(st.player.get("value"));
    }
  }

  const REFS = ["player", "scene", "rig", "skeleton", "ghost", "trails"];

  async function bind() {
    const ticket = ++st.bound;
    const got = await Promise.all(REFS.map((k) => resolve(model, model.get(k)).catch(() => null)));
    if (ticket !== st.bound) return;   // a newer binding is on its way
    const [player, scene, rig, skeleton, ghost, trails] = got;
    if (st.player && st.player !== player) {
      st.player.off("change:value", onValue);
      st.player.off("change:playing", onPlaying);
    }
    Object.assign(st, { scene, rig, skeleton, ghost, trails });
    if (player && st.player !== player) {
      st.player = player;
      player.on("change:value", onValue);
      player.on("change:playing", onPlaying);
    }
    if (!st.player) return;
    redraw();
    onPlaying();
  }

  // an edit's frame at the playhead, sent before the whole clip (`preview`, `preview_frame`): drawn at once when
  // that frame is shown and the clock is stopped; the clip's points replace it when they arrive
  function onPreview() {
    const f = model.get("preview_frame");
    const pts = floats(model.get("preview"));
    if (!st.player || st.playing || f !== st.player.get("value")) return;
    if (!st.data) decode();
    const d = st.data, sk = st.skeleton && st.skeleton.obj;
    if (!sk || pts.length !== d.P * 3) return;
    st.dataAt = performance.now();
    d.buf.set(pts);
    writeMesh(sk, d.buf, d.selected);
    writeColours(sk, Math.min(f, d.F - 1));
    if (st.scene) st.scene.trigger("rerender", st.scene, {});
    model.set("shown", { frame: f, root: [d.buf[0], d.buf[1], d.buf[2]], frames: d.F, at: performance.now(),
                         dataAt: st.dataAt, preview: true });
  }
  model.on("change:preview", onPreview);

  // data changes (one message per edit, several traits): decode and redraw once, after the message is applied
  function onData() {
    st.data = null;
    st.dataAt = performance.now();   // when the kernel's data arrived, page clock (benchmarks read it)
    if (st.pending) return;
    st.pending = setTimeout(() => { st.pending = 0; redraw(); }, 0);
  }

  for (const k of ["points", "num_frames", "num_points", "num_joints", "ghost_points", "ghost_frames", "segments",
                   "template", "sphere_vertices", "tube_vertices", "joint_radius", "bone_radius", "selected",
                   "selected_scale", "states", "palette", "rig_path", "trail_joints", "trail_window"]) {
    model.on(`change:${k}`, onData);
  }
  for (const k of REFS) model.on(`change:${k}`, bind);
  bind();
  return () => {
    st.playing = false;
    model.off("change:preview", onPreview);
    if (st.raf) cancelAnimationFrame(st.raf);
    if (st.pending) clearTimeout(st.pending);
    if (st.player) {
      st.player.off("change:value", onValue);
      st.player.off("change:playing", onPlaying);
    }
  };
}

function render({ model, el }) {
  el.style.display = "none";
  el.classList.add("sn-conductor");
  const mark = () => {
    const s = model.get("shown");
    if (!s) return;
    el.dataset.frame = s.frame;
    el.dataset.frames = s.frames;
    el.dataset.root = s.root.map((x) => x.toFixed(2)).join(",");
    if (s.at !== undefined) el.dataset.shownAt = s.at.toFixed(1);
    if (s.dataAt !== undefined) el.dataset.dataAt = s.dataAt.toFixed(1);
  };
  model.on("change:shown", mark);
  mark();
  return () => model.off("change:shown", mark);
}

export default { initialize, render };
