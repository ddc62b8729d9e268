// The map of a terrain job (docs/web.md, "The map"): Leaflet (web/package.json; the build copies it to
// /web/vendor) in the rasters' projected metres, with no basemap from the network. The hillshade at the
// bottom, one coloured raster at a time (depth, speed, pressure, intensity, ...: GET /jobs/{id}/rasters/{name}.png)
// with its legend drawn from the colour scale map.json serves, and the structures, protected zones,
// cross-sections and release as vector layers with popups naming them. Below the map, the job's downloads.
import * as L from '/web/vendor/leaflet-src.esm.js';
import { API, get } from '/web/api.js';

// The working CRS as Leaflet's plain CRS: lng = easting, lat = northing, in metres; the transformation puts
// the raster's north-west corner at the origin so that pixel numbers stay small at any zoom.
function crsFor(r) {
  return L.extend({}, L.CRS.Simple, { transformation: new L.Transformation(1, -r.west, -1, r.north) });
}

const latLngs = (points) => points.map(([x, y]) => [y, x]);

const STYLE = {
  structure: { color: '#d62728', weight: 4, fillOpacity: 0.15 },
  zone: { color: '#7b3294', weight: 2, dashArray: '6 4', fillOpacity: 0 }, // filled (clickable inside) but clear: the raster shows through
  section: { color: '#111111', weight: 2 },
  release: { color: '#8c510a', weight: 2, fillOpacity: 0.1 },
};

// A vector feature of map.json ({name, geometry}) as Leaflet layers: its path, named `what` in its popup and
// its hover tooltip (which follows the pointer), and (but for the release) a permanent label with its name.
// Labels are placed from the bounding box: Leaflet's own centre of a polygon loses its digits at UTM
// northings of 5e6 m and puts the label kilometres away.
function feature(f, kind, what) {
  const ll = latLngs(f.geometry.type === 'Polygon' ? f.geometry.coordinates[0] : f.geometry.coordinates);
  const layer = f.geometry.type === 'Polygon' ? L.polygon(ll, STYLE[kind]) : L.polyline(ll, STYLE[kind]);
  layer.bindPopup(what);
  layer.bindTooltip(what, { sticky: true });
  layer.feature = { kind, name: f.name || '' };
  if (kind === 'release') return [layer];
  const box = L.latLngBounds(ll);
  // A zone's label in its north-west corner, inside: zones nest (a village on a plain), their centres may meet.
  // A section's above its northern end, clear of the flow it gauges.
  const at = kind === 'zone' ? [box.getNorth(), box.getWest()] : kind === 'section' ? [box.getNorth(), box.getCenter().lng] : box.getCenter();
  const direction = { zone: 'right', section: 'top', structure: 'center' }[kind];
  const label = L.tooltip({ permanent: true, direction, offset: kind === 'zone' ? [4, 10] : [0, 0], className: `map-label ${kind}`, interactive: false })
    .setLatLng(at)
    .setContent(f.name);
  return [layer, label];
}

const numberText = (v) => String(Number(v.toPrecision(4)));

