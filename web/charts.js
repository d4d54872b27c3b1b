// Charts over the vendored Chart.js (web/vendor/chart.umd.min.js, copied from
// npm by scripts/setup.sh; loaded by index.html as the global `Chart`).
//
// Every chart is a <figure data-chart="ID"> holding the canvas and, beside it,
// a table of the very numbers drawn (data-value carries the raw number), for
// screen readers and for anyone who wants the figures rather than the
// picture. Chart.getChart(canvas) gives the chart object itself.
import { h } from './dom.js';
import { labelColor, seriesColor } from './palette.js';

const { Chart } = window;

Chart.defaults.animation = false;  // redraws are instant, and screenshots show the final state
Chart.defaults.font.family = getComputedStyle(document.documentElement).getPropertyValue('--font').trim() || 'system-ui';
Chart.defaults.color = '#333';
Chart.defaults.maintainAspectRatio = false;  // the .chart-box sets the height

// IQR whiskers: a bar dataset may carry `whiskers: [[q1, q3] | null, ...]`
// beside its data; each pair is drawn as an error bar over its bar, in the
// value axis's units (the API's q1 and q3, as given).
const whiskerPlugin = {
  id: 'tallyWhiskers',
  afterDatasetsDraw(chart) {
    const { ctx } = chart;
    const horizontal = chart.options.indexAxis === 'y';
    chart.data.datasets.forEach((d, di) => {
      const meta = chart.getDatasetMeta(di);
      if (!d.whiskers || meta.hidden) return;
      const scale = chart.scales[horizontal ? meta.xAxisID : meta.yAxisID];
      ctx.save();
      ctx.strokeStyle = '#111';
      ctx.lineWidth = 1.5;
      meta.data.forEach((bar, i) => {
        const w = d.whiskers[i];
        if (!w) return;
        const a = scale.getPixelForValue(w[0]), b = scale.getPixelForValue(w[1]);
        const cap = Math.min(6, (horizontal ? bar.height : bar.width) / 4 || 6);
        ctx.beginPath();
        if (horizontal) {
          ctx.moveTo(a, bar.y); ctx.lineTo(b, bar.y);
          ctx.moveTo(a, bar.y - cap); ctx.lineTo(a, bar.y + cap);
          ctx.moveTo(b, bar.y - cap); ctx.lineTo(b, bar.y + cap);
        } else {
          ctx.moveTo(bar.x, a); ctx.lineTo(bar.x, b);
          ctx.moveTo(bar.x - cap, a); ctx.lineTo(bar.x + cap, a);
          ctx.moveTo(bar.x - cap, b); ctx.lineTo(bar.x + cap, b);
        }
        ctx.stroke();
      });
      ctx.restore();
    });
  },
};
Chart.register(whiskerPlugin);

// Threshold lines: a dataset flagged `threshold: true` (two points at its
// value, for the legend and the data table) is drawn as a dashed horizontal
// line across the whole plot area, however narrow the x range of its points.
const thresholdPlugin = {
  id: 'tallyThreshold',
  afterDatasetsDraw(chart) {
    const { ctx, chartArea } = chart;
    chart.data.datasets.forEach((d, di) => {
      const meta = chart.getDatasetMeta(di);
      if (!d.threshold || meta.hidden || !d.data.length) return;
      const y = chart.scales[meta.yAxisID].getPixelForValue(d.data[0].y);
      if (!(y >= chartArea.top && y <= chartArea.bottom)) return;
      ctx.save();
      ctx.strokeStyle = d.borderColor;
      ctx.lineWidth = 2;
      ctx.setLineDash(d.borderDash || [6, 4]);
      ctx.beginPath();
      ctx.moveTo(chartArea.left, y);
      ctx.lineTo(chartArea.right, y);
      ctx.stroke();
      ctx.restore();
    });
  },
};
Chart.register(thresholdPlugin);

