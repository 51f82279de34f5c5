// The standalone page's 3D player (three.js r97 from the pythreejs package, inlined above this script).
// Reads the JSON in <script id="sn-data">: binary arrays as base64 float32, the same tracks SkeletonView sends.
(function () {
  "use strict";
  const D = JSON.parse(document.getElementById("sn-data").textContent);
  const f32 = (b64) => {
    const s = atob(b64);
    const u = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) u[i] = s.charCodeAt(i);
    return new Float32Array(u.buffer);
  };
  const box = document.getElementById("sn-view");
  const W = D.width, H = D.height;
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setSize(W, H);
  renderer.setClearColor(0xffffff, 1);
  box.insertBefore(renderer.domElement, box.firstChild);
  const scene = new THREE.Scene();
  scene.add(new THREE.AmbientLight(0xffffff, 0.45));
  scene.add(new THREE.HemisphereLight(0xffffff, 0x718096, 0.75));

  // the camera stays put; the world ("rig") moves by minus the follow path, so orbiting is plain lookAt
  const rig = new THREE.Group();
  rig.name = "rig";
  scene.add(rig);
  const cyl = new THREE.CylinderGeometry(D.radius * 0.45, D.radius * 0.45, 1, 8);
  const sph = new THREE.SphereGeometry(D.radius, 12, 8);
  const sideMat = {};
  for (const k in D.side_colours) sideMat[k] = new THREE.MeshLambertMaterial({ color: D.side_colours[k] });

  function skeleton(prefix, sk, material, withSpheres) {
    const groups = sk.names.map((_, j) => {
      const g = new THREE.Group();
      g.name = prefix + j;
      g.position.fromArray(sk.rest_positions[j]);
      g.quaternion.fromArray(sk.rest_quats[j]);
      if (withSpheres) {
        const m = new THREE.Mesh(sph, new THREE.MeshLambertMaterial({ color: D.joint_colour }));
        m.name = "s" + j;
        g.add(m);
      }
      return g;
    });
    for (const b of sk.bones) {
      const mesh = new THREE.Mesh(cyl, material || sideMat[b.side]);
      mesh.position.fromArray(b.position);
      mesh.quaternion.fromArray(b.quaternion);
      mesh.scale.set(1, b.length, 1);
      groups[b.parent].add(mesh);
    }
    sk.parents.forEach((p, j) => { if (p >= 0) groups[p].add(groups[j]); });
    rig.add(groups[0]);
    return groups;
  }

  function tracks(prefix, m) {
    const times = f32(m.times);
    const out = [new THREE.VectorKeyframeTrack(prefix + "0.position", times, f32(m.root_position))];
    for (const j in m.quats) out.push(new THREE.QuaternionKeyframeTrack(prefix + j + ".quaternion", times, f32(m.quats[j])));
    for (const j in m.translations) out.push(new THREE.VectorKeyframeTrack(prefix + j + ".position", times, f32(m.translations[j])));
    return out;
  }

  skeleton("j", D.skeleton, null, true);
  const all = tracks("j", D.motion);
  if (D.ghost) {
    const gm = new THREE.MeshLambertMaterial({ color: D.ghost_colour, transparent: true, opacity: 0.35, depthWrite: false });
    skeleton("g", D.skeleton, gm, false);
    all.push(...tracks("g", D.ghost));
  }
  for (const j in D.highlights) {
    const h = D.highlights[j];
    all.push(new THREE.ColorKeyframeTrack("s" + j + ".material.color", f32(h.times), f32(h.colours), THREE.InterpolateDiscrete));
  }
  all.push(new THREE.VectorKeyframeTrack("rig.position", f32(D.camera.times), f32(D.camera.rig)));
  const camera = new THREE.PerspectiveCamera(D.camera.fov, W / H, D.camera.near, D.camera.far);
  const target = new THREE.Vector3().fromArray(D.camera.target);
  const offset = new THREE.Vector3().fromArray(D.camera.position).sub(target);
  const sph0 = new THREE.Spherical().setFromVector3(offset);
  function placeCamera() {
    camera.position.setFromSpherical(sph0).add(target);
    camera.lookAt(target);
  }
  placeCamera();
  const gridGeometry = new THREE.BufferGeometry();
  gridGeometry.addAttribute("position", new THREE.BufferAttribute(f32(D.grid.segments), 3));
  const grid = new THREE.LineSegments(gridGeometry, new THREE.LineBasicMaterial({ color: 0xcbd5e0 }));
  rig.add(grid);

  const clip = new THREE.AnimationClip("motion", -1, all);
  const mixer = new THREE.AnimationMixer(scene);
  const action = mixer.clipAction(clip);
  action.paused = true;
  action.play();

  // -- controls: play / pause, scrub, orbit (drag), zoom (wheel) -----------------------------------------------
  const F = D.num_frames, ft = D.frame_time;
  const playBtn = document.getElementById("sn-play");
  const scrub = document.getElementById("sn-scrub");
  const readout = document.getElementById("sn-time");
  scrub.max = String(F - 1);
  let playing = false, baseFrame = 0, baseWall = 0, frame = 0;
  function show(f) {
    frame = Math.max(0, Math.min(F - 1, f));
    action.time = frame * ft;
    mixer.update(0);
    renderer.render(scene, camera);
    scrub.value = String(Math.round(frame));
    readout.textContent = (frame * ft).toFixed(2) + " s / " + ((F - 1) * ft).toFixed(2) + " s";
    document.body.dataset.frame = String(Math.round(frame));
  }
  function loop() {
    if (!playing) return;
    let f = baseFrame + (performance.now() - baseWall) / (1000 * ft);
    if (f >= F - 1) {            // loop the clip: a page left open keeps playing
      baseFrame = 0;
      baseWall = performance.now();
      f = 0;
    }
    show(f);
    requestAnimationFrame(loop);
  }
  function setPlaying(p) {
    playing = p;
    playBtn.textContent = p ? "\u275a\u275a pause" : "\u25b6 play";
    if (p) {
      baseFrame = frame >= F - 1 ? 0 : frame;
      baseWall = performance.now();
      requestAnimationFrame(loop);
    }
  }
  playBtn.addEventListener("click", () => setPlaying(!playing));
  scrub.addEventListener("input", () => {
    const f = Number(scrub.value);
    baseFrame = f;
    baseWall = performance.now();
    show(f);
  });
  let drag = null;
  renderer.domElement.addEventListener("pointerdown", (e) => { drag = [e.clientX, e.clientY]; });
  window.addEventListener("pointerup", () => { drag = null; });
  window.addEventListener("pointermove", (e) => {
    if (!drag) return;
    sph0.theta -= (e.clientX - drag[0]) * 0.01;
    sph0.phi = Math.max(0.05, Math.min(Math.PI / 2 - 0.02, sph0.phi - (e.clientY - drag[1]) * 0.01));
    drag = [e.clientX, e.clientY];
    placeCamera();
    if (!playing) show(frame);
  });
  renderer.domElement.addEventListener("wheel", (e) => {
    e.preventDefault();
    sph0.radius *= Math.exp(e.deltaY * 0.001);
    placeCamera();
    if (!playing) show(frame);
  }, { passive: false });
  window.snPlayer = { scene, rig, camera, grid, show, get frame() { return frame; } };   // for tests and the console
  show(0);
  setPlaying(D.autoplay);
})();