// The legend of a raster layer from its colour scale: a swatch and the scale's own label per stop (the stop's
// exact value in data-value), the ramp's gradient above them.
function legendOf(layer) {
  const box = document.createElement('div');
  box.className = 'legend';
  box.dataset.layer = layer.name;
  const title = document.createElement('div');
  title.className = 'legend-title';
  title.textContent = `${layer.title}${layer.scale.classes ? '' : ` [${layer.unit}]`}`;
  box.append(title);
  const stops = layer.scale.stops;
  if (!layer.scale.classes) {
    const bar = document.createElement('div');
    bar.className = 'legend-ramp';
    bar.style.background = `linear-gradient(to right, ${stops.map((s) => s.colour).join(', ')})`;
    box.append(bar);
  }
  const list = document.createElement('ul');
  for (const s of stops) {
    const li = document.createElement('li');
    li.dataset.value = String(s.value);
    li.dataset.colour = s.colour;
    const sw = document.createElement('span');
    sw.className = 'swatch';
    sw.style.background = s.colour;
    li.append(sw, document.createTextNode(s.label));
    list.append(li);
  }
  box.append(list);
  const note = document.createElement('div');
  note.className = 'legend-note';
  const sc = layer.scale;
  note.textContent = sc.classes ? 'no colour: not inundated'
    : !sc.zero_transparent ? 'no colour: never reached'
    : sc.min > 0 ? `no colour: below ${numberText(sc.min)} ${layer.unit} or no data` : 'no colour: zero or no data';
  box.append(note);
  // A shared scale says so: its top is the largest value among the compared jobs, not this map's own.
  const scope = document.createElement('div');
  scope.className = 'legend-note legend-scope';
  scope.dataset.shared = String(Boolean(sc.shared));
  if (!sc.classes)
    scope.textContent = sc.shared
      ? `scale shared by the compared maps (top: their largest value); this map's largest: ${numberText(sc.data_max)} ${layer.unit}`
      : `scale of this map alone (top: its largest value)`;
  box.append(scope);
  return box;
}

// The job's files: every raster (GeoTIFF), the hazard polygons, the depth picture and the series (CSV).
function downloads(job, info, series) {
  const box = document.createElement('details');
  box.className = 'downloads';
  box.open = true;
  const summary = document.createElement('summary');
  summary.textContent = `Downloads of job #${job.id}`;
  const list = document.createElement('ul');
  const link = (href, text, type) => {
    const li = document.createElement('li');
    const a = Object.assign(document.createElement('a'), { href, textContent: text });
    a.setAttribute('download', '');
    a.dataset.type = type;
    li.append(a);
    list.append(li);
  };
  // Each GeoTIFF with its QGIS style, both under the run's names (QGIS applies NAME.qml to NAME.tif beside it).
  for (const l of [...(info?.layers || []), ...(info?.differences || [])]) {
    link(l.download, `${l.name}.tif`, 'image/tiff');
    link(l.style, `${l.name}.qml`, 'application/xml');
  }
  if (info) {
    link(`${API}/jobs/${job.id}/vectors/hazard.gpkg`, 'hazard.gpkg', 'application/geopackage+sqlite3');
    link(info.image, 'max_depth.png', 'image/png');
  }
  for (const s of series) link(`${API}/jobs/${job.id}/series/${encodeURIComponent(s)}.csv`, `${s}.csv`, 'text/csv');
  box.append(summary, list);
  return box;
}

