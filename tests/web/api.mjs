// The endpoints the page added to the API (docs/service.md, docs/web.md): POST /api/v1/estimate and
// GET /api/v1/jobs/{id}/map.json, against the real `runout serve`.
//  - estimate: the particle counts are the job's (the tiny 2D dam break of tests/service: 100 fluid + 168
//    boundary at dp 0.02), the steps and seconds follow the cost model's documented formula from its own inputs, the errors
//    are POST /jobs's (a problem document listing every invalid field), it needs the token when there is one, and it writes nothing;
//  - map.json: 409 before the job has results, 404 for a 2D job; for a flume layout the extent equals the
//    raster's cells and the geometries are the resolved scene's; its raster layers with their colour scales,
//    each rasters/{name}.png an RGBA PNG of a pixel per cell; the hillshade;
//  - compare: the decision metrics first, the layouts ranked by the outlet's peak discharge.
//
//   node tests/web/api.mjs --runout BUILD/runout --flume scenarios/flume
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';

const { values: args } = parseArgs({ options: { runout: { type: 'string' }, flume: { type: 'string' } } });
if (!args.runout || !args.flume) {
  console.error('api: --runout and --flume are required');
  process.exit(2);
}

let passed = 0;
const failures = [];
const check = (ok, what) => (ok ? passed++ : failures.push(what));
const equal = (a, b, what) => check(JSON.stringify(a) === JSON.stringify(b), `${what}: got ${JSON.stringify(a)}, expected ${JSON.stringify(b)}`);

function start(dir, extra, env = {}) {
  fs.mkdirSync(dir, { recursive: true });
  return new Promise((resolve, reject) => {
    const child = spawn(args.runout, ['serve', '--port', '0', '--db', path.join(dir, 'runout.db'), '--runs', path.join(dir, 'runs'),
      '--threads-per-job', '1', '--scene-dir', path.resolve(args.flume), ...extra], { stdio: ['ignore', 'pipe', 'pipe'], env: { ...process.env, ...env } });
    let out = '';
    child.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/listening on (http:\/\/[0-9.]+:[0-9]+)/);
      if (m) resolve({ child, base: `${m[1]}/api/v1` });
    });
    child.once('exit', (code) => reject(new Error(`runout serve exited (${code}): ${out}`)));
  });
}
const stop = (s) => new Promise((resolve) => {
  if (s.child.exitCode !== null) return resolve(s.child.exitCode);
  s.child.once('exit', resolve);
  s.child.kill('SIGTERM');
});

