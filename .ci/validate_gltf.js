// Validates glTF files with the Khronos glTF validator (npm package gltf-validator):
// prints each file's counts and exits 1 if any has an error or a warning.
// Usage: node .ci/validate_gltf.js FILE.glb|FILE.gltf ...
const fs = require("fs");
const path = require("path");
const validator = require("gltf-validator");

async function main() {
  let failed = false;
  for (const file of process.argv.slice(2)) {
    const data = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(data, {
      uri: path.basename(file),
      maxIssues: 0,
      externalResourceFunction: (uri) =>
        new Promise((resolve, reject) => {
          fs.readFile(path.join(path.dirname(file), decodeURIComponent(uri)), (err, d) =>
            err ? reject(err.toString()) : resolve(new Uint8Array(d)));
        }),
    });
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints` +
      ` (${report.info ? report.info.totalVertexCount + " vertices, " + report.info.totalTriangleCount + " triangles" : ""})`);
    for (const m of i.messages.filter((m) => m.severity <= 1).slice(0, 20)) {
      console.log(`  ${m.severity === 0 ? "error" : "warning"} ${m.code} at ${m.pointer || ""}: ${m.message}`);
    }
    if (i.numErrors > 0 || i.numWarnings > 0) failed = true;
  }
  process.exit(failed ? 1 : 0);
}
main().catch((e) => { console.error(e); process.exit(1); });