// Crossings: an xy chart's `options.plugins.tallyCrossings.marks`, each
// {x, low, high, label}, is drawn as a shaded band from low to high (the
// interval, clipped to the plot) and a solid vertical line at x with its
// label at the top: where two fitted lines cross (web/views/compare.js).
const crossingPlugin = {
  id: 'tallyCrossings',
  afterDatasetsDraw(chart, _args, options) {
    const marks = options?.marks || [];
    const { ctx, chartArea } = chart;
    const scale = chart.scales.x;
    if (!scale || !marks.length) return;
    const clip = (px) => Math.min(chartArea.right, Math.max(chartArea.left, px));
    const placed = [];  // label boxes: a label that would overlap one goes a line lower
    ctx.save();
    for (const m of marks) {
      const x = scale.getPixelForValue(m.x);
      if (m.low !== null && m.low !== undefined && m.high !== null && m.high !== undefined) {
        const a = clip(scale.getPixelForValue(m.low)), b = clip(scale.getPixelForValue(m.high));
        ctx.fillStyle = 'rgba(120, 120, 120, 0.15)';
        ctx.fillRect(Math.min(a, b), chartArea.top, Math.abs(b - a), chartArea.bottom - chartArea.top);
      }
      if (!(x >= chartArea.left && x <= chartArea.right)) continue;
      ctx.strokeStyle = '#222';
      ctx.lineWidth = 1.5;
      ctx.setLineDash([]);
      ctx.beginPath();
      ctx.moveTo(x, chartArea.top);
      ctx.lineTo(x, chartArea.bottom);
      ctx.stroke();
      if (m.label) {
        ctx.fillStyle = '#222';
        ctx.font = `12px ${Chart.defaults.font.family}`;
        const width = ctx.measureText(m.label).width;
        const left = x + 4 + width > chartArea.right ? x - 4 - width : x + 4;
        let top = chartArea.top + 2;
        const hits = (t) => placed.some((b) => left < b.x + b.w + 3 && b.x < left + width + 3 && t < b.y + b.h && b.y < t + 14);
        while (hits(top) && top + 28 < chartArea.bottom) top += 14;
        placed.push({ x: left, y: top, w: width, h: 14, text: m.label });
        ctx.fillText(m.label, left, top + 10);
      }
    }
    chart.tallyCrossingLabels = placed;
    ctx.restore();
  },
};
Chart.register(crossingPlugin);

// Point labels: an xy dataset flagged `pointLabels: true` has each point's
// `label` written beside it, on the first side (right, left, above, below)
// where it overlaps no label already placed and stays inside the plot; a
// label that fits nowhere is left out (the chart's table lists every point).
// The boxes placed are kept on the chart as `tallyLabelBoxes`, for tests.
const pointLabelPlugin = {
  id: 'tallyPointLabels',
  afterDatasetsDraw(chart) {
    const { ctx, chartArea } = chart;
    const placed = [];
    ctx.save();
    ctx.font = `11px ${Chart.defaults.font.family}`;
    ctx.textBaseline = 'middle';
    chart.data.datasets.forEach((d, di) => {
      const meta = chart.getDatasetMeta(di);
      if (!d.pointLabels || meta.hidden) return;
      meta.data.forEach((point, i) => {
        const text = d.data[i]?.label;
        if (!text) return;
        const w = ctx.measureText(text).width, hgt = 13, gap = 7;
        const tries = [[point.x + gap, point.y - hgt / 2], [point.x - gap - w, point.y - hgt / 2],
          [point.x - w / 2, point.y - gap - hgt], [point.x - w / 2, point.y + gap]];
        const fits = ([x, y]) => x >= chartArea.left && x + w <= chartArea.right && y >= chartArea.top && y + hgt <= chartArea.bottom
          && placed.every((b) => x + w <= b.x || b.x + b.w <= x || y + hgt <= b.y || b.y + b.h <= y);
        const at = tries.find(fits);
        if (!at) return;
        placed.push({ x: at[0], y: at[1], w, h: hgt, text });
        ctx.fillStyle = d.data[i].flag ? '#a61b1b' : '#222';
        ctx.fillText(text, at[0], at[1] + hgt / 2);
      });
    });
    chart.tallyLabelBoxes = placed;
    ctx.restore();
  },
};
Chart.register(pointLabelPlugin);

// The i-th colour of the palette's series (web/palette.js), for things that
// have no label of their own.
export const color = seriesColor;

// A dataset's colour follows its label (or its colorKey: a renderer's variant
// where the label adds a run id), so that a renderer has one colour in every
// chart, whatever the order in which runs were picked.
const colorOf = (d) => labelColor(d.colorKey ?? d.label);

// A figure with an empty canvas and a data table; draw with drawChart once it
// is in the document (Chart.js measures its parent).
function figure(id, title, caption, dataTable) {
  return h('figure', { class: 'chart', dataset: { chart: id } },
    h('figcaption', {}, h('strong', {}, title), caption ? h('span', { class: 'caption' }, ' ', caption) : null),
    h('div', { class: 'chart-box' }, h('canvas', { role: 'img', 'aria-label': title })),
    h('details', { class: 'chart-data' }, h('summary', {}, 'Data'), dataTable));
}

// A table with one row per label and one column per dataset.
function seriesTable(id, labels, datasets, format, labelHeader) {
  return h('div', { class: 'table-wrap' },
    h('table', { dataset: { chartTable: id } },
      h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, labelHeader), datasets.map((d) => h('th', { scope: 'col' }, d.label)))),
      h('tbody', {}, labels.map((label, i) => h('tr', {},
        h('th', { scope: 'row' }, String(label)),
        datasets.map((d) => {
          const v = d.data[i];
          const w = d.whiskers ? d.whiskers[i] : null;
          const text = v === null || v === undefined ? '–' : format(v) + (w ? ` (IQR ${format(w[0])}–${format(w[1])})` : '');
          return h('td', { class: 'num', dataset: { value: v === null || v === undefined ? '' : String(v),
            ...(w ? { q1: String(w[0]), q3: String(w[1]) } : {}) } }, text);
        }))))));
}

