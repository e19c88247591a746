// Khronos's glTF Validator (the npm package gltf-validator) on GLB files: one JSON
// line per file with its issue counts and messages. Run by tests/test_gltf.py as
//   node tests/gltf_validate.cjs <node_modules folder> a.glb [b.glb ...]
// (make installs the package into build/node/node_modules).
"use strict";
const fs = require("fs");
const path = require("path");

const validator = require(path.join(path.resolve(process.argv[2]), "gltf-validator"));

async function main() {
  for (const file of process.argv.slice(3)) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri: path.basename(file), maxIssues: 100, writeTimestamp: false,
    });
    const issues = report.issues;
    console.log(JSON.stringify({
      file, errors: issues.numErrors, warnings: issues.numWarnings,
      infos: issues.numInfos, hints: issues.numHints,
      messages: issues.messages.map((m) => ({severity: m.severity, code: m.code,
                                            message: m.message, pointer: m.pointer})),
    }));
  }
}

main().catch((err) => { console.error(String(err)); process.exit(1); });
