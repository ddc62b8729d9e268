// service/openapi.json under Redocly CLI's `recommended` ruleset (service/redocly.yaml), offline: fails on any
// error or warning. The document's Scene refers to the served JSON Schema (`schema/scene`, relative to the API);
// the lint resolves it against `runout schema`'s output written beside a copy of the document, so the scene
// schema is checked too (as schema/scene.json: Redocly parses a file by its extension).
//
//   node tests/service/openapi_lint.mjs --runout BUILD/runout --redocly BUILD/web-npm/node_modules/.bin/redocly \
//        --openapi service/openapi.json --config service/redocly.yaml
import { execFileSync, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';

const { values: args } = parseArgs({
  options: { runout: { type: 'string' }, redocly: { type: 'string' }, openapi: { type: 'string' }, config: { type: 'string' } },
});
for (const k of ['runout', 'redocly', 'openapi', 'config'])
  if (!args[k]) {
    console.error(`openapi_lint: --${k} is required`);
    process.exit(2);
  }

const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'runout-openapi-lint-'));
const text = fs.readFileSync(args.openapi, 'utf8');
const ref = '"$ref": "schema/scene"';
if (text.split(ref).length !== 2) {
  console.error(`openapi_lint: expected the Scene schema's ${ref} once in ${args.openapi}`);
  process.exit(1);
}
fs.writeFileSync(path.join(dir, 'openapi.json'), text.replace(ref, '"$ref": "schema/scene.json"'));
fs.mkdirSync(path.join(dir, 'schema'));
fs.writeFileSync(path.join(dir, 'schema', 'scene.json'), execFileSync(args.runout, ['schema']));
fs.copyFileSync(args.config, path.join(dir, 'redocly.yaml'));

const r = spawnSync(path.resolve(args.redocly), ['lint', 'openapi.json', '--config', 'redocly.yaml', '--format', 'json'], {
  cwd: dir,
  encoding: 'utf8',
  // Offline and quiet: no usage data sent, no update check.
  env: { ...process.env, REDOCLY_TELEMETRY: 'off', REDOCLY_SUPPRESS_UPDATE_NOTICE: 'true', CI: 'true' },
  timeout: 120000,
});
let report = null;
try {
  report = JSON.parse(r.stdout);
} catch {
  /* below */
}
if (!report || typeof report !== 'object') {
  console.error(`openapi_lint: redocly gave no JSON report (${r.error ?? `exit ${r.status}`}):\n${r.stdout}\n${r.stderr}`);
  process.exit(1);
}
const problems = report.problems || [];
for (const p of problems) {
  const at = p.location?.[0];
  console.error(`${p.severity} ${p.ruleId}: ${p.message} (${at?.source?.ref ?? ''} ${at?.pointer ?? ''})`);
}
fs.rmSync(dir, { recursive: true, force: true });
if (problems.length > 0 || r.status !== 0) {
  console.error(`openapi_lint: FAILED: ${problems.length} problem(s), redocly exit ${r.status}`);
  process.exit(1);
}
console.log('openapi_lint: service/openapi.json is clean under the recommended ruleset');
