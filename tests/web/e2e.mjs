// End-to-end test of the web page (docs/web.md, issue 6) in headless Chromium (Debian's /usr/bin/chromium,
// driven by playwright-core from web/package-lock.json). It starts the real `runout serve --port 0` on a
// scratch database, and through the page: stores a short flume scene (after a refused one, whose API message
// must show beside the scene field), picks one check dam, checks the estimate against POST /estimate, submits
// that layout and the baseline without it, waits for both, opens the compare view against the baseline and
// checks every number of the table against GET /compare, the decision metrics first and the layouts ranked,
// checks the charts, both maps (Leaflet: rasters, legends, vectors, zoom) and the download links, types a bad dp
// and checks the API's message beside the field, and saves screenshots at 1280x800 and 390x844.
//
//   node tests/web/e2e.mjs --runout BUILD/runout --npm-dir BUILD/web-npm --flume scenarios/flume \
//        --out BUILD/web-e2e [--docs docs/web] [--timeout 1500]
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
        '--workers', '1', '--threads-per-job', '1', '--scene-dir', path.resolve(args.flume)],
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
  for (const job of jobs) {
    const fig = `#maps figure.map[data-job="${job}"]`;
    const info = (await api(base, 'GET', `/jobs/${job}/map.json`)).json;
    check(info.layers.length >= 4, `map.json of job ${job} lists the rasters (${info.layers.map((l) => l.name)})`);
    equal(info.layers.slice(0, 4).map((l) => l.name).join(), 'max_depth,max_speed,max_pressure,intensity', 'the first layers');
    check(await page.$(`${fig} .leaflet-container`), `job ${job}: a Leaflet map`);
    const overlay = await page.$eval(`${fig} img.leaflet-image-layer.raster`, (img) => ({ src: img.src, w: img.naturalWidth, h: img.naturalHeight }));
    equal(new URL(overlay.src).pathname, info.layers[0].image, `job ${job}: the first overlay is ${info.layers[0].name}`);
    equal([overlay.w, overlay.h].join('x'), `${info.raster.nx}x${info.raster.ny}`, `job ${job}: the overlay has a pixel per cell`);
    const res = await fetch(overlay.src);
    equal(res.status, 200, `GET ${overlay.src}`);
    equal(res.headers.get('content-type'), 'image/png', `${overlay.src} type`);
    if (info.hillshade) check(await page.$(`${fig} img.leaflet-image-layer.hillshade`), `job ${job}: the hillshade under it`);
    const legend = async () => page.$eval(`${fig} .legend`, (l) => ({ layer: l.dataset.layer, values: [...l.querySelectorAll('li')].map((li) => Number(li.dataset.value)), labels: [...l.querySelectorAll('li')].map((li) => li.textContent), colours: [...l.querySelectorAll('li')].map((li) => li.dataset.colour) }));
    const expectLegend = (got, layer) => {
      equal(got.layer, layer.name, `job ${job}: the legend's layer`);
      equal(JSON.stringify(got.values), JSON.stringify(layer.scale.stops.map((x) => x.value)), `job ${job}: ${layer.name} legend values`);
      equal(JSON.stringify(got.labels), JSON.stringify(layer.scale.stops.map((x) => x.label)), `job ${job}: ${layer.name} legend labels`);
      equal(JSON.stringify(got.colours), JSON.stringify(layer.scale.stops.map((x) => x.colour)), `job ${job}: ${layer.name} legend colours`);
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
    // Downloads: every raster, the hazard polygons, the series.
    const links = await page.$$eval(`${fig} .downloads a[download]`, (as) => as.map((a) => ({ href: a.href, type: a.dataset.type, text: a.textContent })));
    for (const l of info.layers) check(links.some((a) => a.text === `${l.name}.tif`), `job ${job}: a download of ${l.name}.tif`);
    check(links.some((a) => a.text === 'hazard.gpkg') && links.some((a) => a.text === 'section_' + sections[0] + '.csv'), `job ${job}: hazard.gpkg and series downloads`);
    for (const a of links) {
      const r = await fetch(a.href);
      equal(r.status, 200, `download ${a.text}`);
      check((r.headers.get('content-type') || '').startsWith(a.type), `${a.text}: ${r.headers.get('content-type')} is ${a.type}`);
      await r.arrayBuffer();
    }
    log(`map of job ${job}: ${info.layers.length} rasters, legend = scale, ${vectors.length} vectors, zoom, ${links.length} downloads`);
  }
  const withDam = (await api(base, 'GET', `/jobs/${jobs[0]}/map.json`)).json;
  equal(withDam.structures.map((x) => x.name).join(), dam.name, 'the dam on its job\'s map');
  equal((await api(base, 'GET', `/jobs/${jobs[1]}/map.json`)).json.structures.length, 0, 'no structure on the baseline\'s map');
}