// A "log scale" switch for a chart's value axis: one buffer (the lights, say)
// can be a hundred times the rest, which a linear axis flattens to nothing.
function logSwitch(fig, getChart, axis, format) {
  const box = h('input', { type: 'checkbox', name: 'log' });
  const decade = (v) => Math.abs(Math.log10(v) - Math.round(Math.log10(v))) < 1e-9;
  box.addEventListener('change', () => {
    const scale = getChart().options.scales[axis];
    scale.type = box.checked ? 'logarithmic' : 'linear';
    // A log axis ticks 1-9 per decade: label the decades only.
    scale.ticks.callback = box.checked ? (v) => (decade(v) ? format(v) : '') : (v) => format(v);
    getChart().update();
  });
  fig.querySelector('figcaption').append(' ', h('label', { class: 'log-switch' }, box, ' log scale'));
}

// Bar chart. spec: {id, title, caption, labels, datasets: [{label, data, ...Chart.js dataset options}],
// format (value -> text), stacked, horizontal, logSwitch, labelHeader, axes (extra Chart.js scales), yTitle}.
// Appends the figure to parent and returns the Chart. A click on a legend
// entry hides that series and rescales (Chart.js's own behaviour).
export function barChart(parent, spec) {
  const { id, title, caption, labels, datasets, format, stacked = false, horizontal = false } = spec;
  const fig = figure(id, title, caption, seriesTable(id, labels, datasets, format, spec.labelHeader || ''));
  parent.append(fig);
  let chart = null;
  if (spec.logSwitch) logSwitch(fig, () => chart, horizontal ? 'x' : 'y', format);
  const valueAxis = horizontal ? 'x' : 'y';
  const categoryAxis = horizontal ? 'y' : 'x';
  const scales = {
    [categoryAxis]: { stacked },
    [valueAxis]: {
      stacked,
      beginAtZero: true,
      ticks: { callback: (v) => format(v) },
      title: spec.yTitle ? { display: true, text: spec.yTitle } : undefined,
    },
    ...(spec.axes || {}),
  };
  chart = new Chart(fig.querySelector('canvas'), {
    type: 'bar',
    data: {
      labels,
      datasets: datasets.map((d) => ({ backgroundColor: colorOf(d), ...d })),
    },
    options: {
      indexAxis: categoryAxis,
      scales,
      plugins: {
        legend: { display: datasets.length > 1, position: 'bottom', labels: { boxWidth: 12 } },
        tooltip: { callbacks: { label: (c) => `${c.dataset.label}: ${format(c.raw)}` } },
      },
    },
  });
  return chart;
}

// Scatter/line chart over numeric x. spec: {id, title, caption, datasets:
// [{label, data: [{x, y, ...}], showLine, ...}], x: {title, format, type,
// reverse}, y: {title, format, type}, table (a node: the data table to show),
// tooltip (context -> text), marks (vertical crossing marks: [{x, low, high, label}])}.
export function xyChart(parent, spec) {
  const fig = figure(spec.id, spec.title, spec.caption, spec.table);
  parent.append(fig);
  const axis = (a) => ({
    type: a.type || 'linear',
    reverse: Boolean(a.reverse),
    min: a.min,
    max: a.max,
    title: { display: true, text: a.title },
    ticks: { callback: (v) => a.format(v) },
  });
  return new Chart(fig.querySelector('canvas'), {
    type: 'scatter',
    data: {
      datasets: spec.datasets.map((d) => ({ backgroundColor: colorOf(d), borderColor: colorOf(d), pointRadius: 4, ...d })),
    },
    options: {
      scales: { x: axis(spec.x), y: axis(spec.y) },
      plugins: {
        // A dataset with `legend: false` (a line joining two points, a band's edge) has no entry.
        legend: { position: 'bottom', labels: { boxWidth: 12, filter: (item, data) => data.datasets[item.datasetIndex].legend !== false } },
        tooltip: { callbacks: { label: spec.tooltip || ((c) => `${c.dataset.label}: ${spec.x.format(c.raw.x)}, ${spec.y.format(c.raw.y)}`) } },
        tallyCrossings: { marks: spec.marks || [] },
      },
    },
  });
}

// Destroys the charts under root (a view being left), freeing their listeners.
export function destroyCharts(root) {
  for (const canvas of root.querySelectorAll('canvas')) Chart.getChart(canvas)?.destroy();
}
