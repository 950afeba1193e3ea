/* roadsurvey survey report: inline SVG charts: axes, bars, time series and legends, and the
 * damage counts, depth histogram, georeference residuals and trajectory error drawn with them.
 */
(function () {
  'use strict';

  const R = (window.RoadsurveyReport = window.RoadsurveyReport || {});
  const { SEVERITIES, SEVERITY_COLOURS, TYPE_ORDER, TYPE_COLOURS, state, isNum, isText, el, svgEl, clear,
    byId, mm, count, props, severityOf } = R;

  const AXIS_COLOURS = { e: '#1f77b4', n: '#2ca02c', u: '#9467bd' };

  // ---------------------------------------------------------------------------------------------
  // Charts (inline SVG)

  const CHART = { w: 480, h: 260, left: 56, right: 16, top: 30, bottom: 46 };

  /** Round tick values covering [lo, hi], about n of them. */
  function niceTicks(lo, hi, n) {
    if (!(hi > lo)) {
      const pad = Math.abs(lo) > 0 ? Math.abs(lo) * 0.5 : 1;
      lo -= pad;
      hi += pad;
    }
    const raw = (hi - lo) / Math.max(1, n);
    const p = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 2.5, 5, 10].map((m) => m * p).find((s) => s >= raw) || 10 * p;
    const ticks = [];
    for (let v = Math.floor(lo / step) * step; v <= hi + step * 1e-9; v += step) ticks.push(+v.toPrecision(12));
    if (ticks[ticks.length - 1] < hi) ticks.push(+(ticks[ticks.length - 1] + step).toPrecision(12));
    return ticks;
  }

  function tickLabel(v) {
    return String(+v.toPrecision(6));
  }

  /** An empty chart frame with a caption; returns the SVG and the plot area's geometry. */
  function chartFrame(figure, title, desc) {
    clear(figure);
    figure.appendChild(el('figcaption', { text: title }));
    const svg = svgEl('svg', { viewBox: `0 0 ${CHART.w} ${CHART.h}`, role: 'img', 'aria-label': desc || title,
      preserveAspectRatio: 'xMidYMid meet' });
    figure.appendChild(svg);
    const area = { x0: CHART.left, x1: CHART.w - CHART.right, y0: CHART.top, y1: CHART.h - CHART.bottom };
    return { svg, area };
  }

  function chartMessage(figure, title, message) {
    clear(figure);
    figure.appendChild(el('figcaption', { text: title }));
    figure.appendChild(el('p', { class: 'note chart-empty', text: message }));
  }

  function scale(d0, d1, r0, r1) {
    return (v) => r0 + ((v - d0) / (d1 - d0 || 1)) * (r1 - r0);
  }

  /** Y axis with grid lines and a rotated label. */
  function yAxis(svg, area, ticks, y, label) {
    for (const t of ticks) {
      svg.appendChild(svgEl('line', { x1: area.x0, x2: area.x1, y1: y(t), y2: y(t), class: 'grid' }));
      svg.appendChild(svgEl('text', { x: area.x0 - 6, y: y(t) + 4, class: 'tick', 'text-anchor': 'end', text: tickLabel(t) }));
    }
    const cy = (area.y0 + area.y1) / 2;
    svg.appendChild(svgEl('text', { x: 14, y: cy, class: 'axis-label', 'text-anchor': 'middle',
      transform: `rotate(-90 14 ${cy})`, text: label }));
    svg.appendChild(svgEl('line', { x1: area.x0, x2: area.x0, y1: area.y0, y2: area.y1, class: 'axis' }));
  }

  function xAxisLabel(svg, area, label) {
    svg.appendChild(svgEl('line', { x1: area.x0, x2: area.x1, y1: area.y1, y2: area.y1, class: 'axis' }));
    svg.appendChild(svgEl('text', { x: (area.x0 + area.x1) / 2, y: CHART.h - 8, class: 'axis-label',
      'text-anchor': 'middle', text: label }));
  }

  /** Vertical bars: items [{label, value, colour}]. */
  function barChart(figure, title, items, xLabel, yLabel) {
    const { svg, area } = chartFrame(figure, title, `${title}: ${items.map((i) => `${i.label} ${i.value}`).join(', ')}`);
    const max = Math.max(1, ...items.map((i) => i.value));
    const ticks = niceTicks(0, max, 4).filter((t) => Number.isInteger(t));
    const y = scale(0, ticks[ticks.length - 1], area.y1, area.y0);
    yAxis(svg, area, ticks, y, yLabel);
    const slot = (area.x1 - area.x0) / Math.max(1, items.length);
    items.forEach((it, i) => {
      const x = area.x0 + i * slot + slot * 0.15;
      const w = slot * 0.7;
      svg.appendChild(svgEl('rect', { x, y: y(it.value), width: w, height: Math.max(0, area.y1 - y(it.value)),
        fill: it.colour, class: 'bar' }, svgEl('title', { text: `${it.label}: ${it.value}` })));
      svg.appendChild(svgEl('text', { x: x + w / 2, y: y(it.value) - 4, class: 'bar-value', 'text-anchor': 'middle',
        text: String(it.value) }));
      svg.appendChild(svgEl('text', { x: x + w / 2, y: area.y1 + 14, class: 'tick', 'text-anchor': 'middle',
        text: it.label }));
    });
    xAxisLabel(svg, area, xLabel);
  }

  function countsOf(key, order, counts) {
    const found = {};
    for (const d of state.damages) {
      const k = key === 'severity' ? severityOf(d) : d.type;
      found[k] = (found[k] || 0) + 1;
    }
    const source = counts && Object.keys(counts).length ? counts : found;
    const keys = order.concat(Object.keys(source).filter((k) => !order.includes(k)));
    return keys.map((k) => ({ key: k, value: isNum(source[k]) ? source[k] : 0 }));
  }

  function renderCountCharts(report) {
    if (!state.damages.length) {
      chartMessage(byId('chart-type'), 'Damages by type', 'No damage was found.');
      chartMessage(byId('chart-severity'), 'Damages by severity', 'No damage was found.');
      return;
    }
    const counts = report.counts || {};
    const types = countsOf('type', TYPE_ORDER, counts.by_type);
    barChart(byId('chart-type'), 'Damages by type',
      types.map((t) => ({ label: t.key, value: t.value, colour: TYPE_COLOURS[t.key] || '#666' })), 'type', 'damages');
    const sev = countsOf('severity', SEVERITIES, counts.by_severity);
    barChart(byId('chart-severity'), 'Damages by severity',
      sev.map((s) => ({ label: s.key, value: s.value, colour: SEVERITY_COLOURS[s.key] || '#666' })), 'severity', 'damages');
  }

  /** Histogram of the max depth of potholes and other depressions, in millimetre bins. */
  function renderDepthHistogram() {
    const fig = byId('chart-depth');
    const title = 'Max depth of depressions (potholes and other)';
    const depths = state.damages.filter((d) => d.type !== 'crack').map((d) => props(d).max_depth_m)
      .filter(isNum).map((v) => v * 1000);
    if (!depths.length) {
      chartMessage(fig, title, 'No depression with a measured depth.');
      return;
    }
    const max = Math.max(...depths);
    const width = [1, 2, 5, 10, 20, 25, 50, 100, 200, 500].find((w) => max / w <= 10) || 1000;
    const n = Math.max(1, Math.floor(max / width) + 1);
    const bins = new Array(n).fill(0);
    for (const v of depths) bins[Math.min(n - 1, Math.max(0, Math.floor(v / width)))] += 1;
    barChart(fig, title, bins.map((c, i) => ({ label: `${i * width}–${(i + 1) * width}`, value: c, colour: '#5e3c99' })),
      'max depth (mm)', 'depressions');
  }

  /** Points over time: series [{name, colour, points: [{x, y, outlier}]}], optional ±band. */
  function timeChart(figure, title, series, opts) {
    const pts = [].concat(...series.map((s) => s.points));
    const { svg, area } = chartFrame(figure, title);
    const xs = pts.map((p) => p.x);
    const ys = pts.map((p) => p.y).concat(opts.band ? [opts.band, -opts.band] : []);
    const xt = niceTicks(Math.min(...xs), Math.max(...xs), 6);
    const yt = niceTicks(Math.min(0, ...ys), Math.max(0, ...ys), 5);
    const x = scale(xt[0], xt[xt.length - 1], area.x0, area.x1);
    const y = scale(yt[0], yt[yt.length - 1], area.y1, area.y0);
    yAxis(svg, area, yt, y, opts.yLabel);
    for (const t of xt) {
      svg.appendChild(svgEl('text', { x: x(t), y: area.y1 + 14, class: 'tick', 'text-anchor': 'middle', text: tickLabel(t) }));
    }
    xAxisLabel(svg, area, opts.xLabel);
    if (opts.band) {
      svg.appendChild(svgEl('rect', { x: area.x0, width: area.x1 - area.x0, y: y(opts.band),
        height: Math.max(0, y(-opts.band) - y(opts.band)), class: 'band' }));
      for (const b of [opts.band, -opts.band]) {
        svg.appendChild(svgEl('line', { x1: area.x0, x2: area.x1, y1: y(b), y2: y(b), class: 'band-edge' }));
      }
    }
    for (const s of series) drawSeries(svg, s, x, y, opts.lines);
    legend(svg, area, series.map((s) => ({ name: s.name, colour: s.colour }))
      .concat(pts.some((p) => p.outlier) ? [{ name: 'outlier', colour: '#d7191c', cross: true }] : [])
      .concat(opts.band ? [{ name: opts.bandLabel, colour: '#bbb', band: true }] : []));
  }

  function drawSeries(svg, s, x, y, lines) {
    const inl = s.points.filter((p) => !p.outlier);
    if (lines && inl.length > 1) {
      svg.appendChild(svgEl('polyline', { points: inl.map((p) => `${x(p.x).toFixed(1)},${y(p.y).toFixed(1)}`).join(' '),
        fill: 'none', stroke: s.colour, 'stroke-width': 1.5 }));
    } else {
      for (const p of inl) svg.appendChild(svgEl('circle', { cx: x(p.x), cy: y(p.y), r: 2.2, fill: s.colour }));
    }
    for (const p of s.points.filter((q) => q.outlier)) {
      const cx = x(p.x);
      const cy = y(p.y);
      svg.appendChild(svgEl('path', { d: `M${cx - 4},${cy - 4}L${cx + 4},${cy + 4}M${cx - 4},${cy + 4}L${cx + 4},${cy - 4}`,
        class: 'outlier' }, svgEl('title', { text: `${s.name} outlier at ${tickLabel(p.x)} s: ${tickLabel(p.y)}` })));
    }
  }

  function legend(svg, area, items) {
    let x = area.x0 + 6;
    for (const it of items) {
      const y = area.y0 - 16;
      if (it.cross) svg.appendChild(svgEl('path', { d: `M${x - 3},${y - 3}L${x + 3},${y + 3}M${x - 3},${y + 3}L${x + 3},${y - 3}`, class: 'outlier' }));
      else if (it.band) svg.appendChild(svgEl('rect', { x: x - 4, y: y - 4, width: 8, height: 8, class: 'band' }));
      else svg.appendChild(svgEl('circle', { cx: x, cy: y, r: 3.5, fill: it.colour }));
      const label = svgEl('text', { x: x + 7, y: y + 4, class: 'legend', text: it.name });
      svg.appendChild(label);
      x += 18 + it.name.length * 6.2;
    }
  }

  /** GNSS residuals per ENU axis over time, one panel each, with the robust ±3σ band. */
  function renderResiduals(report) {
    const fig = byId('chart-residuals');
    const title = 'Georeference residuals (GNSS fix minus fitted antenna position)';
    const r = report.residuals;
    const fixes = r && Array.isArray(r.fixes) ? r.fixes.filter((f) => isNum(f.t_s)) : [];
    if (!fixes.length) {
      chartMessage(fig, title, r ? 'No GNSS fix was used.' : 'No GNSS residuals: the survey was not georeferenced with GNSS fixes.');
      return;
    }
    clear(fig);
    fig.appendChild(el('figcaption', { text: title }));
    const sigma = r.sigma_m || {};
    const panels = el('div', { class: 'residual-panels' });
    for (const [axis, name, sKey] of [['e', 'east', 'east'], ['n', 'north', 'north'], ['u', 'up', 'up']]) {
      const panel = el('figure', { class: 'chart', id: `chart-residuals-${name}` });
      panels.appendChild(panel);
      const points = fixes.filter((f) => isNum(f[axis])).map((f) => ({ x: f.t_s, y: f[axis] * 1000, outlier: f.inlier === false }));
      if (!points.length) {
        chartMessage(panel, name, 'no data');
        continue;
      }
      const band = isNum(sigma[sKey]) ? 3 * sigma[sKey] * 1000 : null;
      timeChart(panel, `${name} residual`, [{ name, colour: AXIS_COLOURS[axis], points }],
        { xLabel: 'time (s)', yLabel: `${name} (mm)`, band, bandLabel: '±3σ robust', lines: false });
    }
    fig.appendChild(panels);
    if (isText(r.definition)) fig.appendChild(el('p', { class: 'note', text: r.definition }));
  }

  function renderTrajectoryError(report) {
    const fig = byId('chart-trajectory-error');
    const title = 'Trajectory error against the reference';
    const t = report.trajectory_error;
    const frames = t && Array.isArray(t.frames) ? t.frames.filter((f) => isNum(f.t_s)) : [];
    if (!frames.length) {
      chartMessage(fig, title, 'No reference trajectory: the trajectory error was not evaluated.');
      return;
    }
    const series = [['horizontal_m', 'horizontal', '#1f77b4'], ['vertical_m', 'vertical', '#ff7f0e']].map(([k, name, colour]) => ({
      name, colour, points: frames.filter((f) => isNum(f[k])).map((f) => ({ x: f.t_s, y: f[k] * 1000 })),
    })).filter((s) => s.points.length);
    timeChart(fig, title, series, { xLabel: 'time (s)', yLabel: 'error (mm)', lines: true });
    const rmse = t.rmse_m || {};
    const max = t.max_m || {};
    if (isNum(rmse.horizontal) || isNum(max.horizontal)) {
      fig.appendChild(el('p', { class: 'chart-summary', text: `RMSE ${mm(rmse.horizontal)} mm horizontal, ` +
        `${mm(rmse.vertical)} mm vertical; max ${mm(max.horizontal)} mm, ${mm(max.vertical)} mm` +
        (isNum(t.cameras) ? ` over ${count(t.cameras, 'camera')}` : '') }));
    }
    if (isText(t.definition)) fig.appendChild(el('p', { class: 'note', text: t.definition }));
  }

  Object.assign(R, { renderCountCharts, renderDepthHistogram, renderResiduals, renderTrajectoryError });
})();
