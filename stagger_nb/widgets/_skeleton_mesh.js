// The one builder of the skeleton mesh (plain functions on typed arrays, no three.js): the 3D view's clock
// (_conductor.js, which this file is prepended to) and the exported page's player (_export_player.js, inlined
// before it) both draw a frame with it. The mesh is a unit sphere per joint (`tpl` rows 0 .. vs - 1) and a unit
// tube per bone (rows vs .. vs + vt - 1), each row (x, y, z, nx, ny, nz) (stagger_nb.scene3d.mesh_template),
// placed by the world points of the frame: spheres of radius `jr` (x `scale` when selected) at the joints,
// tubes of radius `br` from a bone's parent point to its child point.
//   d = {J, vs, vt, segs (flat point-index pairs), tpl (Float32Array), jr, br, scale}

// points of frame f (fractional: linear between frames, clamped to [0, n - 1]) of src (n, P, 3) into out
function snPointsAt(src, n, P, f, out) {
  if (src.length < n * P * 3 || n < 1) return false;
  const fc = Math.min(Math.max(f, 0), n - 1);
  const f0 = Math.floor(fc), f1 = Math.min(f0 + 1, n - 1), u = fc - f0;
  const a = f0 * P * 3, b = f1 * P * 3;
  for (let i = 0; i < P * 3; i++) out[i] = src[a + i] + u * (src[b + i] - src[a + i]);
  return true;
}

// vertex positions (and the tubes' normals: the spheres' never change) of one frame into pos / nrm (V * 3)
function snMeshVertices(d, pts, selected, pos, nrm) {
  const T = d.tpl;
  const nv = d.J * d.vs + (d.segs.length / 2) * d.vt;
  if (pos.length < nv * 3 || T.length < (d.vs + d.vt) * 6) return false;
  let v = 0;
  for (let j = 0; j < d.J; j++) {
    const r = d.jr * (selected.has(j) ? d.scale : 1);
    const cx = pts[3 * j], cy = pts[3 * j + 1], cz = pts[3 * j + 2];
    for (let k = 0; k < d.vs; k++, v++) {
      pos[3 * v] = cx + r * T[6 * k];
      pos[3 * v + 1] = cy + r * T[6 * k + 1];
      pos[3 * v + 2] = cz + r * T[6 * k + 2];
    }
  }
  const t0 = d.vs * 6, br = d.br;
  for (let i = 0; i < d.segs.length; i += 2) {
    const a = 3 * d.segs[i], b = 3 * d.segs[i + 1];
    const ax = pts[a], ay = pts[a + 1], az = pts[a + 2];
    let dx = pts[b] - ax, dy = pts[b + 1] - ay, dz = pts[b + 2] - az;
    const L = Math.hypot(dx, dy, dz);
    if (L > 1e-12) { dx /= L; dy /= L; dz /= L; } else { dx = 0; dy = 1; dz = 0; }
    // the bone's frame: y along it; helper +x, or +z when the bone is nearly along x; x = y × helper, z = x × y
    const hx = Math.abs(dx) < 0.9 ? 1 : 0, hz = 1 - hx;
    let xx = dy * hz, xy = dz * hx - dx * hz, xz = -dy * hx;
    const xl = Math.hypot(xx, xy, xz) || 1;
    xx /= xl; xy /= xl; xz /= xl;
    const zx = xy * dz - xz * dy, zy = xz * dx - xx * dz, zz = xx * dy - xy * dx;
    for (let k = 0; k < d.vt; k++, v++) {
      const o = t0 + 6 * k;
      const tx = T[o] * br, ty = T[o + 1] * L, tz = T[o + 2] * br;
      pos[3 * v] = ax + tx * xx + ty * dx + tz * zx;
      pos[3 * v + 1] = ay + tx * xy + ty * dy + tz * zy;
      pos[3 * v + 2] = az + tx * xz + ty * dz + tz * zz;
      const nx = T[o + 3], ny = T[o + 4], nz = T[o + 5];
      nrm[3 * v] = nx * xx + ny * dx + nz * zx;
      nrm[3 * v + 1] = nx * xy + ny * dy + nz * zy;
      nrm[3 * v + 2] = nx * xz + ny * dz + nz * zz;
    }
  }
  return true;
}

// the spheres' normals (the unit sphere's own, constant) into nrm
function snSphereNormals(d, nrm) {
  const T = d.tpl;
  for (let j = 0, v = 0; j < d.J; j++) {
    for (let k = 0; k < d.vs; k++, v++) {
      nrm[3 * v] = T[6 * k + 3]; nrm[3 * v + 1] = T[6 * k + 4]; nrm[3 * v + 2] = T[6 * k + 5];
    }
  }
}

// the joints' sphere colours of one frame: palette[state] (0 plain, 1 pose, 2 contact), palette[3] when
// selected; `row` is the frame's (J,) state bytes or null. Returns the key of what was written; writes nothing
// when it equals `lastKey`.
function snJointColours(d, row, selected, palette, col, lastKey) {
  let key = "";
  for (let j = 0; j < d.J; j++) key += selected.has(j) ? 3 : (row ? row[j] : 0);
  if (key === lastKey) return key;
  for (let j = 0; j < d.J; j++) {
    const rgb = palette[+key[j]];
    for (let k = 0, v = j * d.vs; k < d.vs; k++, v++) {
      col[3 * v] = rgb[0]; col[3 * v + 1] = rgb[1]; col[3 * v + 2] = rgb[2];
    }
  }
  return key;
}
