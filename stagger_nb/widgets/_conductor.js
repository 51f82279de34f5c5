// Browser-side playback clock for SkeletonView (an anywidget, model-level: one clock per view model, whether
// or not the conductor itself is displayed).
//
// The motion is in pythreejs AnimationClips (binary keyframe tracks) played by AnimationActions on one
// AnimationMixer, all paused; this clock sets every action's time and applies it (mixer.update(0)), exactly as
// pythreejs' own AnimationAction.animateFrame does, then asks the scene to re-render.
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

function initialize({ model }) {
  const st = {
    player: null, mixer: null, scene: null, actions: [], trails: [],
    playing: false, baseFrame: 0, baseWall: 0, raf: 0, lastTick: null, bound: 0, correcting: null,
  };

  const frameTime = () => Math.max(model.get("frame_time") || 1 / 60, 1e-4);
  const maxFrame = () => (st.player ? st.player.get("max") : 0);

  function show(f) {
    if (!st.mixer || !st.mixer.obj) return;
    const t = f * frameTime();
    for (const a of st.actions) {
      if (a && a.obj) a.obj.time = t;
    }
    st.mixer.obj.update(0);
    const w = model.get("trail_window");
    const fi = Math.round(f);
    for (const tr of st.trails) {
      const g = tr && tr.obj && tr.obj.geometry;
      if (!g) continue;
      const n = g.attributes.position ? g.attributes.position.count : 0;
      const s = Math.max(0, fi - w);
      g.setDrawRange(s, Math.max(0, Math.min(n, fi + w + 1) - s));
    }
    if (st.scene) st.scene.trigger("rerender", st.scene, {});
    model.set("shown_frame", fi);   // local only (not saved): lets tests read what is drawn
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
      show(st.player.get("value"));
    }
  }

  async function bind() {
    const ticket = ++st.bound;
    const [player, mixer, scene] = await Promise.all(
      ["player", "mixer", "scene"].map((k) => resolve(model, model.get(k))));
    const actions = await Promise.all((model.get("actions") || []).map((r) => resolve(model, r)));
    const trails = await Promise.all((model.get("trails") || []).map((r) => resolve(model, r)));
    if (ticket !== st.bound) return;   // a newer binding is on its way
    const old = st.actions;
    if (st.player && st.player !== player) {
      st.player.off("change:value", onValue);
      st.player.off("change:playing", onPlaying);
    }
    // Old actions are stopped, not uncached: three r97 (pythreejs 2.4.2) does not count a property binding
    // shared by a new action (same root and track name, bound by pythreejs' mixer.clipAction), so
    // uncacheAction(old) dropped that binding from the mixer while the new action still used it, and the new
    // action's play() threw "Cannot set properties of undefined (setting '_cacheIndex')" in _lendBinding
    // (fixed in later three.js: _bindAction increments referenceCount). Cost: the stopped actions stay cached.
    for (const a of old) {
      if (a && a.obj && !actions.includes(a)) a.obj.stop();
    }
    st.mixer = mixer;
    st.scene = scene;
    st.actions = actions.filter((a) => a && a.obj);
    st.trails = trails.filter((t) => t);
    for (const a of st.actions) {
      a.obj.paused = true;   // time is set by this clock; the mixer only applies it
      a.obj.play();
    }
    if (player && st.player !== player) {
      st.player = player;
      player.on("change:value", onValue);
      player.on("change:playing", onPlaying);
    }
    if (!st.player) return;
    if (st.playing) show(clockFrame());
    else show(st.player.get("value"));
    onPlaying();
  }

  // An edit updates the tracks in place (new times/values arrays on the same pythreejs track models, tracks added
  // to or dropped from the same clip) and then bumps data_version. A three.js AnimationAction keeps interpolants
  // made from its clip's tracks when it was created, so every action is rebuilt from its clip's current tracks:
  // the mixer's public uncacheAction / clipAction, the new action replacing the old one on its pythreejs model.
  async function refresh() {
    const ticket = st.bound;
    await Promise.all(st.actions.map(async (a) => {   // let the tracks' own updates (sent first) land
      const clip = a && a.get("clip");
      const tracks = (clip && clip.get("tracks")) || [];
      await Promise.all([clip, ...tracks].map((m) => (m && m.state_change) || null));
    }));
    await new Promise((r) => setTimeout(r, 0));
    if (ticket !== st.bound || !st.mixer || !st.mixer.obj) return;   // a rebinding came in between
    const mixer = st.mixer.obj;
    for (const a of st.actions) {
      if (!a || !a.obj) continue;
      const clip = a.obj.getClip();
      const root = a.obj.getRoot();
      clip.resetDuration();
      a.obj.stop();
      mixer.uncacheAction(clip, root);
      const fresh = mixer.clipAction(clip, root);
      fresh.ipymodelId = a.model_id;
      fresh.ipymodel = a;
      fresh.paused = true;
      fresh.play();
      a.obj = fresh;
    }
    // A dropped track (a joint that no longer moves) released its binding, and three.js then restored that
    // node's transform as it was when first bound; the kernel's value for it (the joint's new rest rotation) is
    // on the node's pythreejs model: re-apply the models' transforms, the mixer poses the animated ones on top.
    if (st.scene && st.scene.obj) {
      st.scene.obj.traverse((o) => {
        const m = o.ipymodel;
        if (!o.isGroup || !m) return;
        const q = m.get("quaternion");
        const p = m.get("position");
        if (q && q.length === 4) o.quaternion.fromArray(q);
        if (p && p.length === 3) o.position.fromArray(p);
      });
    }
    if (!st.player) return;
    if (st.playing) show(clockFrame());
    else show(st.player.get("value"));
  }

  model.on("change:data_version", refresh);
  model.on("change:actions", bind);
  model.on("change:trails", bind);
  model.on("change:player", bind);
  model.on("change:trail_window", () => { if (st.player && !st.playing) show(st.player.get("value")); });
  bind();
  return () => {
    st.playing = false;
    if (st.raf) cancelAnimationFrame(st.raf);
    if (st.player) {
      st.player.off("change:value", onValue);
      st.player.off("change:playing", onPlaying);
    }
  };
}

function render({ model, el }) {
  el.style.display = "none";
}

export default { initialize, render };
