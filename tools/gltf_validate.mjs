// Validate glTF/GLB files with the Khronos glTF validator (npm "gltf-validator").
//
// Usage: node tools/gltf_validate.mjs FILE [FILE ...]
// Prints one JSON object per line: {"file", "errors", "warnings", "infos", "hints", "messages"}
// where "messages" lists the error and warning issues (code, message, pointer).
// Exit code: 0 when every file has 0 errors and 0 warnings, 1 otherwise, 2 on bad usage.
import { readFile } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error("usage: node tools/gltf_validate.mjs FILE [FILE ...]");
  process.exit(2);
}

let failed = false;
for (const file of files) {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 200,
    externalResourceFunction: async (uri) =>
      new Uint8Array(await readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)))),
  });
  const issues = report.issues;
  const messages = issues.messages
    .filter((m) => m.severity <= 1)
    .map((m) => ({ code: m.code, message: m.message, pointer: m.pointer ?? null, severity: m.severity }));
  console.log(
    JSON.stringify({
      file,
      errors: issues.numErrors,
      warnings: issues.numWarnings,
      infos: issues.numInfos,
      hints: issues.numHints,
      messages,
    }),
  );
  if (issues.numErrors > 0 || issues.numWarnings > 0) failed = true;
}
process.exit(failed ? 1 : 0);
