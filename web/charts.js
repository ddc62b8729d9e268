// Line charts of the runs' series with uPlot (web/package.json; the build copies it to /web/vendor).
import uPlot from '/web/vendor/uPlot.esm.js';

// One colour per compared job, the baseline first (dark grey); the same job has the same colour everywhere.
const PALETTE = ['#333333', '#1f6fd1', '#d1501f', '#2a9d4b', '#8a3fc1', '#c19a1f', '#1fa6b8', '#c11f6f'];
export const colourOf = (k) => PALETTE[k % PALETTE.length];

const live = new Set(); // charts on the page, resized with their container

const resizer = new ResizeObserver((entries) => {
  for (const e of entries) {
    const u = e.target.__uplot;
    if (u) u.setSize({ width: Math.max(200, Math.floor(e.contentRect.width)), height: u.height });
  }
});

export function clearCharts(container) {
  for (const u of live) {
    if (container.contains(u.root)) {
      resizer.unobserve(u.root.parentElement);
      u.destroy();
      live.delete(u);
    }
  }
  container.replaceChildren();
}

// lines: [{label, colour, x: number[], y: (number|null)[]}], each on its own time base: uPlot.join merges
// them onto the union of the times (null where a line has no sample), and spanGaps draws across.
export function lineChart(container, { title, xLabel, yLabel, lines, id }) {
  const figure = document.createElement('figure');
  figure.className = 'chart';
  if (id) figure.dataset.chart = id;
  const caption = document.createElement('figcaption');
  caption.textContent = title;
  const holder = document.createElement('div');
  figure.append(caption, holder);
  container.append(figure);
  if (lines.length === 0 || lines.every((l) => l.x.length === 0)) {
    holder.className = 'muted small';
    holder.textContent = 'no samples';
    return null;
  }
  const data = uPlot.join(lines.map((l) => [l.x, l.y]));
  const width = Math.max(200, Math.floor(holder.getBoundingClientRect().width || container.clientWidth || 320));
  const opts = {
    width,
    height: 220,
    legend: { live: true },
    cursor: { drag: { x: true, y: false } },
    scales: { x: { time: false } },
    axes: [
      { label: xLabel, size: 36, labelSize: 18 },
      { label: yLabel, size: 64, labelSize: 18, values: (u, vals) => vals.map(shortNumber) },
    ],
    series: [
      { label: xLabel, value: (u, v) => (v == null ? '–' : shortNumber(v)) },
      ...lines.map((l) => ({
        label: l.label,
        stroke: l.colour,
        width: 1.6,
        spanGaps: true,
        points: { show: false },
        value: (u, v) => (v == null ? '–' : shortNumber(v)),
      })),
    ],
  };
  const u = new uPlot(opts, data, holder);
  holder.__uplot = u;
  live.add(u);
  resizer.observe(holder);
  return u;
}

// Numbers for people: 4 significant digits, no exponent for ordinary magnitudes.
export function shortNumber(v) {
  if (v == null || !Number.isFinite(v)) return '–';
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e6)) return v.toExponential(2);
  return String(Number(v.toPrecision(4)));
}
