// Usage: node three_fk.mjs FILE.glb OUT.f64 -> joint world positions (F, J, 3) float64 little-endian, skin order,
// sampled by three.js (GLTFLoader + AnimationMixer) at the clip's key times; prints {frames, joints, names}
import fs from 'fs';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
const [file, out] = process.argv.slice(2);
const buf = fs.readFileSync(file);
const ab = buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength);
new GLTFLoader().parse(ab, '', (gltf) => {
  const scene = gltf.scene;
  let skinned = null;
  scene.traverse((o) => { if (o.isSkinnedMesh) skinned = o; });
  const bones = skinned.skeleton.bones;
  const clip = gltf.animations[0];
  const mixer = new THREE.AnimationMixer(scene);
  const action = mixer.clipAction(clip);
  action.setLoop(THREE.LoopOnce, 1);
  action.clampWhenFinished = true;
  action.play();
  const times = clip.tracks[0].times;
  const F = times.length, J = bones.length;
  const res = new Float64Array(F * J * 3);
  const v = new THREE.Vector3();
  for (let f = 0; f < F; f++) {
    mixer.setTime(times[f]);
    scene.updateMatrixWorld(true);
    for (let j = 0; j < J; j++) {
      bones[j].getWorldPosition(v);
      res.set([v.x, v.y, v.z], (f * J + j) * 3);
    }
  }
  fs.writeFileSync(out, Buffer.from(res.buffer));
  console.log(JSON.stringify({frames: F, joints: J, names: bones.map((b) => b.name)}));
}, (err) => { console.error(String(err)); process.exit(1); });