async function main() {
  fs.mkdirSync(args.out, { recursive: true });
  if (args.docs) fs.mkdirSync(args.docs, { recursive: true });
  const base = await startServer();
  log('server at', base);

  // The flume, short: in 2.4 s the flow reaches the first check dam and, without it, the outlet (so the
  // layouts rank apart on the outlet's peak discharge); at draft fidelity (dp 0.05 m) a run takes ~10-40 s on
  // one thread.
  const flume = JSON.parse(fs.readFileSync(path.join(args.flume, 'flume.json'), 'utf8'));
  flume.name = 'flume-e2e';
  flume.duration = 2.4;
  const dam = (flume.structures || []).find((s) => s.type === 'check_dam');
  check(dam, 'the flume has a check dam among its candidate structures');
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

  // A refused scene: the API's message beside the scene field.
  const bad = structuredClone(flume);
  bad.materials[0].density = -1000;
  const refused = await api(base, 'POST', '/scenes', bad);
  equal(refused.status, 422, 'POST /scenes with a negative density');
  await page.fill('#scene-json', JSON.stringify(bad));
  await page.click('#scene-store');
  await page.waitForFunction(() => document.getElementById('err-scene').textContent.length > 0);
  const sceneErr = await page.textContent('#err-scene');
  check(sceneErr.includes(refused.json.errors[0].message) && sceneErr.includes(refused.json.errors[0].field),
    `the scene error beside the field (${sceneErr}) is the API's (${JSON.stringify(refused.json.errors)})`);

  // The real scene, pasted and stored.
  await page.fill('#scene-json', JSON.stringify(flume));
  await page.click('#scene-store');
  await page.waitForFunction((n) => [...document.querySelectorAll('#scene-select option')].some((o) => o.selected && o.textContent.startsWith(n)), flume.name);
  const sceneId = Number(await page.inputValue('#scene-select'));
  await page.waitForSelector(`#structure-list input[value="${dam.name}"]`);
  log(`scene #${sceneId} stored; layouts: ${dam.name} and none`);

  // Submits a layout after the estimate shown equals POST /estimate's for the same body.
  async function submitLayout(structures, label) {
    await page.selectOption('#fidelity', 'draft');
    for (const box of await page.$$('#structure-list input[type=checkbox]')) {
      const want = structures.includes(await box.getAttribute('value'));
      if ((await box.isChecked()) !== want) await box.click();
    }
    await page.fill('#variant', label);
    const body = { scene_id: sceneId, structures, fidelity: 'draft', variant: label };
    const est = await api(base, 'POST', '/estimate', body);
    equal(est.status, 200, `POST /estimate ${label}`);
    const e = est.json;
    check(e.particles.fluid > 0 && e.particles.boundary > 0 && e.steps_estimate > 0 && e.seconds_estimate > 0, `estimate ${label} is positive`);
    await page.waitForFunction((x) => {
      const d = document.getElementById('estimate').dataset;
      return d.fluid === String(x.particles.fluid) && d.boundary === String(x.particles.boundary) &&
        d.steps === String(x.steps_estimate) && d.seconds === String(x.seconds_estimate);
    }, e);
    checks++;
    const before = (await api(base, 'GET', '/jobs')).json.total;
    await page.click('#submit-btn');
    await page.waitForFunction((n) => document.getElementById('submit-status').textContent.startsWith(`job #${n} `), before + 1);
    const jobs = (await api(base, 'GET', '/jobs')).json;
    equal(jobs.total, before + 1, `one job more after submitting ${label}`);
    const job = jobs.jobs[jobs.jobs.length - 1];
    equal(job.id, before + 1, 'the new job\'s id');
    equal(job.variant, label, 'the new job is the layout submitted');
    equal(job.particles, e.particles.total, `job ${job.id}'s particles equal the estimate's`);
    return job.id;
  }
  const withDam = await submitLayout([dam.name], `with-${dam.name}`);
  const baseline = await submitLayout([], 'baseline');
  log(`submitted job ${withDam} (${dam.name}) and job ${baseline} (baseline)`);
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
      cells: [...tr.querySelectorAll('td')].map((td) => ({ kind: td.dataset.kind, job: td.dataset.job, value: td.dataset.value, text: td.textContent })),
    })));
  equal(table.length, cmp.json.metrics.length, 'rows of the metrics table');
  check(cmp.json.metrics.length > 20, 'the comparison has the run metrics');
  const differing = cmp.json.metrics.filter((m) => m.difference[0] != null && m.difference[0] !== 0).length;
  check(differing > 0, 'the check dam changes some metric');
  cmp.json.metrics.forEach((m, k) => {
    const row = table[k];
    equal(row.metric, m.metric, `row ${k}`);
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
    });
  });
  log(`compare table: ${table.length} metrics equal the API's (${differing} differ)`);
  await checkDecisionView(page, cmp.json, [baseline, withDam]);

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
