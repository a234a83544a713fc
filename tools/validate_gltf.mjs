#!/usr/bin/env node
// Validate glTF 2.0 files (.gltf or .glb) with the Khronos glTF validator
// (npm package gltf-validator, installed into ./node_modules by `make test`).
//
//   node tools/validate_gltf.mjs FILE [FILE ...]
//
// Prints one JSON object per file on its own line:
//   {"file", "validatorVersion", "numErrors", "numWarnings", "numInfos",
//    "numHints", "messages": [{"code", "severity", "message", "pointer"}],
//    "extensionsUsed"}
// Exit status: 0 when no file has an error or a warning, 1 otherwise,
// 2 for bad usage or an unreadable file.
import { readFile } from "node:fs/promises";
import path from "node:path";
import { createRequire } from "node:module";

const require = createRequire(import.meta.url);
let validator;
try {
  validator = require("gltf-validator");
} catch (err) {
  console.error("validate_gltf: the npm package gltf-validator is not installed (run `npm ci` in the repository root)");
  process.exit(2);
}

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error("usage: node tools/validate_gltf.mjs FILE [FILE ...]");
  process.exit(2);
}

let clean = true;
for (const file of files) {
  let bytes;
  try {
    bytes = await readFile(file);
  } catch (err) {
    console.error(`validate_gltf: cannot read ${file}: ${err.message}`);
    process.exit(2);
  }
  const report = await validator.validateBytes(new Uint8Array(bytes), {
    uri: path.basename(file),
    maxIssues: 0,
    writeTimestamp: false,
    externalResourceFunction: (uri) =>
      readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then((d) => new Uint8Array(d)),
  });
  const issues = report.issues;
  const severities = ["error", "warning", "info", "hint"];
  const out = {
    file,
    validatorVersion: report.validatorVersion,
    numErrors: issues.numErrors,
    numWarnings: issues.numWarnings,
    numInfos: issues.numInfos,
    numHints: issues.numHints,
    messages: issues.messages.map((m) => ({
      code: m.code,
      severity: severities[m.severity] ?? String(m.severity),
      message: m.message,
      pointer: m.pointer,
    })),
    extensionsUsed: report.info ? report.info.extensionsUsed || [] : [],
  };
  console.log(JSON.stringify(out));
  if (issues.numErrors > 0 || issues.numWarnings > 0) clean = false;
}
process.exit(clean ? 0 : 1);
