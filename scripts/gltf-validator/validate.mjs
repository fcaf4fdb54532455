// The Khronos glTF Validator on one .glb or .gltf file: prints its report as JSON on stdout.
//   node scripts/gltf-validator/validate.mjs FILE
// (install it first: npm ci --prefix scripts/gltf-validator; scripts/setup.sh test does this where npm is)
// Exit status: 0 when the report has no errors and no warnings, 1 when it has some, 2 when the file
// could not be read or was not recognised as glTF.
import { readFile } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

const file = process.argv[2];
if (!file) {
  console.error("usage: node validate.mjs FILE.glb|FILE.gltf");
  process.exit(2);
}
try {
  const report = await validator.validateBytes(new Uint8Array(await readFile(file)), {
    uri: path.basename(file),
    maxIssues: 0, // every issue
    externalResourceFunction: async (uri) =>
      new Uint8Array(await readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)))),
  });
  console.log(JSON.stringify(report, null, 1));
  process.exit(report.issues.numErrors + report.issues.numWarnings > 0 ? 1 : 0);
} catch (error) {
  console.error(`${file}: ${error}`);
  process.exit(2);
}