// Appends a figure for job `job` ({id, label, colour}); resolves once the map's first raster has loaded.
// `shared`: the ids of the jobs whose maps share one colour scale (map.json?shared=); empty: its own.
export async function drawMap(container, job, shared = []) {
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

  const series = (await get(`/jobs/${job.id}/metrics`).catch(() => ({ series: [] }))).series || [];
  let info = null;
  try {
    info = await get(`/jobs/${job.id}/map.json${shared.length ? `?shared=${shared.join(',')}` : ''}`);
  } catch (e) {
    const p = document.createElement('p');
    p.className = 'muted small';
    p.textContent = e.status === 404 ? 'no map: not a terrain scene' : `map unavailable: ${e.message}`;
    figure.append(p, downloads(job, null, series));
    return;
  }
  const r = info.raster;
  // The map, and beside it (below on a phone) the layer list and the legend, so that neither hides the map.
  const body = document.createElement('div');
  body.className = 'map-body';
  const holder = document.createElement('div');
  holder.className = 'map-frame';
  const side = document.createElement('div');
  side.className = 'map-side';
  const legendBox = document.createElement('div');
  legendBox.className = 'legend-box';
  body.append(holder, side);
  figure.append(body);
  const bounds = L.latLngBounds([r.south, r.west], [r.north, r.east]);
  // The view holds the rasters and every shape (protected zones may lie beyond the rasters); the frame's height
  // follows that view's shape, within limits, so a long narrow reach does not sit in a tall empty box.
  const view = L.latLngBounds(bounds.getSouthWest(), bounds.getNorthEast());
  const shapes = [...info.structures, ...info.protected_zones, ...info.sections, ...(info.release ? [info.release] : [])];
  for (const f of shapes)
    for (const p of latLngs(f.geometry.type === 'Polygon' ? f.geometry.coordinates[0] : f.geometry.coordinates)) view.extend(p);
  const aspect = (view.getNorth() - view.getSouth()) / (view.getEast() - view.getWest());
  const least = window.matchMedia('(max-width: 640px)').matches ? 200 : 320; // a phone's screen is short
  holder.style.height = `${Math.round(Math.min(480, Math.max(least, holder.clientWidth * aspect + 40)))}px`;
  const map = L.map(holder, { crs: crsFor(r), attributionControl: false, zoomSnap: 0.25, zoomDelta: 0.5 });
  // Fit the view, and fit it again when the frame changes size (a phone turned, a window resized): zoom limits
  // from one step out to six in.
  const fit = () => {
    map.setMinZoom(-Infinity).setMaxZoom(Infinity);
    map.fitBounds(view, { padding: [12, 12], animate: false });
    map.setMinZoom(map.getZoom() - 1).setMaxZoom(map.getZoom() + 6);
  };
  fit();
  map.on('resize', fit);
  map.setMaxBounds(view.pad(0.5));
  figure.__map = map; // for the browser test

  if (info.hillshade) L.imageOverlay(info.hillshade, bounds, { className: 'hillshade', alt: 'hillshade' }).addTo(map);
  const rasters = {};
  const byTitle = new Map();
  for (const l of info.layers) {
    const overlay = L.imageOverlay(l.image, bounds, { className: 'raster', opacity: 0.85, alt: l.title });
    overlay.runoutLayer = l;
    rasters[l.title] = overlay;
    byTitle.set(l.title, l);
  }
  const groups = {
    structures: L.layerGroup(info.structures.flatMap((s) => feature(s, 'structure', `${s.type.replace(/_/g, ' ')} ${s.name}`))),
    'protected zones': L.layerGroup(info.protected_zones.flatMap((z) => feature(z, 'zone', `protected zone ${z.name}`))),
    'cross-sections': L.layerGroup(info.sections.flatMap((s) => feature(s, 'section', `cross-section ${s.name} (series ${s.series})`))),
    release: L.layerGroup(info.release ? feature({ name: 'release', ...info.release }, 'release', 'release area') : []),
  };
  for (const g of Object.values(groups)) g.addTo(map);
  // Each path names what it draws (for people: the popup; for the test: data attributes).
  for (const [name, g] of Object.entries(groups))
    g.eachLayer((l) => {
      if (!l.feature) return; // a label
      const el = l.getElement();
      el.dataset.kind = l.feature.kind;
      el.dataset.name = l.feature.name;
      el.dataset.group = name;
    });
  const control = L.control.layers(rasters, groups, { collapsed: false }).addTo(map);
  side.append(control.getContainer(), legendBox); // its listeners stay on its elements
  L.control.scale({ imperial: false, position: 'bottomleft' }).addTo(map);
  const showLegend = (l) => legendBox.replaceChildren(legendOf(l));
  map.on('baselayerchange', (e) => showLegend(byTitle.get(e.name)));
  map.on('zoomend', () => (figure.dataset.zoom = String(map.getZoom())));
  figure.dataset.zoom = String(map.getZoom());

  const first = info.layers[0];
  const note = document.createElement('p');
  note.className = 'muted small';
  note.textContent = `${info.crs || 'working CRS'}; ${(r.east - r.west).toFixed(2)} × ${(r.north - r.south).toFixed(2)} m, cells ${r.dx} m. Pick a raster in the layer list; click a shape for its name.`;
  figure.append(note, downloads(job, info, series));
  if (!first) return;
  const overlay = rasters[first.title];
  const loaded = new Promise((resolve) => {
    overlay.once('load', resolve);
    overlay.once('error', resolve);
  });
  overlay.addTo(map);
  showLegend(first);
  await loaded;
}
