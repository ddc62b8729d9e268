// The Runout page (docs/web.md): choose a layout of a stored base scene, see its estimate, submit it (or all
// permutations), watch the jobs, compare finished ones against a baseline. Everything goes through the JSON
// API (api.js); the API validates, and its messages are shown beside the field they name.
import { ApiError, get, getAll, post, del, token, setToken, parseCsv, API } from '/web/api.js';
import { lineChart, clearCharts, colourOf, shortNumber } from '/web/charts.js';
import { drawMap } from '/web/map.js';

const $ = (id) => document.getElementById(id);

const state = {
  scenes: [],
  scene: null, // {id, name, structures: [names], types: {name: type}}
  jobs: new Map(), // id -> job (the latest poll)
  ticked: new Set(), // jobs to compare
  baseline: null,
  total: 0,
  estimateSeq: 0,
  shipped: 0, // shipped studies stored, as /health last said
};

// ---------------------------------------------------------------------------------------------------------
// Formatting

const int = (n) => (n == null ? '–' : Number(n).toLocaleString('en-US'));

function duration(s) {
  if (s == null || !Number.isFinite(s)) return '–';
  if (s < 1) return '< 1 s';
  if (s < 90) return `${Math.round(s)} s`;
  if (s < 5400) return `${Math.floor(s / 60)} min ${Math.round(s % 60)} s`;
  return `${Math.floor(s / 3600)} h ${Math.round((s % 3600) / 60)} min`;
}

// Table numbers: 6 significant digits (percentages 4), written so that Number() reads them back.
export const tableNumber = (v, digits = 6) => (v == null ? '–' : String(Number(v.toPrecision(digits))));

// ---------------------------------------------------------------------------------------------------------
// Errors beside fields

const SLOTS = ['scene_id', 'scene', 'structures', 'variant', 'name', 'sweep_file', 'fidelity', 'Authorization', 'form'];
// The job form's slots: an estimate or a submission answers these, never the scene store's message (an
// estimate scheduled at page load could otherwise wipe the message a refused scene just got).
const FORM_SLOTS = SLOTS.filter((s) => s !== 'scene');

// Which form field an API error belongs to (its `field` is a JSON path into the body, a header or "(body)").
function slotFor(field, context) {
  if (context === 'scene') return 'scene'; // POST /scenes: any field is a field of the pasted scene
  if (field === 'Authorization') return 'Authorization';
  // A sweep file's fields (its name, layouts, unknown fields) are answered beside the file, but for the fidelity.
  if (mode() === 'file' && !(field === 'fidelity' || field.startsWith('fidelity.') || field === 'dp' || field.endsWith('.dp')))
    return field === 'scene_id' ? 'scene_id' : 'sweep_file';
  if (!field || field === '(body)' || field === '(request)' || field === 'idempotency_key') return 'form';
  if (field === 'fidelity' || field.startsWith('fidelity.')) return 'fidelity';
  // Over the particle budget the validator names dp: a coarser fidelity is the way out.
  if (field === 'dp' || field.endsWith('.dp')) return 'fidelity';
  if (field === 'structures' || field.startsWith('structures[') || field.startsWith('factorial.structures'))
    return 'structures';
  if (field === 'variant') return 'variant';
  if (field === 'name' || field === 'factorial' || field.startsWith('factorial.') || field === 'variants') return 'name';
  return 'scene_id'; // scene_id itself, or a field of the stored scene (its validator's message)
}

function clearErrors(slots = SLOTS) {
  for (const s of slots) {
    const p = $(`err-${s}`);
    if (p) p.textContent = '';
    const f = $(`field-${s}`);
    if (f) f.classList.remove('invalid');
  }
  for (const el of document.querySelectorAll('[aria-invalid="true"]')) el.removeAttribute('aria-invalid');
}

