// Runs the Khronos glTF-Validator on GLB files written by `vsaqem reconstruct -o MESH.glb`
// and prints its counts and messages; exits 1 when it reports an error or a warning.
//
//   npm install --prefix /tmp/gltfval gltf-validator
//   NODE_PATH=/tmp/gltfval/node_modules node bench/gltf_validate.js mesh.glb ...
//
// For benchmarks only, like everything in bench/; the Rust tests check the structure
// without it (host/tests/common/glb.rs).
let validator;
try {
  validator = require('gltf-validator');
} catch (e) {
  console.log('skipped: needs the npm package gltf-validator (see the top of this file)');
  process.exit(0);
}
const fs = require('fs');
(async () => {
  let bad = 0;
  for (const file of process.argv.slice(2)) {
    const r = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)));
    const i = r.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints`);
    for (const m of i.messages) console.log(`  ${m.severity} ${m.code} ${m.pointer || ''} ${m.message}`);
    bad += i.numErrors + i.numWarnings;
  }
  process.exit(bad > 0 ? 1 : 0);
})();