async function call(s, method, p, body, headers = {}) {
  const res = await fetch(s.base + p, {
    method,
    headers: body === undefined ? headers : { 'Content-Type': 'application/json', ...headers },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  const text = await res.text();
  let json = null;
  try {
    json = JSON.parse(text);
  } catch {
    /* not JSON */
  }
  return { status: res.status, json, text, type: res.headers.get('content-type') || '' };
}

async function waitDone(s, id, seconds) {
  const until = Date.now() + seconds * 1000;
  for (;;) {
    const j = (await call(s, 'GET', `/jobs/${id}`)).json;
    if (['done', 'failed', 'cancelled'].includes(j.status) || Date.now() > until) return j;
    await new Promise((r) => setTimeout(r, 300));
  }
}

// tests/service/service_harness.hpp tiny_scene: a 0.2 x 0.2 m water column in a 0.4 x 0.3 m tank.
const tiny = (name, duration = 0.05, dp = 0.02) => ({
  name, dimensions: 2, dp, duration,
  materials: [{ name: 'water', rheology: 'newtonian', density: 1000, viscosity: 0.001 }],
  fluid: [{ min: [0, 0], max: [0.2, 0.2], material: 'water' }],
  boundaries: [{ type: 'tank', min: [0, 0], max: [0.4, 0.3] }],
});

const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'runout-web-api-'));
const servers = [];
try {
  const s = await start(path.join(scratch, 'a'), ['--workers', '1']);
  servers.push(s);

  // The estimate of the tiny scene: the job's particle count, the formula's steps.
  const body = { scene: tiny('est'), fidelity: 'standard' };
  const e = await call(s, 'POST', '/estimate', body);
  equal(e.status, 200, 'POST /estimate');
  equal([e.json.particles.fluid, e.json.particles.boundary, e.json.particles.total], [100, 168, 268], 'particles (fluid, boundary, total) of the tiny scene at dp 0.02');
  const m = e.json.model;
  check(m.dt_s > 0 && m.duration_s === 0.05 && m.threads === 1 && m.step_ratio > 0 && m.a_fluid_s > 0, `model inputs ${JSON.stringify(m)}`);
  equal([m.fluid_mean, m.boundary], [100, 168], 'the cost model sees the built scene (no inlet: fluid_mean = fluid)');
  equal(e.json.steps_estimate, Math.ceil(m.step_ratio * m.duration_s / m.dt_s), 'steps = ceil(step_ratio duration / dt0)');
  equal([m.boundary_fixed, m.bed, e.json.particles.boundary_peak_estimate], [168, 0, 168], 'no terrain: every wall is fixed and alive');
  equal(m.flow_model, 'sph3d', 'a 3D scene is priced by the SPH coefficients');
  const perStep = m.a_fluid_s * m.fluid_mean * m.neighbours * m.passes + m.b_fluid_s * m.fluid_mean + m.b_boundary_s * e.json.particles.boundary_peak_estimate + m.c_step_s;
  const seconds = e.json.steps_estimate * perStep;  // one thread
  check(Math.abs(e.json.seconds_estimate - seconds) <= 1e-9 * seconds, `seconds = steps x per-step cost (${e.json.seconds_estimate} vs ${seconds})`);
  equal((await call(s, 'GET', '/jobs')).json.total, 0, 'an estimate writes no job');

  // Its errors are POST /jobs's, field and message.
  for (const bad of [
    { scene: tiny('bad'), fidelity: { dp: -1 } },
    { scene: { ...tiny('bad'), materials: [{ name: 'water', rheology: 'newtonian', density: -5, viscosity: 0.001 }] } },
    { scene: tiny('bad'), fidelity: 'coarse' },
    { scene_id: 99 },
    { scene: tiny('bad'), extra: 1 },
  ]) {
    const a = await call(s, 'POST', '/estimate', bad);
    const b = await call(s, 'POST', '/jobs', bad);
    check(a.status >= 400 && a.status < 500, `estimate refuses ${JSON.stringify(bad).slice(0, 80)}: ${a.status}`);
    equal([a.status, a.json?.type, a.json?.errors], [b.status, b.json?.type, b.json?.errors],
      `estimate and POST /jobs give the same problem for ${JSON.stringify(bad).slice(0, 80)}`);
  }
  // A refusal is a problem document listing every invalid field (what web/api.js reads into ApiError.errors).
  const two = await call(s, 'POST', '/estimate', { scene: tiny('bad'), fidelity: 'coarse', colour: 'red' });
  equal([two.status, two.type], [422, 'application/problem+json'], 'a refused estimate is a problem document');
  equal((two.json?.errors || []).map((x) => x.field), ['colour', 'fidelity'], 'both invalid fields are listed');
  equal(two.json?.instance, '/api/v1/estimate', 'the problem names the request path');
  equal((await call(s, 'GET', '/jobs')).json.total, 0, 'refused submissions write no job');

  // A job of the same body: the particles the estimate said.
  const job = await call(s, 'POST', '/jobs', body);
  equal(job.status, 201, 'POST /jobs');
  equal(job.json.particles, e.json.particles.total, 'the job\'s particles equal the estimate\'s');

  // map.json: a 2D job has no map.
  const queued = await call(s, 'GET', `/jobs/${job.json.id}/map.json`);
  check([409, 200, 404].includes(queued.status), `map.json while queued: ${queued.status}`);
  const done = await waitDone(s, job.json.id, 120);
  equal(done.status, 'done', 'the tiny job finishes');
  const flat = await call(s, 'GET', `/jobs/${job.json.id}/map.json`);
  equal(flat.status, 404, 'map.json of a 2D job');
  equal(flat.json?.errors?.[0]?.field, 'id', 'the 404 names the job');
  equal((await call(s, 'GET', '/jobs/999/map.json')).status, 404, 'map.json of no job');

  // A flume layout (coarse, short): the map's extent and overlays.
  const flume = JSON.parse(fs.readFileSync(path.join(args.flume, 'flume.json'), 'utf8'));
  flume.duration = 0.05;
  const dam = flume.structures.find((x) => x.type === 'check_dam');
  const fj = await call(s, 'POST', '/jobs', { base: flume, structures: [dam.name], fidelity: { dp: 0.06 } });
  equal(fj.status, 201, 'flume job');
  const early = await call(s, 'GET', `/jobs/${fj.json.id}/map.json`);
  check(early.status === 409 || early.status === 200, `map.json before the job is done: ${early.status}`);
  equal((await waitDone(s, fj.json.id, 300)).status, 'done', 'the flume job finishes');
  const mj = await call(s, 'GET', `/jobs/${fj.json.id}/map.json`);
  equal(mj.status, 200, 'map.json of a terrain job');
  const r = mj.json.raster;
  check(r.nx > 0 && r.ny > 0 && r.dx > 0 && r.dy > 0, `raster size ${JSON.stringify(r)}`);
  check(Math.abs(r.east - (r.west + r.nx * r.dx)) < 1e-6 && Math.abs(r.south - (r.north - r.ny * r.dy)) < 1e-6, 'extent = cells x size');
  // The flume's corridor polygon lies inside the raster (the raster is a window around it).
  for (const [x, y] of flume.terrain.corridor.polygon)
    check(x >= r.west - 1e-6 && x <= r.east + 1e-6 && y >= r.south - 1e-6 && y <= r.north + 1e-6, `corridor vertex ${x},${y} inside the map`);
  check(/UTM zone 32N/.test(mj.json.crs), `the CRS is named: ${mj.json.crs}`);
  equal(mj.json.image, `/api/v1/jobs/${fj.json.id}/map.png`, 'the image path');
  equal(mj.json.structures.map((x) => [x.name, x.type, x.geometry.type]), [[dam.name, 'check_dam', 'LineString']], 'the layout\'s structures only');
  equal(mj.json.structures[0].geometry.coordinates, dam.axis, 'the dam\'s axis, as in the scene');
  equal(mj.json.protected_zones.map((z) => z.name), flume.protected_zones.map((z) => z.name), 'protected zones');
  const z0 = flume.protected_zones[0].polygon;
  equal(mj.json.protected_zones[0].geometry.coordinates, [[...z0, z0[0]]], 'a zone polygon, closed');
  equal(mj.json.sections.map((x) => x.series), flume.monitors.filter((x) => x.type === 'section').map((x) => `section_${x.name}`), 'sections and their series');
  const png = await fetch(`${s.base}/jobs/${fj.json.id}/map.png`);
  const bytes = Buffer.from(await png.arrayBuffer());
  // PNG IHDR: width and height at bytes 16-23; the picture enlarges every cell by the same whole factor.
  const w = bytes.readUInt32BE(16), h = bytes.readUInt32BE(20);
  check(w % r.nx === 0 && h % r.ny === 0 && w / r.nx === h / r.ny, `map.png ${w}x${h} is the ${r.nx}x${r.ny} cells enlarged`);

  // The coloured rasters: map.json lists them with their colour scales; each PNG is RGBA, a pixel per cell.
  equal(mj.json.layers.map((l) => l.name), ['max_depth', 'max_speed', 'max_pressure', 'intensity', 'arrival_time', 'max_hv', 'deposit_depth'], 'map layers');
  for (const l of mj.json.layers) {
    equal([l.image, l.download], [`/api/v1/jobs/${fj.json.id}/rasters/${l.name}.png`, `/api/v1/jobs/${fj.json.id}/rasters/${l.name}.tif`], `${l.name} paths`);
    const st = l.scale.stops;
    check(st.length >= 3 && st.every((x, k) => k === 0 || x.value > st[k - 1].value) && l.scale.min === st[0].value && l.scale.max === st[st.length - 1].value,
      `${l.name} scale ascending from min to max: ${JSON.stringify(l.scale)}`);
    const pic = await fetch(`${s.base}/jobs/${fj.json.id}/rasters/${l.name}.png`);
    const b = Buffer.from(await pic.arrayBuffer());
    equal([pic.status, pic.headers.get('content-type')], [200, 'image/png'], `rasters/${l.name}.png`);
    // IHDR: width, height, bit depth 8, colour type 6 (RGBA).
    equal([b.readUInt32BE(16), b.readUInt32BE(20), b[24], b[25]], [r.nx, r.ny, 8, 6], `${l.name}.png is RGBA, a pixel per cell`);
  }
  const depth = mj.json.layers[0].scale;
  equal(depth.min, flume.output.inundation_threshold, 'the depth scale starts at the run\'s inundation threshold');
  equal(mj.json.layers.find((l) => l.name === 'intensity').scale.stops.map((x) => x.label), ['low', 'medium', 'high'], 'intensity classes');
  const unknown = await call(s, 'GET', `/jobs/${fj.json.id}/rasters/elevation.png`);
  equal([unknown.status, unknown.json?.errors?.[0]?.field], [404, 'name'], 'an unknown raster picture is 404 naming the field');
  check(/max_depth, max_speed/.test(unknown.json?.errors?.[0]?.message || ''), `the 404 lists the layers: ${unknown.text}`);
  equal((await call(s, 'GET', `/jobs/${job.json.id}/rasters/max_depth.png`)).status, 404, 'a 2D job has no raster pictures');
  equal(mj.json.hillshade, `/api/v1/jobs/${fj.json.id}/hillshade.png`, 'the hillshade path');
  const hs = await fetch(`${s.base}/jobs/${fj.json.id}/hillshade.png`);
  equal([hs.status, hs.headers.get('content-type')], [200, 'image/png'], 'hillshade.png');

  // GET /compare: the decision metrics first (the outlet's peak discharge leading), the layouts ranked.
  const cmp = await call(s, 'GET', `/compare?jobs=${fj.json.id}`);
  equal(cmp.status, 200, 'compare one flume job');
  const flags = cmp.json.metrics.map((x) => x.decision);
  const nd = flags.filter(Boolean).length;
  check(nd > 0 && flags.slice(0, nd).every(Boolean) && !flags.slice(nd).includes(true), `decision rows first (${nd})`);
  equal(cmp.json.outlet, 'Outlet', 'the flume\'s outlet');
  equal(cmp.json.metrics[0].metric, 'monitors.section.Outlet.peak_discharge_m3_s', 'the first decision metric');
  equal(cmp.json.ranking.layouts.map((x) => [x.rank, x.job, x.baseline, x.value]), [[1, fj.json.id, true, cmp.json.metrics[0].baseline]], 'the one layout ranked');
  const rest = cmp.json.metrics.slice(nd).map((x) => x.metric);
  equal(rest, [...rest].sort(), 'the other metrics by name');

  // With a token: the estimate needs it, like every POST.
  const t = await start(path.join(scratch, 'b'), ['--workers', '0'], { RUNOUT_TOKEN: 'sesame' });
  servers.push(t);
  const no = await call(t, 'POST', '/estimate', body);
  equal(no.status, 401, 'estimate without the token');
  equal(no.json?.errors?.[0]?.field, 'Authorization', 'the 401 names the header');
  const yes = await call(t, 'POST', '/estimate', body, { Authorization: 'Bearer sesame' });
  equal(yes.status, 200, 'estimate with the token');
} catch (e) {
  failures.push(String(e.stack || e));
} finally {
  for (const s of servers) check((await stop(s)) === 0, 'runout serve exits 0 on SIGTERM');
  fs.rmSync(scratch, { recursive: true, force: true });
}
for (const f of failures) console.error(`FAILED: ${f}`);
console.log(`${passed} passed, ${failures.length} failed`);
process.exit(failures.length ? 1 : 0);