// Every invalid field the API names, each beside its slot (several in one slot: one line each).
function showError(e, context) {
  const errors = e instanceof ApiError ? e.errors : [{ field: '', message: e.message }];
  const started = new Set();
  for (const { field = '', message } of errors) {
    const slot = e instanceof ApiError ? slotFor(field, context) : context === 'scene' ? 'scene' : 'form';
    const p = $(`err-${slot}`);
    if (!started.has(slot)) {
      started.add(slot);
      p.textContent = '';
      p.dataset.field = field;
      p.dataset.status = e instanceof ApiError ? e.status : '';
    } else {
      p.append(document.createElement('br'));
    }
    if (field) {
      const code = document.createElement('code');
      code.textContent = field;
      p.append(code, document.createTextNode(': '));
    }
    p.append(document.createTextNode(message));
    const f = $(`field-${slot}`);
    if (f) {
      f.classList.add('invalid');
      // The control the field names: the spacing input for a dp, else the slot's first text control.
      const dp = (field === 'dp' || field.endsWith('.dp')) && !$('dp').hidden ? $('dp') : null;
      const input = dp || f.querySelector('input:not([type=checkbox]):not([type=radio]):not([type=file]):not([hidden]), select, textarea');
      if (input) {
        input.setAttribute('aria-invalid', 'true');
        input.setAttribute('aria-describedby', p.id);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------------------
// Health, scenes

async function loadHealth() {
  try {
    const h = await get('/health');
    const j = h.jobs || {};
    $('health').textContent =
      `v${h.version} · ${h.workers} worker${h.workers === 1 ? '' : 's'} (${h.busy_workers} busy) × ${h.threads_per_job} thread${h.threads_per_job === 1 ? '' : 's'} · ` +
      `budget ${int(h.particle_budget)} particles · writes ${h.auth === 'open' ? 'open' : 'need the token'} · ` +
      `${j.queued || 0} queued, ${j.running || 0} running` +
      (h.shipped_studies?.status === 'storing' ? ' · storing the shipped studies…' : '');
    // The shipped studies are stored in the background at start: the list follows as they arrive.
    const offered = h.shipped_studies?.offered?.length ?? 0;
    if (offered !== state.shipped) {
      state.shipped = offered;
      loadScenes().catch((e) => showError(e));
    }
    $('token-note').textContent = h.auth === 'open' ? '(not needed: writes are open)' : '(needed; kept in this tab only)';
    $('health').classList.remove('down');
  } catch (e) {
    $('health').textContent = `service unreachable: ${e.message}`;
    $('health').classList.add('down');
  }
}

let sceneAddOpened = false; // the scene box was opened because there was no scene yet

// The stored scenes in the picker. The scene picked stays picked (its ticked structures with it); a new pick
// (selectId, or the first scene there is) shows its structures.
async function loadScenes(selectId) {
  const scenes = await getAll('/scenes?limit=1000', 'scenes');
  state.scenes = scenes;
  const sel = $('scene-select');
  sel.replaceChildren();
  if (scenes.length === 0) {
    const o = new Option('no stored scenes yet: add one below', '');
    sel.append(o);
    sceneAddOpened = sceneAddOpened || !$('scene-add').open;
    $('scene-add').open = true;
  } else if (sceneAddOpened) {
    sceneAddOpened = false;
    $('scene-add').open = false;
  }
  for (const s of scenes) sel.append(new Option(`${s.name} (#${s.id}, ${s.structures.length} candidate structures)`, s.id));
  const keep = selectId ?? state.scene?.id ?? scenes[0]?.id;
  if (keep != null) sel.value = String(keep);
  if (selectId != null || state.scene?.id !== keep) await pickScene();
}

async function pickScene() {
  const id = Number($('scene-select').value);
  const list = $('structure-list');
  if (!id) {
    state.scene = null;
    list.replaceChildren(Object.assign(document.createElement('span'), { className: 'muted', textContent: 'pick a scene' }));
    scheduleEstimate();
    return;
  }
  const s = await get(`/scenes/${id}`);
  const types = {};
  for (const st of s.scene.structures || []) types[st.name] = st.type;
  state.scene = { id, name: s.name, structures: s.structures, types, dimensions: s.scene.dimensions };
  list.replaceChildren();
  if (s.structures.length === 0) {
    list.append(Object.assign(document.createElement('span'), { className: 'muted', textContent: 'this scene has no candidate structures' }));
  }
  for (const name of s.structures) {
    const label = document.createElement('label');
    label.className = 'check';
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.value = name;
    box.name = 'structure';
    const type = (types[name] || '').replace(/_/g, ' ');
    const text = document.createElement('span');
    text.append(document.createTextNode(name));
    if (type) text.append(Object.assign(document.createElement('span'), { className: 'muted small', textContent: ` ${type}` }));
    label.append(box, text);
    list.append(label);
  }
  scheduleEstimate();
}

async function storeScene() {
  clearErrors(['scene']);
  const text = $('scene-json').value;
  try {
    const s = await post('/scenes', text); // the text as it is: the API judges the JSON
    $('err-scene').textContent = '';
    $('submit-status').textContent = `scene #${s.id} ${s.name} stored`;
    await loadScenes(s.id);
    $('scene-add').open = false;
  } catch (e) {
    showError(e, 'scene');
  }
}

// ---------------------------------------------------------------------------------------------------------
// The form

function tickedStructures() {
  return [...document.querySelectorAll('#structure-list input[type=checkbox]:checked')].map((b) => b.value);
}

function mode() {
  return document.querySelector('input[name=mode]:checked').value;
}

// The fidelity as the API takes it. A custom dp is sent as typed when it is not a number, so that the API's
// message (not the page's) answers it.
function fidelity() {
  const f = $('fidelity').value;
  if (f !== 'custom') return f;
  const text = $('dp').value.trim();
  const n = Number(text);
  return { dp: text !== '' && Number.isFinite(n) ? n : text };
}

function jobBody(structures = tickedStructures()) {
  const body = { scene_id: state.scene?.id ?? null, structures, fidelity: fidelity() };
  const v = $('variant').value.trim();
  if (v) body.variant = v;
  return body;
}

function sweepBody() {
  const body = { scene_id: state.scene?.id ?? null, fidelity: fidelity(), factorial: { structures: tickedStructures() } };
  const n = $('sweep-name').value.trim();
  const p = $('sweep-prefix').value.trim();
  if (n) body.name = n;
  if (p) body.factorial.prefix = p;
  return body;
}

// The sweep file as POST /sweeps takes it: as written, but its `base` (a file name on the engineer's machine)
// becomes the base scene picked above; an inline base scene (an object) is sent as it is. Not JSON: said
// beside the file (nothing to send).
function sweepFileBody() {
  let body;
  try {
    body = JSON.parse($('sweep-json').value);
  } catch (e) {
    throw new ApiError(0, '(sweep file)', `not JSON: ${e.message}`);
  }
  if (body === null || typeof body !== 'object' || Array.isArray(body))
    throw new ApiError(0, '(sweep file)', 'must be a JSON object {name, base, fidelity, variants or factorial}');
  if (typeof body.base !== 'object' || body.base === null) {
    delete body.base;
    body.scene_id = state.scene?.id ?? null;
  }
  if (body.fidelity === undefined) body.fidelity = fidelity();
  return body;
}

// The layouts of a sweep body: its variants' structures, or every subset of its factorial's.
function sweepLayouts(body) {
  if (Array.isArray(body.variants)) return body.variants.map((v) => (Array.isArray(v?.structures) ? v.structures : []));
  const names = body.factorial?.structures;
  return Array.isArray(names) ? subsets(names) : [];
}

// All subsets of `names`, as factorial_variants numbers them (by size, then order).
function subsets(names) {
  const out = [];
  for (let m = 0; m < 1 << names.length; m++) out.push(names.filter((_, k) => m & (1 << k)));
  return out.sort((a, b) => a.length - b.length);
}

let estimateTimer = null;
function scheduleEstimate() {
  clearTimeout(estimateTimer);
  estimateTimer = setTimeout(runEstimate, 350);
}

async function runEstimate() {
  const seq = ++state.estimateSeq;
  const box = $('estimate');
  clearErrors(FORM_SLOTS);
  if (!state.scene) {
    box.replaceChildren();
    return;
  }
  box.classList.add('busy');
  try {
    if (mode() === 'single') {
      const e = await post('/estimate', jobBody());
      if (seq !== state.estimateSeq) return;
      renderEstimate([e], 1);
    } else if (mode() === 'file') {
      if (!$('sweep-json').value.trim()) {
        box.replaceChildren();
        return;
      }
      const body = sweepFileBody();
      const layouts = sweepLayouts(body);
      $('sweep-summary').textContent = `${body.name || 'sweep'}: ${layouts.length} layout${layouts.length === 1 ? '' : 's'} on ${body.scene_id ? `scene #${body.scene_id}` : 'its own base scene'}`;
      // Up to 32 layouts each estimated; beyond, the first and the last bracket the rest.
      const picked = layouts.length <= 32 ? layouts : [layouts[0], layouts[layouts.length - 1]];
      const results = [];
      for (const structures of picked) {
        const e = { structures, fidelity: body.fidelity };
        if (body.scene_id !== undefined) e.scene_id = body.scene_id;
        else e.base = body.base;
        results.push(await post('/estimate', e));
        if (seq !== state.estimateSeq) return;
      }
      if (results.length) renderEstimate(results, layouts.length, 'listed');
      else box.replaceChildren();
    } else {
      const names = tickedStructures();
      // Up to 32 layouts each estimated; beyond, the empty and the full layout bracket the rest.
      const layouts = names.length <= 5 ? subsets(names) : [[], names];
      const results = [];
      for (const layout of layouts) {
        const body = jobBody(layout);
        delete body.variant;
        results.push(await post('/estimate', body));
        if (seq !== state.estimateSeq) return;
      }
      renderEstimate(results, 2 ** names.length);
    }
  } catch (e) {
    if (seq !== state.estimateSeq) return;
    box.replaceChildren(Object.assign(document.createElement('span'), { className: 'muted', textContent: 'no estimate: see the message beside the field' }));
    delete box.dataset.fluid;
    showError(e);
  } finally {
    if (seq === state.estimateSeq) box.classList.remove('busy');
  }
}

function renderEstimate(results, jobs, design = 'factorial') {
  const box = $('estimate');
  box.replaceChildren();
  const e = results[0];
  const m = e.model;
  if (jobs === 1) {
    delete box.dataset.jobs;
    box.dataset.fluid = e.particles.fluid;
    box.dataset.boundary = e.particles.boundary;
    box.dataset.steps = e.steps_estimate;
    box.dataset.seconds = e.seconds_estimate;
    box.innerHTML = '';
    const lines = [
      ['particles', `${int(e.particles.fluid)} fluid + ${int(e.particles.boundary)} boundary = ${int(e.particles.total)} (budget ${int(e.particle_budget)})`],
      ['steps', `≈ ${int(e.steps_estimate)} (Δt ≈ ${shortNumber(m.dt_s * 1000)} ms over ${shortNumber(m.duration_s)} s; dp ${shortNumber(e.dp)} m)`],
      ['run time', `≈ ${duration(e.seconds_estimate)} on ${m.threads} thread${m.threads === 1 ? '' : 's'}`],
    ];
    box.append(definitionList(lines));
  } else {
    const fluid = results.map((r) => r.particles.fluid);
    const total = results.map((r) => r.particles.total);
    const mean = (a) => a.reduce((s, x) => s + x, 0) / a.length;
    const secs = results.map((r) => r.seconds_estimate);
    const steps = results.map((r) => r.steps_estimate);
    const exact = results.length === jobs;
    const allSecs = exact ? secs.reduce((s, x) => s + x, 0) : mean(secs) * jobs;
    for (const k of ['fluid', 'boundary', 'steps']) delete box.dataset[k];
    box.dataset.jobs = jobs;
    box.dataset.seconds = allSecs;
    box.append(
      definitionList([
        ['jobs', design === 'factorial' ? `${jobs} (every subset of ${Math.log2(jobs)} structures)` : `${jobs} (the file's layouts)`],
        ['particles per job', `${int(Math.min(...fluid))}–${int(Math.max(...fluid))} fluid, ${int(Math.min(...total))}–${int(Math.max(...total))} in all`],
        ['steps per job', `≈ ${int(Math.min(...steps))}–${int(Math.max(...steps))}`],
        ['run time', `${exact ? '≈' : 'about'} ${duration(allSecs)} for the sweep on one worker`],
      ]),
    );
  }
}

function definitionList(rows) {
  const dl = document.createElement('dl');
  for (const [k, v] of rows) {
    dl.append(Object.assign(document.createElement('dt'), { textContent: k }), Object.assign(document.createElement('dd'), { textContent: v }));
  }
  return dl;
}

async function submit(ev) {
  ev.preventDefault();
  clearErrors(FORM_SLOTS);
  const status = $('submit-status');
  if (!state.scene && mode() !== 'file') {
    showError(new ApiError(0, 'scene_id', 'pick a stored scene, or add one'));
    return;
  }
  $('submit-btn').disabled = true;
  status.textContent = 'submitting…';
  try {
    if (mode() === 'single') {
      const job = await post('/jobs', jobBody());
      status.textContent = `job #${job.id} ${job.scene_name} queued`;
    } else if (mode() === 'file') {
      const sweep = await post('/sweeps', sweepFileBody());
      status.textContent = sweep.study
        ? `study #${sweep.id} ${sweep.name}: ${sweep.jobs.length} screening jobs queued; then up to ${sweep.study.detailed.candidates} layouts in 3D`
        : `sweep #${sweep.id} ${sweep.name}: ${sweep.jobs.length} jobs queued`;
    } else {
      const sweep = await post('/sweeps', sweepBody());
      status.textContent = `sweep #${sweep.id} ${sweep.name}: ${sweep.jobs.length} jobs queued`;
    }
    await pollJobs();
  } catch (e) {
    status.textContent = '';
    showError(e);
  } finally {
    $('submit-btn').disabled = false;
  }
}

// ---------------------------------------------------------------------------------------------------------
// Jobs

const PAGE = 100;
let pollTimer = null;

async function pollJobs() {
  clearTimeout(pollTimer);
  let active = false;
  try {
    // The newest PAGE jobs (the list is oldest first).
    let r = await get(`/jobs?limit=${PAGE}&offset=${Math.max(0, state.total - PAGE)}`);
    if (r.total !== state.total) {
      state.total = r.total;
      r = await get(`/jobs?limit=${PAGE}&offset=${Math.max(0, r.total - PAGE)}`);
    }
    state.jobs = new Map(r.jobs.map((j) => [j.id, j]));
    renderJobs(r);
    active = r.jobs.some((j) => j.status === 'queued' || j.status === 'running');
    $('err-jobs').textContent = '';
  } catch (e) {
    $('err-jobs').textContent = `jobs: ${e.message}`;
  }
  loadHealth();
  active = (await pollSweeps()) || active;
  pollTimer = setTimeout(pollJobs, active ? 1000 : 4000);
}

// ---------------------------------------------------------------------------------------------------------
// Sweeps and studies: the newest sweeps with their progress; a study's two stages (GET /sweeps/{id} `study`)

const SWEEPS = 10;
const studies = new Map(); // sweep id -> the latest GET /sweeps/{id} of a study (read again while it runs)

async function pollSweeps() {
  let active = false;
  try {
    const r = await get(`/sweeps?limit=${SWEEPS}`);
    for (const s of r.sweeps) {
      if (s.status === 'running') active = true;
      const seen = studies.get(s.id);
      if (s.study && (s.status === 'running' || seen?.status !== s.status)) studies.set(s.id, await get(`/sweeps/${s.id}`));
    }
    renderSweeps(r.sweeps);
    $('err-sweeps').textContent = '';
  } catch (e) {
    $('err-sweeps').textContent = `sweeps: ${e.message}`;
  }
  return active;
}

function progressBar(fraction, status) {
  const bar = Object.assign(document.createElement('div'), { className: 'bar' });
  const fill = Object.assign(document.createElement('div'), { className: `fill status-${status}` });
  fill.style.width = `${(100 * fraction).toFixed(1)}%`;
  bar.append(fill);
  return bar;
}

const stageStatus = (st) => (st.jobs_by_status.queued + st.jobs_by_status.running > 0 ? 'running' : 'done');

function stageRow(label, bar) {
  const row = Object.assign(document.createElement('div'), { className: 'stage' });
  row.append(Object.assign(document.createElement('span'), { className: 'small', textContent: label }), bar);
  return row;
}

function renderStudy(li, d) {
  const st = d.study;
  const s1 = st.screening;
  const s2 = st.detailed;
  const count = (x) => `${x.jobs_by_status.done}/${x.jobs_total} done`;
  li.append(stageRow(`1 · screening (${s1.fidelity}): ${count(s1)}`, progressBar(s1.progress.fraction, stageStatus(s1))));
  const o = st.outcome;
  const second = o
    ? `2 · 3D (${s2.fidelity}): ${count(s2)}, ${s2.jobs_total} of ${s2.candidates} layouts`
    : `2 · 3D (${s2.fidelity}): waits for the screening stage (${s2.candidates} layouts planned)`;
  li.append(stageRow(second, progressBar(o ? s2.progress.fraction : 0, o ? stageStatus(s2) : 'queued')));
  if (!o) return;
  const chosen = o.layouts.filter((l) => l.chosen).map((l) => l.layout);
  const dropped = o.layouts.filter((l) => !l.chosen);
  const leader = o.leader ? `leader ${o.leader}` : 'no layout has a screening value to rank by, so every one is kept';
  const lines = [
    o.members ? `screened over ${o.members} members; ${leader}; to 3D: ${chosen.join(', ') || 'none'}` : 'no screening member completed: nothing goes on to 3D',
  ];
  if (o.note) lines.push(o.note);
  if (dropped.length) lines.push(`dropped: ${dropped.map((l) => `${l.layout} (${l.why.replace(/^dropped: /, '')})`).join('; ')}`);
  if (st.stage === 'done' && o.ranking.length) lines.push(`3D ranking, lowest ${o.ranking_metric || 'value'} first: ${o.ranking.join(', ')}`);
  for (const t of lines) li.append(Object.assign(document.createElement('div'), { className: 'small', textContent: t }));
}

function renderSweeps(sweeps) {
  $('sweeps-card').hidden = sweeps.length === 0;
  const list = $('sweeps-list');
  list.replaceChildren();
  for (const s of sweeps) {
    const li = document.createElement('li');
    li.dataset.sweep = s.id;
    const head = Object.assign(document.createElement('div'), { className: 'row' });
    head.append(
      Object.assign(document.createElement('strong'), { textContent: `#${s.id} ${s.name}` }),
      Object.assign(document.createElement('span'), { className: 'muted small', textContent: `${s.study ? 'study' : 'sweep'} · ${s.fidelity} · ${s.jobs_total} jobs` }),
      Object.assign(document.createElement('span'), { className: `badge status-${s.status}`, textContent: s.status }),
    );
    if (s.jobs_by_status.done > 0) head.append(Object.assign(document.createElement('a'), { href: `${API}/sweeps/${s.id}/report.html`, textContent: 'report', target: '_blank', rel: 'noopener' }));
    li.append(head);
    const d = studies.get(s.id);
    if (s.study && d && d.study) renderStudy(li, d);
    else {
      const finished = s.jobs_by_status.done + s.jobs_by_status.failed + s.jobs_by_status.cancelled;
      li.append(stageRow(`${finished}/${s.jobs_total} finished`, progressBar(s.jobs_total ? finished / s.jobs_total : 1, s.status === 'running' ? 'running' : s.status)));
    }
    list.append(li);
  }
}

const rows = new Map(); // job id -> <tr>

function cell(tr, k) {
  return tr.children[k];
}

function renderJobs(r) {
  const tbody = document.querySelector('#jobs-table tbody');
  const ids = r.jobs.map((j) => j.id).reverse(); // newest first
  for (const [id, tr] of rows) if (!state.jobs.has(id)) (tr.remove(), rows.delete(id));
  let previous = null;
  for (const id of ids) {
    const j = state.jobs.get(id);
    let tr = rows.get(id);
    if (!tr) {
      tr = newJobRow(j);
      rows.set(id, tr);
    }
    if (previous ? previous.nextSibling !== tr : tbody.firstChild !== tr) {
      if (previous) previous.after(tr);
      else tbody.prepend(tr);
    }
    previous = tr;
    updateJobRow(tr, j);
  }
  $('jobs-more').textContent = r.total > ids.length ? `the newest ${ids.length} of ${r.total} jobs` : r.total === 0 ? 'no jobs yet' : '';
  for (const id of [...state.ticked]) if (!state.jobs.has(id)) state.ticked.delete(id);
  updateCompareButton();
}

function newJobRow(j) {
  const tr = document.createElement('tr');
  tr.dataset.job = j.id;
  const tick = Object.assign(document.createElement('input'), { type: 'checkbox', title: `compare job ${j.id}` });
  tick.className = 'tick';
  tick.addEventListener('change', () => {
    if (tick.checked) state.ticked.add(j.id);
    else state.ticked.delete(j.id);
    updateCompareButton();
  });
  const base = Object.assign(document.createElement('input'), { type: 'radio', name: 'baseline', title: `job ${j.id} as the baseline` });
  base.className = 'base';
  base.addEventListener('change', () => {
    if (base.checked) state.baseline = j.id;
    updateCompareButton();
  });
  const cancel = Object.assign(document.createElement('button'), { type: 'button', textContent: 'cancel', className: 'cancel' });
  cancel.addEventListener('click', () => cancelJob(j.id, cancel));
  const cells = [tick, base, null, null, null, null, null, null, cancel];
  cells.forEach((c, k) => {
    const td = document.createElement(k === 2 ? 'th' : 'td');
    if (k === 2) td.scope = 'row';
    if (k === 4 || k === 5) td.className = 'wide';
    if (k === 5) td.classList.add('num');
    if (c) td.append(c);
    tr.append(td);
  });
  const bar = document.createElement('div');
  bar.className = 'bar';
  bar.append(Object.assign(document.createElement('div'), { className: 'fill' }));
  cell(tr, 7).append(bar, Object.assign(document.createElement('span'), { className: 'small progress-text' }));
  return tr;
}

function updateJobRow(tr, j) {
  const done = j.status === 'done';
  const tick = tr.querySelector('.tick');
  const base = tr.querySelector('.base');
  tick.disabled = !done;
  base.disabled = !done;
  tick.checked = done && state.ticked.has(j.id);
  base.checked = done && state.baseline === j.id;
  cell(tr, 2).textContent = j.id;
  const name = cell(tr, 3);
  name.textContent = j.scene_name;
  if (j.sweep) name.append(Object.assign(document.createElement('span'), { className: 'muted small', textContent: ` · ${j.sweep}` }));
  cell(tr, 4).textContent = j.fidelity + (j.dp ? ` ${j.dp} m` : '');
  cell(tr, 5).textContent = int(j.particles);
  const st = cell(tr, 6);
  st.replaceChildren(Object.assign(document.createElement('span'), { className: `badge status-${j.status}`, textContent: j.cancel_requested && j.status === 'running' ? 'cancelling' : j.status }));
  st.dataset.status = j.status;
  st.title = j.error || '';
  if (j.error) st.append(Object.assign(document.createElement('div'), { className: 'small error-text', textContent: j.error }));
  const p = j.progress;
  const frac = done ? 1 : p.fraction || 0;
  const fill = tr.querySelector('.fill');
  fill.style.width = `${(100 * frac).toFixed(1)}%`;
  fill.className = `fill status-${j.status}`;
  const eta = j.status === 'running' && p.eta_seconds != null ? ` · ${duration(p.eta_seconds)} left` : '';
  tr.querySelector('.progress-text').textContent =
    j.status === 'queued' ? 'waiting' : `${(100 * frac).toFixed(0)} % · ${shortNumber(p.simulated_time)}/${shortNumber(p.duration)} s${eta}`;
  const cancel = tr.querySelector('.cancel');
  cancel.hidden = !(j.status === 'queued' || (j.status === 'running' && !j.cancel_requested));
}

async function cancelJob(id, button) {
  button.disabled = true;
  clearErrors(['Authorization']);
  try {
    await del(`/jobs/${id}`);
    $('err-jobs').textContent = '';
  } catch (e) {
    $('err-jobs').textContent = `job ${id}: ${e.field ? e.field + ': ' : ''}${e.message}`;
    if (e.field === 'Authorization') showError(e);
  } finally {
    button.disabled = false;
    pollJobs();
  }
}

function updateCompareButton() {
  const others = [...state.ticked].filter((id) => id !== state.baseline && state.jobs.get(id)?.status === 'done');
  const ok = state.baseline != null && state.jobs.get(state.baseline)?.status === 'done' && others.length > 0;
  $('compare-btn').disabled = !ok;
  $('compare-btn').textContent = ok ? `Compare ${others.length} with #${state.baseline}` : 'Compare ticked with baseline';
}

// ---------------------------------------------------------------------------------------------------------
// Compare

let jobsById = new Map(); // the compared jobs (id -> {id, label, colour})

async function showCompare() {
  const base = state.baseline;
  const ids = [...state.ticked].filter((id) => id !== base && state.jobs.get(id)?.status === 'done').sort((a, b) => a - b);
  const card = $('compare-card');
  card.hidden = false;
  card.dataset.ready = 'false';
  $('err-compare').textContent = '';
  let c;
  try {
    c = await get(`/compare?jobs=${[base, ...ids].join(',')}&baseline=${base}`);
  } catch (e) {
    $('err-compare').textContent = `${e.field ? e.field + ': ' : ''}${e.message}`;
    return;
  }
  const jobs = [
    { id: c.baseline.job, label: c.baseline.label, colour: colourOf(0) },
    ...c.jobs.map((j, k) => ({ id: j.job, label: j.label, colour: colourOf(k + 1) })),
  ];
  jobsById = new Map(jobs.map((j) => [j.id, j]));
  $('compare-head').textContent = `baseline #${c.baseline.job} ${c.baseline.label}; ${c.jobs.map((j) => `#${j.job} ${j.label}`).join(', ')}`;
  renderReportLink(c);
  renderRanking(c);
  renderMetrics(c);
  card.scrollIntoView({ behavior: 'instant', block: 'start' });
  await Promise.all([renderCharts(jobs), renderMaps(jobs)]);
  card.dataset.ready = 'true';
}

// The sweep's study report (GET /compare `sweep`), when every compared job is a layout of one sweep.
function renderReportLink(c) {
  const p = $('report-link');
  p.replaceChildren();
  p.hidden = !c.sweep;
  if (!c.sweep) return;
  const a = Object.assign(document.createElement('a'), { href: c.sweep.report, textContent: `the study report of sweep ${c.sweep.name}`, target: '_blank', rel: 'noopener' });
  p.append(document.createTextNode('All layouts of the sweep, ranked, with hydrographs, intensity and difference maps: '), a);
}

// The layouts ranked by the server (GET /compare `ranking`: the outlet's peak discharge, lowest first).
function renderRanking(c) {
  const box = $('ranking');
  box.replaceChildren();
  const r = c.ranking;
  if (!r) {
    box.append(Object.assign(document.createElement('p'), { className: 'muted small', textContent: 'No ranking: these runs have no cross-section (the ranking key is the outlet\'s peak discharge).' }));
    return;
  }
  const key = document.createElement('p');
  key.className = 'ranking-key';
  key.append(document.createTextNode('Layouts ranked by '), Object.assign(document.createElement('strong'), { textContent: `the peak discharge at the outlet (${c.outlet})` }),
    document.createTextNode(', lowest first: less debris leaving the reach is the better layout.'));
  const list = document.createElement('ol');
  list.className = 'ranking-list';
  const ranks = r.layouts.map((l) => l.rank);
  const tied = (rank) => ranks.filter((x) => x === rank).length > 1;
  for (const l of r.layouts) {
    const li = document.createElement('li');
    li.dataset.job = l.job;
    li.dataset.rank = l.rank;
    li.dataset.value = l.value == null ? '' : String(l.value);
    const job = jobsById.get(l.job);
    if (job) {
      const sw = Object.assign(document.createElement('span'), { className: 'swatch' });
      sw.style.background = job.colour;
      li.append(sw);
    }
    li.append(Object.assign(document.createElement('span'), { className: 'rank', textContent: `${l.rank}.` }),
      Object.assign(document.createElement('span'), { className: 'rank-label', textContent: `#${l.job} ${l.label}${l.baseline ? ' (baseline)' : ''}` }),
      Object.assign(document.createElement('span'), { className: 'num', textContent: l.value == null ? 'no value' : `${shortNumber(l.value)} m³/s` }));
    if (l.rank === 1 && !tied(1)) li.append(Object.assign(document.createElement('span'), { className: 'best', textContent: 'best' }));
    else if (tied(l.rank)) li.append(Object.assign(document.createElement('span'), { className: 'tie', textContent: 'tied' }));
    list.append(li);
  }
  box.append(key, list);
  if (new Set(ranks).size === 1 && r.layouts.length > 1)
    box.append(Object.assign(document.createElement('p'), { className: 'muted small', textContent: 'Every layout ties on this key (the same peak discharge at the outlet: in these runs perhaps none reached it); the decision metrics below tell them apart.' }));
}

function renderMetrics(c) {
  const table = $('compare-table');
  const head = table.tHead;
  const body = table.tBodies[0];
  head.replaceChildren();
  body.replaceChildren();
  const r1 = document.createElement('tr');
  const r2 = document.createElement('tr');
  const th = (text, attrs = {}) => Object.assign(document.createElement('th'), { textContent: text, scope: 'col', ...attrs });
  r1.append(th('metric', { rowSpan: 2 }), th(`baseline #${c.baseline.job} ${c.baseline.label}`, { rowSpan: 2 }));
  for (const j of c.jobs) {
    r1.append(th(`#${j.job} ${j.label}`, { colSpan: 3 }));
    r2.append(th('value'), th('Δ'), th('Δ %'));
  }
  head.append(r1, r2);
  // never: an arrival time that never happened (GET /compare's never / baseline_never), shown as the word.
  const td = (v, metric, job, kind, digits, never = false) => {
    const d = document.createElement('td');
    d.className = 'num';
    d.textContent = never ? 'never' : tableNumber(v, digits);
    d.dataset.metric = metric;
    d.dataset.job = job;
    d.dataset.kind = kind;
    d.dataset.value = v == null ? '' : String(v);
    if (never) d.dataset.never = 'true';
    // Better or worse by the metric's direction (a later arrival is better); no direction: no judgement.
    if ((kind === 'difference' || kind === 'percent') && v != null && v !== 0 && better) {
      const good = better === 'higher' ? v > 0 : v < 0;
      d.classList.add(good ? 'better' : 'worse');
      d.dataset.judged = good ? 'better' : 'worse';
    }
    return d;
  };
  let better = null; // the row's direction, while its cells are made
  let previous = null;
  for (const m of c.metrics) {
    const tr = document.createElement('tr');
    tr.dataset.metric = m.metric;
    tr.dataset.decision = String(Boolean(m.decision));
    if (m.decision) tr.classList.add('decision');
    else if (previous?.decision) tr.classList.add('first-other');
    previous = m;
    const differs = m.difference.some((d) => d != null && d !== 0) || (m.never ?? []).some((n) => n !== Boolean(m.baseline_never));
    tr.dataset.differs = differs;
    // The metric for people (the API's label), the stored name in its tooltip; a metric without a label keeps
    // its stored name, in monospace.
    const head = Object.assign(document.createElement('th'), { scope: 'row', textContent: m.label ?? m.metric, title: m.metric });
    if (m.label && m.label !== m.metric) head.className = 'labelled';
    tr.append(head);
    better = m.better ?? null;
    tr.append(td(m.baseline, m.metric, c.baseline.job, 'baseline', 6, m.baseline_never));
    c.jobs.forEach((j, k) => {
      tr.append(td(m.values[k], m.metric, j.job, 'value', 6, m.never?.[k]), td(m.difference[k], m.metric, j.job, 'difference', 6), td(m.percent[k], m.metric, j.job, 'percent', 4));
    });
    body.append(tr);
  }
  // Opens on the decision metrics; with none (a scene without monitors), on every metric.
  const decisions = c.metrics.filter((m) => m.decision).length;
  $('all-metrics').checked = decisions === 0;
  $('all-metrics').disabled = decisions === 0;
  table.dataset.decisions = decisions;
  filterMetrics();
}

function filterMetrics() {
  const q = $('metric-filter').value.trim().toLowerCase();
  const only = $('only-diff').checked;
  const all = $('all-metrics').checked;
  let shown = 0;
  const rows = $('compare-table').tBodies[0].rows;
  for (const tr of rows) {
    tr.hidden = (!all && tr.dataset.decision !== 'true') || (q && !tr.dataset.metric.toLowerCase().includes(q)) || (only && tr.dataset.differs !== 'true');
    shown += !tr.hidden;
  }
  $('metric-count').textContent = `${shown} of ${rows.length} metrics${all ? '' : ' (the decision metrics; tick “all metrics” for the rest)'}`;
}

async function seriesOf(job, name) {
  const res = await fetch(`${API}/jobs/${job}/series/${encodeURIComponent(name)}.csv`);
  if (!res.ok) return null;
  return parseCsv(await res.text());
}

function column(csv, name) {
  const k = csv.columns.indexOf(name);
  return k < 0 ? null : csv.data[k];
}

async function renderCharts(jobs) {
  const box = $('charts');
  clearCharts(box);
  const metrics = await Promise.all(jobs.map((j) => get(`/jobs/${j.id}/metrics`)));
  const names = new Set(metrics.flatMap((m) => m.series));
  const sorted = [...names].sort();
  const lines = async (series, col) => {
    const out = [];
    for (let k = 0; k < jobs.length; k++) {
      if (!metrics[k].series.includes(series)) continue;
      const csv = await seriesOf(jobs[k].id, series);
      const y = csv && column(csv, col);
      if (!y) continue;
      out.push({ label: `#${jobs[k].id} ${jobs[k].label}`, colour: jobs[k].colour, x: column(csv, 't'), y });
    }
    return out;
  };
  const chart = async (id, title, series, col, yLabel) => {
    const l = await lines(series, col);
    if (l.length) lineChart(box, { id, title, xLabel: 't [s]', yLabel, lines: l });
  };
  for (const s of sorted.filter((n) => n.startsWith('section_')))
    await chart(s, `Hydrograph at ${s.slice(8)}`, s, 'discharge_m3_s', 'discharge [m³/s]');
  for (const s of sorted.filter((n) => n.startsWith('structure_load_'))) {
    const name = s.slice(15);
    // Load-cell readings (window means, docs/scene-format.md "structure_load"); the single-particle pressure
    // is a diagnostic in the CSV, not a design value.
    await chart(`${s}:force`, `Force on ${name} (load-cell window)`, s, 'force_n', 'force [N]');
    await chart(`${s}:pressure`, `Mean pressure on ${name} (load-cell window)`, s, 'mean_pressure_pa', 'pressure [Pa]');
  }
  if (names.has('run')) await chart('front', 'Front position', 'run', 'front_x', 'front x [m]');
  if (!box.children.length) box.append(Object.assign(document.createElement('p'), { className: 'muted', textContent: 'no series to plot' }));
}

// A map per job, all on one colour scale per raster (map.json?shared=): the same colour is the same value on
// every map, and the page says so.
async function renderMaps(jobs) {
  const box = $('maps');
  for (const f of box.querySelectorAll('figure.map')) f.__map?.remove();
  box.replaceChildren();
  const ids = jobs.map((j) => j.id);
  $('maps-scale').textContent = ids.length > 1
    ? `The ${ids.length} maps share one colour scale per raster, from the largest value among jobs ${ids.map((i) => `#${i}`).join(', ')}: the same colour means the same value on every map (each legend gives the scale and its map's own largest value).`
    : '';
  await Promise.all(jobs.map((j) => drawMap(box, j, ids.length > 1 ? ids : [])));
}

// ---------------------------------------------------------------------------------------------------------

function wire() {
  $('token').value = token();
  $('token').addEventListener('input', () => {
    setToken($('token').value.trim());
    scheduleEstimate();
  });
  $('scene-select').addEventListener('change', () => pickScene().catch((e) => showError(e)));
  $('structure-list').addEventListener('change', scheduleEstimate);
  for (const r of document.querySelectorAll('input[name=mode]'))
    r.addEventListener('change', () => {
      const m = mode();
      $('field-name').hidden = m !== 'factorial';
      $('field-variant').hidden = m !== 'single';
      $('field-sweep_file').hidden = m !== 'file';
      $('field-structures').hidden = m === 'file'; // the file names its layouts
      $('submit-btn').textContent = { single: 'Submit', factorial: 'Submit the sweep', file: 'Submit the sweep file' }[m];
      scheduleEstimate();
    });
  $('sweep-file').addEventListener('change', async () => {
    const f = $('sweep-file').files[0];
    if (f) $('sweep-json').value = await f.text();
    scheduleEstimate();
  });
  $('sweep-json').addEventListener('input', scheduleEstimate);
  $('fidelity').addEventListener('change', () => {
    $('dp').hidden = $('fidelity').value !== 'custom';
    scheduleEstimate();
  });
  for (const id of ['dp', 'variant', 'sweep-name', 'sweep-prefix']) $(id).addEventListener('input', scheduleEstimate);
  $('job-form').addEventListener('submit', submit);
  $('scene-store').addEventListener('click', storeScene);
  $('scene-file').addEventListener('change', async () => {
    const f = $('scene-file').files[0];
    if (f) $('scene-json').value = await f.text();
  });
  $('compare-btn').addEventListener('click', showCompare);
  $('metric-filter').addEventListener('input', filterMetrics);
  $('only-diff').addEventListener('change', filterMetrics);
  $('all-metrics').addEventListener('change', filterMetrics);
}

wire();
loadHealth();
loadScenes().catch((e) => showError(e));
pollJobs();
