// Usage: node validate.mjs FILE... -> one JSON line per file: the Khronos glTF validator's counts and messages
import fs from 'fs';
import { validateBytes } from 'gltf-validator';
for (const f of process.argv.slice(2)) {
  const r = await validateBytes(new Uint8Array(fs.readFileSync(f)));
  const i = r.issues;
  console.log(JSON.stringify({ file: f, errors: i.numErrors, warnings: i.numWarnings, infos: i.numInfos,
    hints: i.numHints, messages: i.messages }));
}
