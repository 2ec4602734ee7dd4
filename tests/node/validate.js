// Validate glTF/GLB files with the Khronos glTF validator: node validate.js FILE...
// Prints one JSON object: {file: {errors, warnings, infos, hints, messages}} for each file.
const fs = require("fs");
const validator = require("gltf-validator");

async function main(files) {
  const out = {};
  for (const file of files) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri: file,
      maxIssues: 100,
      // a GLB holds its buffers and images: nothing external to load
      externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
    });
    const s = report.issues;
    out[file] = {
      errors: s.numErrors, warnings: s.numWarnings, infos: s.numInfos, hints: s.numHints,
      messages: s.messages.map((m) => `${m.severity} ${m.code} ${m.pointer || ""}: ${m.message}`),
    };
  }
  process.stdout.write(JSON.stringify(out) + "\n");
}

main(process.argv.slice(2)).catch((e) => { console.error(e); process.exit(1); });
