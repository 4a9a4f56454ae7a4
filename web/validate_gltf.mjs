// Validate glTF files with the Khronos glTF-Validator (npm gltf-validator); print one JSON report per file.
// Usage: node web/validate_gltf.mjs FILE.gltf [FILE.glb ...]
import { readFile } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

const reports = {};
for (const file of process.argv.slice(2)) {
  const bytes = new Uint8Array(await readFile(file));
  const folder = path.dirname(file);
  reports[file] = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 200,
    // Resources resolve beside the file, as a glTF loader resolves them.
    externalResourceFunction: async (uri) => new Uint8Array(await readFile(path.join(folder, decodeURIComponent(uri)))),
  });
}
process.stdout.write(JSON.stringify(reports));
