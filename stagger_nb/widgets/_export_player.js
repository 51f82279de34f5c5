// The exported page's player (export.py): inflates three.js (r97, from the pythreejs package), plotly.js and the
// data pack (deflate-raw + base64 blocks, DecompressionStream), then draws the motion with the live view's mesh
// builder (_skeleton_mesh.js, inlined above this script) and the plots. Play / pause (keeps the frame), scrub,
// orbit (drag), zoom (wheel). Nothing is fetched: the page works from a file, offline.
(function () {
  "use strict";
  const status = document.getElementById("sn-status");
  const fail = (msg) => {
    status.textContent = msg;
    status.style.display = "block";
    document.body.dataset.error = msg;
  };
  if (typeof DecompressionStream === "undefined") {
    fail("This page needs a browser that can inflate its own data (DecompressionStream: Chrome 80+, " +
         "Firefox 113+, Safari 16.4+).");
    return;
  }

  async function inflate(id) {
    const bin = atob(document.getElementById(id).textContent.trim());
    const u = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) u[i] = bin.charCodeAt(i);
    const stream = new Blob([u]).stream().pipeThrough(new DecompressionStream("deflate-raw"));
    return new Uint8Array(await new Response(stream).arrayBuffer());
  }

  function runScript(bytes) {   // a library's source, run in the page's global scope (defines THREE, Plotly)
    const s = document.createElement("script");
    s.textContent = new TextDecoder().decode(bytes);
    document.head.appendChild(s);
  }

  // the pack: "SNX1", u32 header length, JSON header, arrays (export.py's _Pack)
  function unpack(u) {
    const magic = String.fromCharCode(u[0], u[1], u[2], u[3]);
    if (magic !== "SNX1") throw new Error("not a stagger_nb data pack");
    const n = new DataView(u.buffer, u.byteOffset + 4, 4).getUint32(0, true);
    const header = JSON.parse(new TextDecoder().decode(u.subarray(8, 8 + n)));
    const base = u.byteOffset + 8 + n;
    const types = { f4: Float32Array, u4: Uint32Array, i4: Int32Array, u2: Uint16Array, u1: Uint8Array };
    const arrays = {};
    for (const name in header.arrays) {
      const e = header.arrays[name];
      const T = types[e.dtype];
      const raw = new T(u.buffer, base + e.offset, e.nbytes / T.BYTES_PER_ELEMENT);
      if (e.codec === "q16d2") {   // zigzag second differences along the frames (low bytes, then high) -> positions
        const F = e.shape[0], n = raw.length / 2, C = n / F, D = e.shape[e.shape.length - 1];
        const out = new Float32Array(n), d1 = new Uint16Array(C), q = new Uint16Array(C);
        for (let f = 0, i = 0; f < F; f++) {
          for (let c = 0; c < C; c++, i++) {
            const zz = raw[i] | (raw[n + i] << 8);
            const d2 = (zz >>> 1) ^ -(zz & 1);
            d1[c] = (d1[c] + d2) & 0xffff;
            q[c] = (q[c] + d1[c]) & 0xffff;
            out[i] = e.lo[c % D] + q[c] * e.step;
          }
        }
        arrays[name] = out;
      } else {
        arrays[name] = raw;
      }
    }
    return { header, arrays };
  }

  function withArrays(v, arrays) {   // figures: {"__sn__": name} -> the typed array
    if (Array.isArray(v)) return v.map((x) => withArrays(x, arrays));
    if (v && typeof v === "object") {
      if (typeof v.__sn__ === "string") return arrays[v.__sn__];
      const o = {};
      for (const k in v) o[k] = withArrays(v[k], arrays);
      return o;
    }
    return v;
  }

  function player(P) {
    const H = P.header, A = P.arrays;
    const box = document.getElementById("sn-view");
    const W = H.width, Hh = H.height, F = H.num_frames, NP = H.num_points, ft = H.frame_time;
    const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    renderer.setSize(W, Hh);
    renderer.setClearColor(0xffffff, 1);
    box.insertBefore(renderer.domElement, box.firstChild);
    const scene = new THREE.Scene();
    scene.add(new THREE.HemisphereLight(0xffffff, 0xa0aec0, 1.1));
    const rig = new THREE.Group();
    rig.name = "rig";
    scene.add(rig);
    const d = { J: H.num_joints, vs: H.sphere_vertices, vt: H.tube_vertices, segs: H.segments, tpl: A.template,
                jr: H.joint_radius, br: H.bone_radius, scale: 1 };
    const V = d.J * d.vs + (d.segs.length / 2) * d.vt;
    // the merged mesh's triangles: the template's, offset for each joint's sphere and each bone's tube
    const index = new (V < 65536 ? Uint16Array : Uint32Array)(d.J * A.sphere_index.length +
                                                             (d.segs.length / 2) * A.tube_index.length);
    let ii = 0;
    for (let j = 0; j < d.J; j++) for (const t of A.sphere_index) index[ii++] = t + j * d.vs;
    for (let b = 0; b < d.segs.length / 2; b++) for (const t of A.tube_index) index[ii++] = t + d.J * d.vs + b * d.vt;
    const none = new Set();

    function mesh(material, colours) {
      const g = new THREE.BufferGeometry();
      g.setIndex(new THREE.BufferAttribute(index, 1));
      const pos = new THREE.BufferAttribute(new Float32Array(V * 3), 3);
      const nrm = new THREE.BufferAttribute(new Float32Array(V * 3), 3);
      pos.dynamic = nrm.dynamic = true;
      snSphereNormals(d, nrm.array);
      g.addAttribute("position", pos);
      g.addAttribute("normal", nrm);
      if (colours) {
        const col = new THREE.BufferAttribute(new Float32Array(V * 3), 3);
        const bc = A.bone_colours;   // (B, 3): every vertex of bone b's tube
        for (let b = 0, v = d.J * d.vs; b < d.segs.length / 2; b++) {
          for (let k = 0; k < d.vt; k++, v++) {
            col.array[3 * v] = bc[3 * b]; col.array[3 * v + 1] = bc[3 * b + 1]; col.array[3 * v + 2] = bc[3 * b + 2];
          }
        }
        col.dynamic = true;
        g.addAttribute("color", col);
      }
      const m = new THREE.Mesh(g, material);
      m.frustumCulled = false;
      rig.add(m);
      return m;
    }
    const skel = mesh(new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors }), true);
    skel.name = "skeleton";
    const ghost = H.has_ghost ? mesh(new THREE.MeshLambertMaterial({ color: H.ghost_colour, transparent: true,
                                                                      opacity: 0.35, depthWrite: false }), false)
                              : null;
    const gridGeometry = new THREE.BufferGeometry();
    gridGeometry.addAttribute("position", new THREE.BufferAttribute(A.grid, 3));
    rig.add(new THREE.LineSegments(gridGeometry, new THREE.LineBasicMaterial({ color: 0xcbd5e0 })));
    document.getElementById("sn-grid-note").textContent =
      `grid square: ${+H.grid_cell.toPrecision(6)} units · drag to orbit, wheel to zoom`;

    const camera = new THREE.PerspectiveCamera(H.camera.fov, W / Hh, H.camera.near, H.camera.far);
    const target = new THREE.Vector3().fromArray(H.camera.target);
    const sph0 = new THREE.Spherical().setFromVector3(new THREE.Vector3().fromArray(H.camera.position).sub(target));
    function placeCamera() {
      camera.position.setFromSpherical(sph0).add(target);
      camera.lookAt(target);
    }
    placeCamera();

    const buf = new Float32Array(NP * 3), gbuf = new Float32Array(NP * 3);
    let colourKey = null;
    function draw(f) {
      if (snPointsAt(A.points, F, NP, f, buf)) {
        const g = skel.geometry;
        snMeshVertices(d, buf, none, g.attributes.position.array, g.attributes.normal.array);
        g.attributes.position.needsUpdate = g.attributes.normal.needsUpdate = true;
        const fi = Math.min(Math.max(Math.round(f), 0), F - 1);
        const row = A.states.length >= F * d.J ? A.states.subarray(fi * d.J, (fi + 1) * d.J) : null;
        const key = snJointColours(d, row, none, H.palette, g.attributes.color.array, colourKey);
        if (key !== colourKey) { colourKey = key; g.attributes.color.needsUpdate = true; }
        g.computeBoundingSphere();
      }
      if (ghost && snPointsAt(A.ghost, A.ghost.length / (NP * 3), NP, f, gbuf)) {
        const g = ghost.geometry;
        snMeshVertices(d, gbuf, none, g.attributes.position.array, g.attributes.normal.array);
        g.attributes.position.needsUpdate = g.attributes.normal.needsUpdate = true;
      }
      const fc = Math.min(Math.max(f, 0), F - 1), f0 = Math.floor(fc), f1 = Math.min(f0 + 1, F - 1), u = fc - f0;
      rig.position.set(...[0, 1, 2].map((k) => A.rig[3 * f0 + k] + u * (A.rig[3 * f1 + k] - A.rig[3 * f0 + k])));
      renderer.render(scene, camera);
    }

    // -- controls: play / pause (keeps the frame), scrub, orbit (drag), zoom (wheel) -------------------------------
    const playBtn = document.getElementById("sn-play");
    const scrub = document.getElementById("sn-scrub");
    const readout = document.getElementById("sn-time");
    scrub.max = String(F - 1);
    let playing = false, baseFrame = 0, baseWall = 0, frame = 0;
    function show(f) {
      frame = Math.max(0, Math.min(F - 1, f));
      draw(frame);
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
    window.snPlayer = { scene, rig, camera, show, setPlaying, get frame() { return frame; },
                        get playing() { return playing; } };
    show(0);
    setPlaying(H.autoplay);
  }

  (async () => {
    try {
      const [three, plotly, data] = await Promise.all(["sn-lib-three", "sn-lib-plotly", "sn-data"].map(inflate));
      runScript(three);
      runScript(plotly);
      const P = unpack(data);
      player(P);
      (P.header.figures || []).forEach((f, i) => {
        const fig = withArrays(f, P.arrays);
        Plotly.newPlot("sn-plot-" + i, fig.data, fig.layout, { displaylogo: false, responsive: true });
      });
      status.textContent = "";
      status.style.display = "none";
      document.body.dataset.ready = "1";
    } catch (err) {
      fail("stagger_nb: the page could not be drawn: " + err);
      throw err;
    }
  })();
})();
