// End-to-end test of the web page (docs/web.md, issues 6 and 48) in headless Chromium (Debian's
// /usr/bin/chromium, driven by playwright-core from web/package-lock.json). It starts a fresh `runout serve
// --port 0` (scratch database, no --scene-dir: the shipped studies are offered), and through the page: a
// refused pasted scene shows the API's message beside the scene field; it picks the shipped flume, checks a
// layout's estimate against POST /estimate, uploads a sweep file (the shipped C0-C7 file cut to C0 and C4) and
// submits it, waits for both jobs, opens the compare view against C0 and checks every number of the table
// against GET /compare (C4's Village arrival reads "never"), the labels, the better/worse colours by each
// metric's direction, the decision metrics first and the layouts ranked, the link to the sweep's report (with
// its intensity and difference maps), the charts, both maps on one shared colour scale (Leaflet: rasters,
// legends, vectors, zoom) and the download links (GeoTIFFs with their .qml styles), types a bad dp and checks
// the API's message beside the field, and saves screenshots at 1280x800 and 390x844.
//
//   node tests/web/e2e.mjs --runout BUILD/runout --npm-dir BUILD/web-npm --flume scenarios/flume \
//        --out BUILD/web-e2e [--docs docs/web] [--report-docs docs/report] [--timeout 1500]
import { spawn } from 'node:child_process';
import { createRequire } from 'node:module';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';

const { values: args } = parseArgs({
  options: {
    runout: { type: 'string' },
    'npm-dir': { type: 'string' },
    flume: { type: 'string' },
    out: { type: 'string' },
    docs: { type: 'string' },
    'report-docs': { type: 'string' },
    timeout: { type: 'string', default: '1500' },
  },
});
for (const k of ['runout', 'npm-dir', 'flume', 'out'])
  if (!args[k]) {
    console.error(`e2e: --${k} is required`);
    process.exit(2);
  }
const { chromium } = createRequire(path.join(path.resolve(args['npm-dir']), 'package.json'))('playwright-core');

const t0 = Date.now();
const elapsed = () => `${((Date.now() - t0) / 1000).toFixed(1)} s`;
const log = (...m) => console.log(`[e2e ${elapsed()}]`, ...m);
let checks = 0;
function check(ok, what) {
  if (!ok) throw new Error(`check failed: ${what}`);
  checks++;
}
function equal(a, b, what) {
  check(a === b, `${what}: got ${JSON.stringify(a)}, expected ${JSON.stringify(b)}`);
}
// The page's table format (web/app.js tableNumber).
const tableNumber = (v, digits = 6) => (v == null ? '–' : String(Number(v.toPrecision(digits))));

const scratch = fs.mkdtempSync(path.join(os.tmpdir(), 'runout-web-e2e-'));
const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'runout-web-chromium-'));
let server = null;
let serverLog = '';
let context = null;

async function cleanup() {
  if (context) await context.close().catch(() => {});
  if (server && server.exitCode === null) {
    server.kill('SIGTERM');
    await new Promise((r) => server.once('exit', r));
  }
  fs.rmSync(profile, { recursive: true, force: true });
}

// A hard stop: generous (CI has two slow cores shared with other tests), but a hang still fails.
const deadline = setTimeout(async () => {
  console.error(`e2e: FAILED: over the --timeout of ${args.timeout} s`);
  console.error(serverLog.slice(-4000));
  await cleanup();
  process.exit(1);
}, Number(args.timeout) * 1000);

// `runout serve --port 0`: the port is on its first stdout line.
function startServer() {
  return new Promise((resolve, reject) => {
    server = spawn(
      args.runout,
      ['serve', '--port', '0', '--db', path.join(scratch, 'runout.db'), '--runs', path.join(scratch, 'runs'),
        '--workers', '1', '--threads-per-job', '1'],  // no --scene-dir: a fresh service, the shipped studies
      { stdio: ['ignore', 'pipe', 'pipe'] },
    );
    let out = '';
    server.stdout.on('data', (d) => {
      out += d;
      serverLog += d;
      const m = out.match(/listening on http:\/\/([0-9.]+):([0-9]+)/);
      if (m) resolve(`http://${m[1]}:${m[2]}`);
    });
    server.stderr.on('data', (d) => (serverLog += d));
    server.once('exit', (code) => reject(new Error(`runout serve exited (${code}) before listening: ${serverLog}`)));
  });
}

