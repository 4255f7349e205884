#!/usr/bin/env node
// Validates glTF files (mesh.glb) with the Khronos glTF validator (not part of CTest or CI).
//
// Usage: node tools/gltf-validate.mjs [--strict] FILE.glb...
//   --strict  warnings fail too
// Prints each file's issues (errors, warnings, infos, hints) and exits 1 when a file has errors
// (or warnings with --strict), 2 on a usage error or a file that cannot be read or parsed.
// The validator is pinned in tools/gltf-validator/package-lock.json; install it once with
//   npm ci --prefix tools/gltf-validator
import { readFile } from 'node:fs/promises';
import { createRequire } from 'node:module';

const require = createRequire(new URL('./gltf-validator/package.json', import.meta.url));
let validator;
try {
  validator = require('gltf-validator');
} catch {
  console.error('gltf-validate: the validator is not installed: npm ci --prefix tools/gltf-validator');
  process.exit(2);
}

const args = process.argv.slice(2);
const strict = args.includes('--strict');
const files = args.filter((a) => a !== '--strict');
if (files.length === 0 || files.some((f) => f.startsWith('-'))) {
  console.error('usage: node tools/gltf-validate.mjs [--strict] FILE.glb...');
  process.exit(2);
}

const kSeverity = ['error', 'warning', 'info', 'hint'];
let status = 0;
for (const file of files) {
  let report;
  try {
    const bytes = new Uint8Array(await readFile(file));
    report = await validator.validateBytes(bytes, { uri: file, maxIssues: 0, writeTimestamp: false });
  } catch (error) {
    console.error(`${file}: ${error}`);
    status = 2;
    continue;
  }
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos, ` +
              `${numHints} hints (glTF validator ${validator.version()})`);
  for (const m of messages)
    console.log(`  ${kSeverity[m.severity] ?? m.severity} ${m.code}` +
                `${m.pointer ? ` at ${m.pointer}` : ''}: ${m.message}`);
  if (status === 0 && (numErrors > 0 || (strict && numWarnings > 0))) status = 1;
}
process.exit(status);
