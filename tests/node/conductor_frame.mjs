// Usage: node conductor_frame.mjs STATE.json OUT.f32
// Runs stagger_nb/widgets/_conductor.js (the real module, after _skeleton_mesh.js) against stand-in models: STATE.json holds the conductor's
// traits (buffers as base64), the sizes of the skeleton mesh's attributes and the frame to show. Writes what the
// clock wrote into the mesh: positions (V, 3) then normals (V, 3) then colours (V, 3), float32, and prints
// {"shown_frame", "rig"} (the rig position it set).
import fs from 'fs';
import path from 'path';
import { fileURLToPath, pathToFileURL } from 'url';

const [stateFile, out] = process.argv.slice(2);
const st = JSON.parse(fs.readFileSync(stateFile, 'utf8'));
const here = path.dirname(fileURLToPath(import.meta.url));
// the module as the kernel sends it: the one mesh builder, then the clock (skeleton_view.py joins them)
const widgets = path.join(here, '..', '..', 'stagger_nb', 'widgets');
const src = fs.readFileSync(path.join(widgets, '_skeleton_mesh.js'), 'utf8') +
  fs.readFileSync(path.join(widgets, '_conductor.js'), 'utf8');
const mod = await import('data:text/javascript;base64,' + Buffer.from(src).toString('base64'));

function evented(values, obj) {
  const handlers = {};
  return {
    obj, values,
    get: (k) => values[k],
    set: (k, v) => { values[k] = v; (handlers[`change:${k}`] || []).forEach((h) => h()); },
    save_changes: () => {},
    on: (e, h) => { (handlers[e] = handlers[e] || []).push(h); },
    off: (e, h) => { handlers[e] = (handlers[e] || []).filter((x) => x !== h); },
    trigger: () => {},
  };
}
const V = st.vertices;
class Attr { constructor(array, itemSize) { this.array = array; this.itemSize = itemSize; } }
const attr = (n, init) => new Attr(init ? Float32Array.from(init) : new Float32Array(n * 3), 3);
// the kernel's arrays: positions zero, the constant normals and colours (the clock copies them, then writes)
const geometry = { attributes: { position: attr(V), normal: attr(V, st.normal), color: attr(V, st.color) },
  computeBoundingSphere() {},
  addAttribute(name, a) { this.attributes[name] = a; } };
const position = { x: 0, y: 0, z: 0, set(x, y, z) { Object.assign(this, { x, y, z }); } };
const models = {
  player: evented({ value: st.frame, max: st.traits.num_frames - 1, playing: false, step: 1 }),
  scene: evented({}),
  rig: evented({}, { position }),
  skeleton: evented({}, { geometry, visible: true }),
};
const traits = { ...st.traits };
for (const k of st.buffers) {
  const b = Buffer.from(traits[k], 'base64');
  traits[k] = new DataView(b.buffer, b.byteOffset, b.byteLength);
}
for (const k of Object.keys(models)) traits[k] = `IPY_MODEL_${k}`;
const model = evented(traits);
model.widget_manager = { get_model: async (id) => models[id] };
mod.default.initialize({ model });
await new Promise((r) => setTimeout(r, 50));
const a = geometry.attributes;
const res = new Float32Array(9 * V);
res.set(a.position.array, 0); res.set(a.normal.array, 3 * V); res.set(a.color.array, 6 * V);
fs.writeFileSync(out, Buffer.from(res.buffer));
console.log(JSON.stringify({ shown_frame: traits.shown_frame, rig: [position.x, position.y, position.z] }));