async function api(base, method, p, body) {
  const res = await fetch(`${base}/api/v1${p}`, {
    method,
    headers: body === undefined ? {} : { 'Content-Type': 'application/json' },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  const text = await res.text();
  let json = null;
  try {
    json = JSON.parse(text);
  } catch {
    /* CSV or PNG */
  }
  return { status: res.status, json, text };
}

// The compare view opens on the decision metrics, first in the table as GET /compare orders them, with the
// layouts ranked as the server ranks them (by the outlet's peak discharge, lowest first); "all metrics" shows
// the rest.
async function checkDecisionView(page, cmp, jobs) {
  const flags = cmp.metrics.map((m) => m.decision);
  const decisions = flags.filter(Boolean).length;
  check(decisions >= 2, `the flume comparison has decision metrics (${decisions})`);
  check(flags.slice(0, decisions).every(Boolean) && !flags.slice(decisions).some(Boolean), 'the decision metrics come first');
  equal(cmp.metrics[0].metric, `monitors.section.${cmp.outlet}.peak_discharge_m3_s`, 'the first row is the outlet\'s peak discharge');
  const rows = await page.$$eval('#compare-table tbody tr', (trs) => trs.map((tr) => ({ decision: tr.dataset.decision, hidden: tr.hidden })));
  equal(JSON.stringify(rows.map((r) => r.decision === 'true')), JSON.stringify(flags), 'the page marks the API\'s decision rows');
  equal(JSON.stringify(rows.map((r) => !r.hidden)), JSON.stringify(flags), 'the view opens on the decision metrics only');
  // The ranking: every layout once, ascending by the ranking metric's value, as the table's first row gives it.
  const r = cmp.ranking;
  equal(r.metric, cmp.metrics[0].metric, 'layouts are ranked by the first decision metric');
  equal(JSON.stringify(r.layouts.map((l) => l.job).sort()), JSON.stringify([...jobs].sort()), 'every layout is ranked');
  // Without the dam the flow reaches the outlet within the run, with it not: the key tells them apart, so the
  // order below is a real one.
  check(new Set(r.layouts.map((l) => l.value)).size === r.layouts.length, `the layouts differ on the key: ${JSON.stringify(r.layouts)}`);
  const valueOf = (job) => (job === cmp.baseline.job ? cmp.metrics[0].baseline : cmp.metrics[0].values[cmp.jobs.findIndex((j) => j.job === job)]);
  r.layouts.forEach((l, k) => {
    equal(l.value, valueOf(l.job), `ranked value of job ${l.job}`);
    if (k > 0) check(r.layouts[k - 1].value <= l.value, `ranking ascending at ${k}`);
    // Equal values share a rank (a key that cannot tell layouts apart must not seem to).
    equal(l.rank, k > 0 && r.layouts[k - 1].value === l.value ? r.layouts[k - 1].rank : k + 1, `rank of job ${l.job}`);
  });
  const shown = await page.$$eval('#ranking li', (lis) => lis.map((li) => ({ job: Number(li.dataset.job), rank: Number(li.dataset.rank), text: li.textContent })));
  equal(JSON.stringify(shown.map((x) => x.job)), JSON.stringify(r.layouts.map((l) => l.job)), 'the page lists the layouts in the server\'s order');
  equal(JSON.stringify(shown.map((x) => x.rank)), JSON.stringify(r.layouts.map((l) => l.rank)), 'the page shows the server\'s ranks');
  check(/peak discharge at the outlet/.test(await page.textContent('#ranking')), 'the page states the ranking key');
  await page.check('#all-metrics');
  const all = await page.$$eval('#compare-table tbody tr', (trs) => trs.filter((tr) => !tr.hidden).length);
  equal(all, cmp.metrics.length, '"all metrics" shows every row');
  await page.uncheck('#all-metrics');
  log(`decision view: ${decisions} decision metrics first; ranking ${shown.map((x) => `#${x.job}`).join(' < ')}`);
}

// Each job's map: Leaflet, its first raster overlay (HTTP 200, image/png, one pixel per cell), a legend
// equal to the served colour scale, the structures, zones and sections of map.json as named vector layers,
// another raster picked from the layer list with its own legend, zoom; then every download link answers 200
// with its media type.
async function checkMaps(page, base, jobs, { dam, flume, sections }) {
  const shared = jobs.join(',');
  const infos = [];
  for (const job of jobs) {
    const fig = `#maps figure.map[data-job="${job}"]`;
    // The page asks for the maps on one shared scale (map.json?shared=): what it shows must be that.
    const info = (await api(base, 'GET', `/jobs/${job}/map.json?shared=${[...jobs].sort((x, y) => x - y).join(',')}`)).json;
    infos.push(info);
    check(info.layers.length >= 4, `map.json of job ${job} lists the rasters (${info.layers.map((l) => l.name)})`);
    equal(info.layers.slice(0, 4).map((l) => l.name).join(), 'max_depth,max_speed,max_pressure,intensity', 'the first layers');
    check(await page.$(`${fig} .leaflet-container`), `job ${job}: a Leaflet map`);
    const overlay = await page.$eval(`${fig} img.leaflet-image-layer.raster`, (img) => ({ src: img.src, w: img.naturalWidth, h: img.naturalHeight }));
    const url = new URL(overlay.src);
    equal(url.pathname + url.search, info.layers[0].image, `job ${job}: the first overlay is ${info.layers[0].name} on the shared scale`);
    check(/\?max=/.test(info.layers[0].image), `job ${job}: the picture is coloured on the shared scale (${info.layers[0].image})`);
    equal([overlay.w, overlay.h].join('x'), `${info.raster.nx}x${info.raster.ny}`, `job ${job}: the overlay has a pixel per cell`);
    const res = await fetch(overlay.src);
    equal(res.status, 200, `GET ${overlay.src}`);
    equal(res.headers.get('content-type'), 'image/png', `${overlay.src} type`);
    if (info.hillshade) check(await page.$(`${fig} img.leaflet-image-layer.hillshade`), `job ${job}: the hillshade under it`);
    const legend = async () => page.$eval(`${fig} .legend`, (l) => ({ layer: l.dataset.layer, values: [...l.querySelectorAll('li')].map((li) => Number(li.dataset.value)), labels: [...l.querySelectorAll('li')].map((li) => li.textContent), colours: [...l.querySelectorAll('li')].map((li) => li.dataset.colour), scope: l.querySelector('.legend-scope')?.dataset.shared, scopeText: l.querySelector('.legend-scope')?.textContent }));
    const expectLegend = (got, layer) => {
      equal(got.layer, layer.name, `job ${job}: the legend's layer`);
      equal(JSON.stringify(got.values), JSON.stringify(layer.scale.stops.map((x) => x.value)), `job ${job}: ${layer.name} legend values`);
      equal(JSON.stringify(got.labels), JSON.stringify(layer.scale.stops.map((x) => x.label)), `job ${job}: ${layer.name} legend labels`);
      equal(JSON.stringify(got.colours), JSON.stringify(layer.scale.stops.map((x) => x.colour)), `job ${job}: ${layer.name} legend colours`);
      // The legend states that the scale is shared, and this map's own largest value.
      equal(got.scope, 'true', `job ${job}: the ${layer.name} legend says its scale is shared`);
      check(/shared by the compared maps/.test(got.scopeText), `job ${job}: the legend's words (${got.scopeText})`);
    };
    expectLegend(await legend(), info.layers[0]);
    // The vector layers: what map.json lists, by name.
    const vectors = await page.$$eval(`${fig} path[data-kind]`, (ps) => ps.map((p) => ({ kind: p.dataset.kind, name: p.dataset.name })));
    const names = (kind) => vectors.filter((v) => v.kind === kind).map((v) => v.name).join();
    equal(names('structure'), info.structures.map((x) => x.name).join(), `job ${job}: structures on the map`);
    equal(names('zone'), (flume.protected_zones || []).map((z) => z.name).join(), `job ${job}: protected zones`);
    equal(names('section'), sections.join(), `job ${job}: cross-sections`);
    const labels = await page.$$eval(`${fig} .leaflet-tooltip.structure`, (ts) => ts.map((t) => t.textContent));
    equal(labels.join(), info.structures.map((x) => x.name).join(), `job ${job}: structure labels`);
    const zoneLabels = await page.$$eval(`${fig} .leaflet-tooltip.zone`, (ts) => ts.map((t) => t.textContent));
    equal(zoneLabels.join(), info.protected_zones.map((x) => x.name).join(), `job ${job}: zone labels (tooltips: ${await page.$$eval(`${fig} .leaflet-tooltip`, (ts) => ts.map((t) => t.className + ':' + t.textContent).join('; '))})`);
    // Another raster from the layer list: its picture and its legend.
    const speed = info.layers.find((l) => l.name === 'max_speed');
    await page.click(`${fig} .leaflet-control-layers-base label:has-text("${speed.title}")`);
    await page.waitForFunction(([f, src]) => [...document.querySelectorAll(`${f} img.leaflet-image-layer.raster`)].some((i) => i.src.endsWith(src) && i.naturalWidth > 0), [fig, speed.image]);
    expectLegend(await legend(), speed);
    // Zoom in with the control.
    const z0 = Number(await page.getAttribute(fig, 'data-zoom'));
    await page.click(`${fig} .leaflet-control-zoom-in`);
    await page.waitForFunction(([f, z]) => Number(document.querySelector(f).dataset.zoom) > z, [fig, z0]);
    checks++;
    await page.click(`${fig} .leaflet-control-zoom-out`);
    await page.waitForFunction(([f, z]) => Number(document.querySelector(f).dataset.zoom) === z, [fig, z0]);
    await page.click(`${fig} .leaflet-control-layers-base label:has-text("${info.layers[0].title}")`);
    // Downloads: every raster with its QGIS style (both under the run's names), the layout's difference
    // rasters, the hazard polygons, the series.
    const links = await page.$$eval(`${fig} .downloads a[download]`, (as) => as.map((a) => ({ href: a.href, type: a.dataset.type, text: a.textContent })));
    for (const l of [...info.layers, ...info.differences])
      for (const ext of ['tif', 'qml']) check(links.some((a) => a.text === `${l.name}.${ext}`), `job ${job}: a download of ${l.name}.${ext}`);
    check(links.some((a) => a.text === 'hazard.gpkg') && links.some((a) => a.text === 'section_' + sections[0] + '.csv'), `job ${job}: hazard.gpkg and series downloads`);
    for (const a of links) {
      const r = await fetch(a.href);
      equal(r.status, 200, `download ${a.text}`);
      check((r.headers.get('content-type') || '').startsWith(a.type), `${a.text}: ${r.headers.get('content-type')} is ${a.type}`);
      if (/\.(tif|qml)$/.test(a.text))
        equal(r.headers.get('content-disposition'), `attachment; filename="${a.text}"`, `${a.text} keeps its name`);
      await r.arrayBuffer();
    }
    log(`map of job ${job}: ${info.layers.length} rasters on the shared scale, ${info.differences.length} differences, legend = scale, ${vectors.length} vectors, zoom, ${links.length} downloads`);
  }
  // One scale: every ramp of both maps ends at the same top, the larger of the two maps' own largest values.
  infos[0].layers.forEach((l, k) => {
    const other = infos[1].layers[k];
    equal(other.name, l.name, `layer ${k} of both maps`);
    if (l.scale.classes) return;
    equal(other.scale.max, l.scale.max, `${l.name}: one scale on both maps`);
    if (Math.max(l.scale.data_max, other.scale.data_max) > l.scale.min)
      equal(l.scale.max, Math.max(l.scale.data_max, other.scale.data_max), `${l.name}: the scale's top is the larger maximum`);
  });
  equal(infos[0].structures.map((x) => x.name).join(), dam.name, 'the structure on its job\'s map');
  equal(infos[1].structures.length, 0, 'no structure on the baseline\'s map');
  equal(infos[0].differences.map((d) => d.name).join(), 'diff_max_depth,diff_max_hv', 'the layout has its difference rasters against the baseline');
  equal(infos[1].differences.length, 0, 'the baseline has none');
  check((await page.textContent('#maps-scale')).includes('share one colour scale'), 'the page states that the maps share a scale');
}

async function main() {
  fs.mkdirSync(args.out, { recursive: true });
  if (args.docs) fs.mkdirSync(args.docs, { recursive: true });
  const base = await startServer();
  log('server at', base);

  // The shipped flume study: its base scene (offered by the fresh service) and its sweep file, cut to the
  // baseline C0 and C4 (the retention basin RB1_P2 at the chute's foot): at draft (dp 0.05 m) a layout takes
  // ~20-40 s on one thread; with the basin the flow never reaches the Village zone (an arrival "never") and
  // hardly the outlet, so the two rank apart on the outlet's peak discharge.
  const flume = JSON.parse(fs.readFileSync(path.join(args.flume, 'flume.json'), 'utf8'));
  const study = JSON.parse(fs.readFileSync(path.join(args.flume, 'c0_c7.json'), 'utf8'));
  const sweepFile = { ...study, name: 'flume-e2e', variants: study.variants.filter((v) => v.name === 'C0' || v.name === 'C4') };
  equal(sweepFile.variants.map((v) => v.name).join(), 'C0,C4', 'the sweep file\'s layouts');
  const dam = flume.structures.find((st) => st.name === sweepFile.variants[1].structures[0]);
  check(dam && dam.type === 'retention_basin', 'C4 builds a retention basin of the flume');
  const sweepPath = path.join(scratch, 'flume-e2e.json');
  fs.writeFileSync(sweepPath, JSON.stringify(sweepFile, null, 2));
  const sections = (flume.monitors || []).filter((m) => m.type === 'section').map((m) => m.name);

  context = await chromium.launchPersistentContext(profile, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking'],
    viewport: { width: 1280, height: 800 },
  });
  const page = context.pages()[0] || (await context.newPage());
  page.setDefaultTimeout(60_000);
  const problems = [];
  const foreign = [];
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('console', (m) => {
    // 4xx answers the page provokes on purpose (the refused scene, the bad dp) are logged by Chromium as
    // failed resources: those are expected, anything else is a problem.
    if (m.type() === 'error' && !/status of 4\d\d/.test(m.text())) problems.push(`console: ${m.text()}`);
  });
  page.on('request', (r) => {
    const u = new URL(r.url());
    if (u.protocol !== 'data:' && u.origin !== base) foreign.push(r.url());
  });

  await page.goto(`${base}/`);
  await page.waitForFunction(() => /worker/.test(document.getElementById('health').textContent));
  log('page loaded');

  // A fresh service offers the shipped studies: the flume first, within seconds, while the catchments are
  // still being checked in the background.
  const health = (await api(base, 'GET', '/health')).json;
  check(['storing', 'done'].includes(health.shipped_studies.status), `the shipped studies are being stored (${JSON.stringify(health.shipped_studies)})`);
  // The page follows /health's list of stored studies: the flume appears without a reload.
  await page.waitForFunction(() => [...document.querySelectorAll('#scene-select option')].some((o) => o.textContent.startsWith('flume (')), null, { timeout: 120_000 });
  const flumeScene = (await api(base, 'GET', '/scenes')).json.scenes.find((x) => x.name === 'flume');
  check(flumeScene, 'the shipped flume is a stored base scene');
  const sceneId = flumeScene.id;
  equal((await api(base, 'GET', `/scenes/${sceneId}`)).json.scene.terrain.dem, 'flume/flume_dem.asc', 'the flume\'s DEM inside the scenarios folder');
  await page.selectOption('#scene-select', String(sceneId));
  await page.waitForSelector(`#structure-list input[value="${dam.name}"]`);
  log(`shipped flume offered as scene #${sceneId} (studies ${health.shipped_studies.status})`);

  // A refused scene: the API's message beside the scene field.
  const bad = structuredClone(flume);
  bad.name = 'flume-bad';
  bad.materials[0].density = -1000;
  const refused = await api(base, 'POST', '/scenes', bad);
  equal(refused.status, 422, 'POST /scenes with a negative density');
  await page.evaluate(() => (document.getElementById('scene-add').open = true));
  await page.fill('#scene-json', JSON.stringify(bad));
  await page.click('#scene-store');
  await page.waitForFunction(() => document.getElementById('err-scene').textContent.length > 0);
  const sceneErr = await page.textContent('#err-scene');
  check(sceneErr.includes(refused.json.errors[0].message) && sceneErr.includes(refused.json.errors[0].field),
    `the scene error beside the field (${sceneErr}) is the API's (${JSON.stringify(refused.json.errors)})`);
  await page.evaluate(() => (document.getElementById('scene-add').open = false));

  // One layout: the estimate shown equals POST /estimate's for the same body.
  await page.selectOption('#fidelity', 'draft');
  for (const box of await page.$$('#structure-list input[type=checkbox]'))
    if ((await box.isChecked()) !== ((await box.getAttribute('value')) === dam.name)) await box.click();
  await page.fill('#variant', 'C4');
  const est = await api(base, 'POST', '/estimate', { scene_id: sceneId, structures: [dam.name], fidelity: 'draft', variant: 'C4' });
  equal(est.status, 200, 'POST /estimate C4');
  const e = est.json;
  check(e.particles.fluid > 0 && e.particles.boundary > 0 && e.steps_estimate > 0 && e.seconds_estimate > 0, 'estimate C4 is positive');
  await page.waitForFunction((x) => {
    const d = document.getElementById('estimate').dataset;
    return d.fluid === String(x.particles.fluid) && d.boundary === String(x.particles.boundary) &&
      d.steps === String(x.steps_estimate) && d.seconds === String(x.seconds_estimate);
  }, e);
  checks++;

  // The sweep file, uploaded: its layouts' estimates summed, then submitted as a sweep on the flume.
  await page.check('input[name=mode][value=file]');
  await page.setInputFiles('#sweep-file', sweepPath);
  const layoutSeconds = await Promise.all(sweepFile.variants.map(async (v) =>
    (await api(base, 'POST', '/estimate', { scene_id: sceneId, structures: v.structures, fidelity: 'draft' })).json.seconds_estimate));
  await page.waitForFunction((x) => document.getElementById('estimate').dataset.jobs === '2' &&
    document.getElementById('estimate').dataset.seconds === String(x), layoutSeconds.reduce((a, x) => a + x, 0));
  checks++;
  await page.click('#submit-btn');
  await page.waitForFunction(() => /^sweep #\d+ flume-e2e: 2 jobs queued/.test(document.getElementById('submit-status').textContent));
  const sweeps = (await api(base, 'GET', '/sweeps')).json.sweeps;
  equal(sweeps.length, 1, 'one sweep');
  equal(sweeps[0].scene_id, sceneId, 'the sweep runs on the flume');
  const sweepJobsDone = (await api(base, 'GET', `/jobs?sweep=${sweeps[0].id}`)).json.jobs;
  equal(JSON.stringify(sweepJobsDone.map((j) => [j.variant, j.fidelity])), JSON.stringify([['C0', 'draft'], ['C4', 'draft']]), 'the sweep\'s jobs');
  const [baseline, withDam] = sweepJobsDone.map((j) => j.id);
  log(`sweep file submitted: job ${baseline} (C0) and job ${withDam} (C4, ${dam.name})`);
  await page.check('input[name=mode][value=single]');
  await page.screenshot({ path: path.join(args.out, 'running-1280x800.png') });

  // Both finish; the page shows it. A failed or cancelled job fails the test at once.
  const until = Date.now() + 900_000;
  for (;;) {
    const states = await Promise.all([withDam, baseline].map(async (id) => (await api(base, 'GET', `/jobs/${id}`)).json));
    for (const j of states)
      check(j.status !== 'failed' && j.status !== 'cancelled', `job ${j.id} is ${j.status}: ${j.error}`);
    if (states.every((j) => j.status === 'done')) break;
    check(Date.now() < until, 'both jobs finish within 900 s');
    await new Promise((r) => setTimeout(r, 1000));
  }
  for (const id of [withDam, baseline])
    await page.waitForSelector(`#jobs-table tr[data-job="${id}"] td[data-status="done"]`, { timeout: 30_000 });
  log('both jobs done');

  // Compare against the baseline.
  await page.check(`#jobs-table tr[data-job="${withDam}"] input.tick`);
  await page.check(`#jobs-table tr[data-job="${baseline}"] input.base`);
  await page.click('#compare-btn');
  await page.waitForSelector('#compare-card[data-ready="true"]', { timeout: 120_000 });
  const cmp = await api(base, 'GET', `/compare?jobs=${baseline},${withDam}&baseline=${baseline}`);
  equal(cmp.status, 200, 'GET /compare');
  const table = await page.$$eval('#compare-table tbody tr', (trs) =>
    trs.map((tr) => ({
      metric: tr.dataset.metric,
      head: tr.querySelector('th').textContent,
      title: tr.querySelector('th').title,
      cells: [...tr.querySelectorAll('td')].map((td) => ({ kind: td.dataset.kind, job: td.dataset.job, value: td.dataset.value, text: td.textContent, judged: td.dataset.judged ?? null, cls: td.className })),
    })));
  equal(table.length, cmp.json.metrics.length, 'rows of the metrics table');
  check(cmp.json.metrics.length > 20, 'the comparison has the run metrics');
  const differing = cmp.json.metrics.filter((m) => m.difference[0] != null && m.difference[0] !== 0).length;
  check(differing > 0, 'the basin changes some metric');
  let judged = 0;
  cmp.json.metrics.forEach((m, k) => {
    const row = table[k];
    equal(row.metric, m.metric, `row ${k}`);
    // The heading is the API's label for people (the stored name for metrics without one).
    equal(row.head, m.label, `${m.metric}: its heading`);
    equal(row.title, m.metric, `${m.metric}: the stored name in the heading's tooltip`);
    if (m.decision) check(m.label !== m.metric && /\[.+\]$/.test(m.label), `${m.metric}: a decision metric has a label with its unit (${m.label})`);
    const want = [
      ['baseline', baseline, m.baseline, 6, m.baseline_never],
      ['value', withDam, m.values[0], 6, m.never[0]],
      ['difference', withDam, m.difference[0], 6, false],
      ['percent', withDam, m.percent[0], 4, false],
    ];
    equal(row.cells.length, want.length, `cells of ${m.metric}`);
    want.forEach(([kind, job, v, digits, never], c) => {
      const cell = row.cells[c];
      equal(cell.kind, kind, `${m.metric} cell ${c}`);
      equal(cell.job, String(job), `${m.metric} ${kind} job`);
      // The exact number the API gave, and the text shown is that number to the shown precision; an arrival
      // that never happened (null with its never flag) reads "never".
      equal(cell.value, v == null ? '' : String(v), `${m.metric} ${kind} value`);
      equal(cell.text, never ? 'never' : tableNumber(v, digits), `${m.metric} ${kind} text`);
      // Differences coloured by better or worse in the metric's own direction (a later arrival, more held
      // back: better), not by sign; metrics without a direction are not judged.
      if (kind === 'difference' || kind === 'percent') {
        const expect = !m.better || v == null || v === 0 ? null : (m.better === 'higher') === (v > 0) ? 'better' : 'worse';
        equal(cell.judged, expect, `${m.metric} ${kind}: judged`);
        if (expect) check(cell.cls.includes(expect), `${m.metric} ${kind}: coloured ${expect} (${cell.cls})`);
        judged += expect ? 1 : 0;
      }
    });
  });
  // The basin lowers the outlet's peak discharge: better, in green, though the difference is negative.
  const q = table.find((r) => r.metric === `monitors.section.${cmp.json.outlet}.peak_discharge_m3_s`);
  check(cmp.json.metrics.find((m) => m.metric === q.metric).difference[0] < 0 && q.cells[2].judged === 'better', 'a lower outlet peak discharge reads better');
  // "never": C4's Village arrival, shown as the word.
  const village = 'terrain.protected_zones.Village.arrival_time_s';
  const vrow = table.find((r) => r.metric === village);
  check(vrow && vrow.cells[1].text === 'never' && vrow.cells[0].text !== 'never', `C4 never reaches the Village, C0 does (${JSON.stringify(vrow)})`);
  equal(await page.$eval(`#compare-table td[data-metric="${village}"][data-kind="value"]`, (td) => td.dataset.never), 'true', 'the never cell is marked');
  log(`compare table: ${table.length} metrics equal the API's (${differing} differ, ${judged} judged better/worse; Village: never)`);
  await checkDecisionView(page, cmp.json, [baseline, withDam]);

  // The sweep's report, linked from the compare view: the intensity and the difference maps the service wrote.
  const reportHref = await page.$eval('#report-link a', (a) => a.getAttribute('href'));
  equal(reportHref, cmp.json.sweep.report, 'the page links the sweep\'s report');
  equal(reportHref, `/api/v1/sweeps/${sweeps[0].id}/report.html?baseline=C0`, 'the report of the sweep, against C0');
  const report = await fetch(`${base}${reportHref}`);
  equal(report.status, 200, 'GET the report');
  const reportHtml = await report.text();
  check(reportHtml.includes('data-raster="intensity"') && reportHtml.includes('data-raster="diff_max_depth"'), 'the report has intensity and difference maps');

  // Charts: a hydrograph per cross-section, force and pressure on the dam, the front position; maps.
  const charts = await page.$$eval('#charts figure.chart', (fs) => fs.map((f) => ({ id: f.dataset.chart, canvas: !!f.querySelector('canvas') })));
  const ids = charts.map((c) => c.id);
  for (const s of sections) check(ids.includes(`section_${s}`), `hydrograph of section ${s} (charts: ${ids})`);
  check(ids.includes(`structure_load_${dam.name}:force`) && ids.includes(`structure_load_${dam.name}:pressure`), `force and pressure of ${dam.name}`);
  check(ids.includes('front'), 'front position chart');
  check(charts.every((c) => c.canvas), 'every chart is drawn');
  log(`charts: ${ids.join(', ')}`);
  await checkMaps(page, base, [withDam, baseline], { dam, flume, sections });

  const shots = [];
  async function shot(name, opts = {}) {
    const file = path.join(args.out, name);
    await page.screenshot({ path: file, ...opts });
    shots.push(file);
    if (args.docs) fs.copyFileSync(file, path.join(args.docs, name));
  }
  await page.evaluate(() => window.scrollTo(0, 0));
  await shot('web-1280x800.png');
  await page.evaluate(() => document.getElementById('compare-card').scrollIntoView({ block: 'start' }));
  await shot('web-compare-1280x800.png');
  await page.evaluate(() => document.getElementById('charts').scrollIntoView({ block: 'start' }));
  await shot('web-charts-1280x800.png');
  await page.evaluate(() => document.getElementById('maps').scrollIntoView({ block: 'start' }));
  await shot('web-maps-1280x800.png');

  // A bad value: the API's message beside the field it names, and nothing submitted.
  await page.evaluate(() => window.scrollTo(0, 0));
  await page.selectOption('#fidelity', 'custom');
  await page.fill('#dp', '-1');
  const badBody = { scene_id: sceneId, structures: [], fidelity: { dp: -1 }, variant: 'baseline' };
  const badEst = await api(base, 'POST', '/estimate', badBody);
  equal(badEst.status, 422, 'POST /estimate with dp -1');
  const badJob = await api(base, 'POST', '/jobs', badBody);
  equal(badJob.status, 422, 'POST /jobs with dp -1');
  equal(badJob.json.errors[0].field, 'fidelity.dp', 'the field the API names');
  await page.waitForFunction((m) => document.getElementById('err-fidelity').textContent.includes(m), badJob.json.errors[0].message);
  const total = (await api(base, 'GET', '/jobs')).json.total;
  await page.click('#submit-btn');
  await page.waitForFunction((m) => document.getElementById('err-fidelity').textContent.includes(m) &&
    document.getElementById('submit-status').textContent === '', badJob.json.errors[0].message);
  const fidErr = await page.textContent('#err-fidelity');
  check(fidErr.startsWith('fidelity.dp'), `the message names the field (${fidErr})`);
  equal(await page.getAttribute('#dp', 'aria-invalid'), 'true', 'the dp input is marked invalid');
  equal((await api(base, 'GET', '/jobs')).json.total, total, 'a refused submission adds no job');
  log(`bad dp: "${fidErr}" beside the field`);
  await shot('web-error-1280x800.png', { clip: { x: 0, y: 0, width: 1280, height: 800 } });

  // Every permutation of the dam (a sweep of 2 jobs, at standard fidelity so they really run), its summed
  // estimate, then both cancelled from the jobs list (one running, one queued).
  await page.selectOption('#fidelity', 'standard');
  await page.check('input[name=mode][value=factorial]');
  await page.fill('#sweep-name', 'e2e-sweep');
  for (const box of await page.$$('#structure-list input[type=checkbox]'))
    if ((await box.isChecked()) !== ((await box.getAttribute('value')) === dam.name)) await box.click();
  const layouts = await Promise.all([[], [dam.name]].map(async (st) =>
    (await api(base, 'POST', '/estimate', { scene_id: sceneId, structures: st, fidelity: 'standard' })).json));
  const sweepSeconds = layouts.reduce((a, e) => a + e.seconds_estimate, 0);
  await page.waitForFunction((x) => document.getElementById('estimate').dataset.jobs === '2' &&
    document.getElementById('estimate').dataset.seconds === String(x), sweepSeconds);
  checks++;
  const before = (await api(base, 'GET', '/jobs')).json.total;
  await page.click('#submit-btn');
  await page.waitForFunction(() => /^sweep #\d+ e2e-sweep: 2 jobs queued/.test(document.getElementById('submit-status').textContent));
  const sweepJobs = (await api(base, 'GET', `/jobs?offset=${before}`)).json.jobs;
  equal(JSON.stringify(sweepJobs.map((j) => [j.sweep, j.variant])), JSON.stringify([['e2e-sweep', 'G0'], ['e2e-sweep', 'G1']]), 'the sweep\'s jobs');
  for (const j of sweepJobs) {
    const button = `#jobs-table tr[data-job="${j.id}"] button.cancel`;
    await page.waitForSelector(`${button}:not([hidden])`);
    await page.click(button);
  }
  for (const j of sweepJobs)
    await page.waitForSelector(`#jobs-table tr[data-job="${j.id}"] td[data-status="cancelled"]`, { timeout: 120_000 });
  for (const j of sweepJobs) equal((await api(base, 'GET', `/jobs/${j.id}`)).json.status, 'cancelled', `job ${j.id} cancelled`);
  log(`sweep of 2 jobs (estimate ${sweepSeconds.toFixed(1)} s) submitted and cancelled from the page`);
  await page.check('input[name=mode][value=single]');

  // A multi-fidelity study (docs/service.md, "Studies") on a tiny 2D dam break: two layouts over a viscosity
  // ensemble of two members at draft, then both layouts at standard at the median viscosity. The sweeps card
  // shows its two stages with the API's counts, the decision and the 3D ranking once it is done.
  const tiny = {
    name: 'study-tank', dimensions: 2, dp: 0.02, duration: 0.05,
    materials: [{ name: 'water', rheology: 'newtonian', density: 1000, viscosity: 0.001 }],
    fluid: [{ min: [0, 0], max: [0.2, 0.2], material: 'water' }],
    boundaries: [{ type: 'tank', min: [0, 0], max: [0.4, 0.3] }],
  };
  const studyReply = await api(base, 'POST', '/sweeps', {
    name: 'e2e-study', base: tiny, variants: [{ name: 'A' }, { name: 'B' }], fidelity: 'draft',
    ensemble: { parameters: [{ pointer: '/materials/0/viscosity', values: [0.001, 0.003] }] }, study: { fidelity: 'standard' },
  });
  equal(studyReply.status, 201, `POST /sweeps with a study: ${studyReply.text.slice(0, 300)}`);
  const studyId = studyReply.json.id;
  const studyItem = `#sweeps-list li[data-sweep="${studyId}"]`;
  await page.waitForSelector(`${studyItem} .badge.status-done`, { timeout: 300_000 });
  const studyView = (await api(base, 'GET', `/sweeps/${studyId}`)).json.study;
  equal(studyView.stage, 'done', 'the study has run both stages');
  equal(JSON.stringify([studyView.screening.jobs_by_status.done, studyView.detailed.jobs_by_status.done, studyView.detailed.candidates]),
    JSON.stringify([4, 2, 2]), 'every member screened; both layouts (neither has a ranking value, so none is dropped) in 3D');
  const stages = await page.$$eval(`${studyItem} .stage > span`, (spans) => spans.map((x) => x.textContent));
  equal(JSON.stringify(stages), JSON.stringify([
    `1 · screening (draft): ${studyView.screening.jobs_by_status.done}/${studyView.screening.jobs_total} done`,
    `2 · 3D (standard): ${studyView.detailed.jobs_by_status.done}/${studyView.detailed.jobs_total} done, ${studyView.detailed.jobs_total} of ${studyView.detailed.candidates} layouts`,
  ]), 'the study\'s two stages as the API counts them');
  const lines = await page.$$eval(`${studyItem} > div.small`, (d) => d.map((x) => x.textContent));
  check(lines.some((t) => t.startsWith(`screened over ${studyView.outcome.members} members`)), `the decision is shown (${lines.join(' | ')})`);
  check(lines.some((t) => t.endsWith(studyView.outcome.ranking.join(', '))), `the 3D ranking is shown (${lines.join(' | ')})`);
  await page.evaluate(() => document.getElementById('sweeps-card').scrollIntoView({ block: 'start' }));
  await shot('web-study-1280x800.png');
  log(`study of 2 layouts x 2 members: both stages shown (${stages.join('; ')})`);

  // Phone width: no sideways scrolling of the page; form, jobs and the compare view.
  await page.setViewportSize({ width: 390, height: 844 });
  await page.selectOption('#fidelity', 'draft');
  await page.waitForFunction(() => document.getElementById('err-fidelity').textContent === '');
  await page.evaluate(() => window.scrollTo(0, 0));
  await page.waitForTimeout(300);
  const width = await page.evaluate(() => document.documentElement.scrollWidth);
  check(width <= 390, `no horizontal scrolling at 390 px (page is ${width} px wide)`);
  await shot('web-phone-390x844.png');
  await page.evaluate(() => document.getElementById('jobs-card').scrollIntoView({ block: 'start' }));
  await shot('web-phone-jobs-390x844.png');
  await page.evaluate(() => document.getElementById('charts').scrollIntoView({ block: 'start' }));
  await shot('web-phone-charts-390x844.png');
  await page.evaluate(() => document.getElementById('maps').scrollIntoView({ block: 'start' }));
  await page.waitForTimeout(300); // Leaflet follows the window's resize
  await shot('web-phone-maps-390x844.png');

  // The report's maps for docs/report: a page of its own (nothing fetched: the report is self-contained).
  const reportPage = await context.newPage();
  await reportPage.setViewportSize({ width: 1280, height: 800 });
  await reportPage.goto(`${base}${reportHref}`);
  const hazard = await reportPage.$('figure.map.hazard[data-raster="intensity"]');
  check(hazard, 'the report page shows the intensity map');
  await hazard.scrollIntoViewIfNeeded();
  await reportPage.evaluate(() => window.scrollBy(0, -60));
  const reportShot = path.join(args.out, 'report-intensity-1280x800.png');
  await reportPage.screenshot({ path: reportShot });
  shots.push(reportShot);
  if (args['report-docs']) {
    fs.mkdirSync(args['report-docs'], { recursive: true });
    fs.copyFileSync(reportShot, path.join(args['report-docs'], 'report-intensity-1280x800.png'));
  }
  await reportPage.close();

  check(problems.length === 0, `no errors in the page: ${problems.join('; ')}`);
  check(foreign.length === 0, `nothing fetched from elsewhere: ${foreign.join(', ')}`);
  for (const f of shots) check(fs.statSync(f).size > 10_000, `${f} is a real screenshot`);
  log('screenshots:', shots.join(' '));
}

try {
  await main();
  await cleanup();
  clearTimeout(deadline);
  const code = server ? server.exitCode : null;
  check(code === 0, `runout serve exits 0 after SIGTERM (got ${code})`);
  fs.rmSync(scratch, { recursive: true, force: true });
  log(`web e2e: ${checks} checks passed`);
  console.log(`${checks} passed, 0 failed`);
} catch (e) {
  console.error(`e2e: FAILED: ${e.stack || e}`);
  console.error(`server log (tail):\n${serverLog.slice(-4000)}`);
  console.error(`scratch kept: ${scratch}`);
  await cleanup();
  clearTimeout(deadline);
  process.exit(1);
}
