// The maximum-depth map of a terrain job: map.png (hillshade and depth, drawn by the run) under an SVG layer
// with the structures, protected zones, release and cross-sections from GET /jobs/{id}/map.json, placed by
// the raster's extent (the PNG enlarges each raster cell by a whole factor, so cell units fit both).
import { API, get } from '/web/api.js';

const SVG = 'http://www.w3.org/2000/svg';

function el(name, attrs = {}, parent = null) {
  const e = document.createElementNS(SVG, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  if (parent) parent.append(e);
  return e;
}

// Map coordinates (working CRS, metres) to raster cell units (x east from the west edge, y down from north).
function projector(r) {
  return ([x, y]) => [(x - r.west) / r.dx, (r.north - y) / r.dy];
}

function pathOf(geometry, project) {
  const rings = geometry.type === 'Polygon' ? geometry.coordinates : [geometry.coordinates];
  return rings
    .map((ring) => ring.map((p, i) => `${i ? 'L' : 'M'}${project(p).map((v) => v.toFixed(2)).join(' ')}`).join(' ') +
      (geometry.type === 'Polygon' ? ' Z' : ''))
    .join(' ');
}

function centre(geometry, project) {
  const pts = (geometry.type === 'Polygon' ? geometry.coordinates[0] : geometry.coordinates).map(project);
  const n = pts.length || 1;
  return [pts.reduce((s, p) => s + p[0], 0) / n, pts.reduce((s, p) => s + p[1], 0) / n];
}

// Appends a figure for job `job` ({id, label, colour}); resolves once the picture and its layer are drawn.
export async function drawMap(container, job) {
  const figure = document.createElement('figure');
  figure.className = 'map';
  figure.dataset.job = job.id;
  const caption = document.createElement('figcaption');
  const swatch = document.createElement('span');
  swatch.className = 'swatch';
  swatch.style.background = job.colour;
  caption.append(swatch, document.createTextNode(` #${job.id} ${job.label}`));
  figure.append(caption);
  container.append(figure);

  let info;
  try {
    info = await get(`/jobs/${job.id}/map.json`);
  } catch (e) {
    const p = document.createElement('p');
    p.className = 'muted small';
    p.textContent = e.status === 404 ? 'no map: not a terrain scene' : `map unavailable: ${e.message}`;
    figure.append(p);
    return;
  }
  const r = info.raster;
  const project = projector(r);
  const frame = document.createElement('div');
  frame.className = 'map-frame';
  frame.style.aspectRatio = `${r.nx} / ${r.ny}`;
  const img = document.createElement('img');
  img.alt = `maximum flow depth of job ${job.id}`;
  img.src = `${API}/jobs/${job.id}/map.png`;
  const svg = el('svg', { viewBox: `0 0 ${r.nx} ${r.ny}`, preserveAspectRatio: 'none', role: 'img' });
  svg.setAttribute('aria-label', `structures and zones of job ${job.id}`);
  const font = Math.max(r.nx, r.ny) / 40;
  const label = (text, [x, y], cls) => {
    const t = el('text', { x: x.toFixed(2), y: y.toFixed(2), 'font-size': font.toFixed(2), class: `label ${cls}` }, svg);
    t.textContent = text;
  };
  const shape = (geometry, cls, name) => {
    const p = el('path', { d: pathOf(geometry, project), class: cls, 'vector-effect': 'non-scaling-stroke' }, svg);
    const title = el('title', {}, p);
    title.textContent = name;
    return p;
  };
  for (const z of info.protected_zones) {
    shape(z.geometry, 'zone', `protected zone ${z.name}`).dataset.zone = z.name;
    // At the zone's north-west corner, inside: zones nest (a village on a plain), their centres may meet.
    const pts = z.geometry.coordinates[0].map(project);
    const x = Math.min(...pts.map((p) => p[0])), y = Math.min(...pts.map((p) => p[1]));
    label(z.name, [x + font * 0.3, y + font * 1.1], 'zone');
  }
  if (info.release) shape(info.release.geometry, 'release', 'release');
  for (const s of info.sections) {
    shape(s.geometry, 'section', `cross-section ${s.name}`).dataset.section = s.name;
    label(s.name, project(s.geometry.coordinates[0]), 'section');
  }
  for (const s of info.structures) {
    shape(s.geometry, `structure ${s.type}`, `${s.type.replace('_', ' ')} ${s.name}`).dataset.structure = s.name;
    label(s.name, centre(s.geometry, project), 'structure');
  }
  frame.append(img, svg);
  figure.append(frame);
  const note = document.createElement('p');
  note.className = 'muted small';
  note.textContent = `${info.crs || 'working CRS'}; ${(r.east - r.west).toFixed(2)} × ${(r.north - r.south).toFixed(2)} m, cells ${r.dx} m`;
  figure.append(note);
  await new Promise((resolve) => {
    if (img.complete) resolve();
    img.addEventListener('load', resolve, { once: true });
    img.addEventListener('error', resolve, { once: true });
  });
}
