/* roadsurvey survey report.
 *
 * Draws window.ROADSURVEY_REPORT (data/report.js) and window.ROADSURVEY_RUN (data/run.js) into
 * index.html: summary, map, damage table with detail panel, charts and file links. Plain ES2017
 * and Leaflet, no build step and no network, so the folder opens from file:// anywhere.
 * Data text is only ever inserted as text (never as HTML): rule texts and warnings come from logs.
 */
(function () {
  'use strict';

  const DASH = '\u2014';
  const SVG_NS = 'http://www.w3.org/2000/svg';
  const SEVERITIES = ['high', 'medium', 'low', 'none'];
  const SEVERITY_RANK = { none: 0, low: 1, medium: 2, high: 3 };
  const SEVERITY_COLOURS = { high: '#d7191c', medium: '#ff8000', low: '#ffcc00', none: '#808080' };
  const TYPE_ORDER = ['pothole', 'crack', 'other'];
  const TYPE_COLOURS = { pothole: '#5e3c99', crack: '#1b7837', other: '#2b83ba' };
  const AXIS_COLOURS = { e: '#1f77b4', n: '#2ca02c', u: '#9467bd' };
  const SELECTED_STROKE = '#1e90ff';
  // Zooming onto a damage keeps road around it (at least this much, else its own size), so the
  // reader sees where it lies.
  const ZOOM_MARGIN_M = 0.6;
  const MAX_ZOOM = 9;

  const state = {
    report: null,
    run: null,
    damages: [],
    byId: new Map(),
    rows: new Map(),
    layers: new Map(),
    map: null,
    damageGroup: null,
    fitExtent: null,
    sortKey: 'id',
    sortDir: 'asc',
    filterType: '',
    filterSeverity: '',
    query: '',
    selectedId: null,
  };

  // ---------------------------------------------------------------------------------------------
  // DOM and value utilities

  function isNum(v) {
    return typeof v === 'number' && isFinite(v);
  }

  function isText(v) {
    return typeof v === 'string' && v.length > 0;
  }

  /** An HTML element; attrs.text sets textContent, attrs.class the class, the rest attributes. */
  function el(tag, attrs, children) {
    return build(document.createElement(tag), attrs, children);
  }

  function svgEl(tag, attrs, children) {
    return build(document.createElementNS(SVG_NS, tag), attrs, children);
  }

  function build(node, attrs, children) {
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === null || v === undefined || v === false) continue;
      if (k === 'text') node.textContent = String(v);
      else if (k === 'class') node.setAttribute('class', v);
      else node.setAttribute(k, v === true ? '' : String(v));
    }
    for (const c of [].concat(children || [])) {
      if (c === null || c === undefined || c === false) continue;
      node.appendChild(typeof c === 'string' ? document.createTextNode(c) : c);
    }
    return node;
  }

  function clear(node) {
    while (node.firstChild) node.removeChild(node.firstChild);
    return node;
  }

  function byId(id) {
    return document.getElementById(id);
  }

  // ---------------------------------------------------------------------------------------------
  // Formatting: every missing value reads "—", never 0.

  function fixed(v, digits) {
    return isNum(v) ? v.toFixed(digits) : DASH;
  }

  // Quantities: the unit's scale from SI and the decimals used when no σ sets the precision.
  const MM = { scale: 1000, digits: (x) => (Math.abs(x) < 10 ? 1 : 0) };
  const M = { scale: 1, digits: (x) => (Math.abs(x) < 10 ? 2 : 1) };
  const M2 = { scale: 1, digits: (x) => (Math.abs(x) < 1 ? 3 : 2) };
  const LITRE = { scale: 1000, digits: (x) => (Math.abs(x) < 1 ? 3 : Math.abs(x) < 10 ? 2 : 1) };
  const M3 = { scale: 1, digits: () => 2 };

  /** Decimals that show a σ to one significant digit (two when it starts with 1). */
  function sigmaDigits(s) {
    if (!(s > 0)) return null;
    const e = Math.floor(Math.log10(s));
    const lead = Math.floor(s / Math.pow(10, e) + 1e-9);
    return Math.min(4, Math.max(0, -e + (lead === 1 ? 1 : 0)));
  }

  /** "value ± σ" in the quantity's unit, both to the precision the σ supports. */
  function measure(value, sigma, q) {
    if (!isNum(value)) return DASH;
    const v = value * q.scale;
    const s = isNum(sigma) ? sigma * q.scale : null;
    const sd = s === null ? null : sigmaDigits(s);
    const d = sd === null ? q.digits(v) : sd;
    return s === null ? v.toFixed(d) : `${v.toFixed(d)} ± ${s.toFixed(d)}`;
  }

  function mm(v) {
    return measure(v, null, MM);
  }

  /** Volume in litres below a cubic metre (a pothole's fill), cubic metres above. */
  function volume(value, sigma) {
    if (!isNum(value)) return DASH;
    const litres = Math.abs(value) < 1;
    return `${measure(value, sigma, litres ? LITRE : M3)} ${litres ? 'L' : 'm³'}`;
  }

  /** Offset across the surveyed line: positive is right of the direction of travel. */
  function offset(v) {
    if (!isNum(v)) return DASH;
    const a = Math.abs(v).toFixed(2);
    if (Number(a) === 0) return a;
    return `${a} ${v > 0 ? 'R' : 'L'}`;
  }

  function offsetWords(v) {
    if (!isNum(v)) return DASH;
    const a = Math.abs(v).toFixed(2);
    return Number(a) === 0 ? `${a} m, on the line` : `${a} m ${v > 0 ? 'right' : 'left'} of the line`;
  }

  function percent(v) {
    return isNum(v) ? `${Math.round(v * 100)} %` : DASH;
  }

  function yesNo(v) {
    return v === true ? 'yes' : v === false ? 'no' : DASH;
  }

  function seconds(s) {
    if (!isNum(s)) return DASH;
    if (s < 60) return `${s.toFixed(s < 10 ? 2 : 1)} s`;
    if (s < 3600) return `${Math.floor(s / 60)} min ${String(Math.round(s % 60)).padStart(2, '0')} s`;
    return `${Math.floor(s / 3600)} h ${String(Math.floor((s % 3600) / 60)).padStart(2, '0')} min`;
  }

  /** ISO-8601 UTC as written by the pipeline, shown without the browser's locale or time zone. */
  function utc(iso) {
    if (!isText(iso)) return DASH;
    return iso.replace('T', ' ').replace(/(\.\d+)?Z$/, ' UTC');
  }

  function text(v) {
    return isText(v) ? v : isNum(v) ? String(v) : DASH;
  }

  function count(n, singular, plural) {
    return `${n} ${n === 1 ? singular : plural || singular + 's'}`;
  }

  // ---------------------------------------------------------------------------------------------
  // Damage fields

  function props(d) {
    return d.properties || {};
  }

  /** The grade that sets the severity: FHWA LTPP for cracks, ASTM D6433 for depressions. */
  function governingRule(d) {
    const p = props(d);
    const astm = { standard: 'ASTM D6433', rule: p.astm_d6433_rule };
    const fhwa = { standard: 'FHWA LTPP', rule: p.fhwa_ltpp_rule };
    const [first, second] = d.type === 'crack' ? [fhwa, astm] : [astm, fhwa];
    if (isText(first.rule)) return first;
    if (isText(second.rule)) return second;
    return { standard: null, rule: null };
  }

  function severityOf(d) {
    return SEVERITY_COLOURS[d.severity] ? d.severity : 'none';
  }

  function severityBadge(d) {
    const sev = severityOf(d);
    const g = governingRule(d);
    return el('span', { class: `sev sev-${sev}`, text: sev, title: g.rule || 'no grading rule recorded' });
  }

  /** Text a search can match: what a reader may remember about a damage. */
  function searchText(d) {
    const p = props(d);
    return [d.id, d.type, d.severity, p.astm_d6433_rule, p.fhwa_ltpp_rule, p.intervention_rule, p.basis,
      p.observation_frames, p.best_frame].filter((v) => v !== null && v !== undefined).join(' ').toLowerCase();
  }

  // ---------------------------------------------------------------------------------------------
  // Header and summary

  function renderHeader(report, run) {
    const title = report.title || (report.survey && report.survey.name) || 'survey';
    document.title = `Road survey report: ${title}`;
    byId('report-title').textContent = `Road survey report: ${title}`;
    const parts = [];
    const date = report.survey && report.survey.date_utc;
    parts.push(isText(date) ? `Surveyed ${utc(date)}` : 'Survey date not in the flight log');
    if (run && isText(run.finished_utc)) parts.push(`processed ${utc(run.finished_utc)}`);
    byId('report-subtitle').textContent = parts.join(' · ');
    byId('report-footer').textContent = `roadsurvey · ${report.format || 'report'}` +
      (hasMap(report) ? ` · map coordinates in metres from ${originText(report)}` : '');
  }

  function hasMap(report) {
    return Boolean(report && report.map && typeof report.map === 'object');
  }

  function originText(report) {
    const o = report.map && report.map.origin_crs;
    const crs = report.survey && report.survey.crs;
    const epsg = crs && crs.epsg ? ` (${crs.epsg})` : '';
    return Array.isArray(o) ? `E ${fixed(o[0], 3)}, N ${fixed(o[1], 3)}${epsg}` : `the survey origin${epsg}`;
  }

  /** One card: a heading and label/value rows. */
  function card(title, rows) {
    const dl = el('dl');
    for (const [label, value] of rows) {
      dl.appendChild(el('dt', { text: label }));
      dl.appendChild(el('dd', { text: value }));
    }
    return el('div', { class: 'card' }, [el('h3', { text: title }), dl]);
  }

  function renderSummary(report) {
    const s = report.survey || {};
    const f = s.frames || {};
    const crs = s.crs || {};
    const g = s.gnss || null;
    const surf = s.surface || null;
    const cards = clear(byId('summary-cards'));

    cards.appendChild(card('Survey', [
      ['Date', isText(s.date_utc) ? utc(s.date_utc) : DASH],
      ['Length', isNum(s.length_m) ? `${measure(s.length_m, null, M)} m` : DASH],
      ['Duration', seconds(s.duration_s)],
      ['Damages', String((report.damages || []).length)],
    ]));
    cards.appendChild(card('Frames', [
      ['Listed', text(f.listed)],
      ['Usable', text(f.usable)],
      ['Placed', text(f.placed)],
      ['Analysed', text(f.analysed)],
    ]));
    cards.appendChild(card('Coordinate system', [
      ['CRS', [crs.epsg, crs.spec].filter(isText).join(' · ') || DASH],
      ['Heights', text(crs.heights)],
      ['Units', text(crs.units)],
      ['Map origin', originText(report)],
    ]));
    cards.appendChild(card('GNSS', gnssRows(g)));
    cards.appendChild(card('Surface', surf ? [
      ['Area', isNum(surf.area_m2) ? `${fixed(surf.area_m2, 1)} m²` : DASH],
      ['Cell', isNum(surf.cell_m) ? `${mm(surf.cell_m)} mm` : DASH],
      ['Mean height σ', isNum(surf.mean_sigma_m) ? `${mm(surf.mean_sigma_m)} mm` : DASH],
    ] : [['Surface model', 'not computed']]));
  }

  function gnssRows(g) {
    if (!g) return [['GNSS', 'no fixes used']];
    const types = Object.entries(g.fix_types || {}).map(([k, n]) => `${k.replace(/_/g, ' ')} ${n}`);
    const rmse = g.residual_rmse_m || null;
    const sigma = g.robust_sigma_m || null;
    return [
      ['Fixes', text(g.fixes)],
      ['Fix types', types.length ? types.join(', ') : DASH],
      ['Residual RMSE', rmse ? `${mm(rmse.horizontal)} mm horizontal, ${mm(rmse.vertical)} mm vertical` : DASH],
      ['Robust σ (E/N/U)', sigma ? `${mm(sigma.east)} / ${mm(sigma.north)} / ${mm(sigma.up)} mm` : DASH],
      ['Outliers', text(g.outliers)],
    ];
  }

  function renderRunTimes(run) {
    const table = clear(byId('run-times'));
    const stages = run && Array.isArray(run.stages) ? run.stages : [];
    if (!stages.length) {
      table.replaceWith(el('p', { id: 'run-times', class: 'note', text: 'Processing times were not recorded.' }));
      return;
    }
    table.appendChild(el('caption', { text: isText(run.finished_utc) ? `Run finished ${utc(run.finished_utc)}` : null }));
    table.appendChild(el('thead', {}, el('tr', {}, ['Stage', 'Time', 'Frames computed', 'reused', 'skipped']
      .map((h, i) => el('th', { scope: 'col', class: i ? 'num' : null, text: h })))));
    const body = el('tbody');
    for (const st of stages) {
      body.appendChild(el('tr', {}, [
        el('th', { scope: 'row', text: text(st.name) }),
        el('td', { class: 'num', text: seconds(st.wall_s) }),
        el('td', { class: 'num', text: text(st.frames_computed) }),
        el('td', { class: 'num', text: text(st.frames_reused) }),
        el('td', { class: 'num', text: text(st.frames_skipped) }),
      ]));
    }
    table.appendChild(body);
    const total = isNum(run.total_s) ? run.total_s : stages.reduce((a, st) => a + (isNum(st.wall_s) ? st.wall_s : 0), 0);
    table.appendChild(el('tfoot', {}, el('tr', {}, [
      el('th', { scope: 'row', text: 'Total' }),
      el('td', { class: 'num', text: seconds(total) }),
      el('td', { colspan: 3 }),
    ])));
  }

  /** Warnings and skipped frames: collapsed lists, their counts in the summary line. */
  /** A list from the report data, else from the run record (which records what each run met). */
  function listFrom(report, run, key) {
    if (Array.isArray(report[key]) && report[key].length) return report[key];
    return run && Array.isArray(run[key]) ? run[key] : [];
  }

  function renderNotices(report, run) {
    const box = clear(byId('notices'));
    const warnings = listFrom(report, run, 'warnings');
    const skipped = listFrom(report, run, 'skipped_frames');

    const wList = el('ul', { class: 'notice-list' }, warnings.map((w) =>
      el('li', {}, [el('span', { class: 'stage-tag', text: text(w.stage) }), ' ', text(w.message)])));
    box.appendChild(el('details', { id: 'warnings', class: warnings.length ? 'has-items' : null }, [
      el('summary', { text: `Warnings (${warnings.length})` }),
      warnings.length ? wList : el('p', { class: 'note', text: 'No warnings.' }),
    ]));

    const sTable = el('table', { class: 'compact' }, [
      el('thead', {}, el('tr', {}, ['Frame', 'Stage', 'Reason', 'Where'].map((h) => el('th', { scope: 'col', text: h })))),
      el('tbody', {}, skipped.map((s) => el('tr', {}, [
        el('td', { class: 'num', text: text(s.frame) }), el('td', { text: text(s.stage) }),
        el('td', { text: text(s.reason) }), el('td', { class: 'where', text: text(s.where) }),
      ]))),
    ]);
    box.appendChild(el('details', { id: 'skipped-frames', class: skipped.length ? 'has-items' : null }, [
      el('summary', { text: `Skipped frames (${skipped.length})` }),
      skipped.length ? sTable : el('p', { class: 'note', text: 'No frame was skipped.' }),
    ]));
  }

  // ---------------------------------------------------------------------------------------------
  // Map

  /** A scale bar that reads down to millimetres (Leaflet's own stops at 1 m). */
  function scaleBar() {
    return new (L.Control.extend({
      options: { position: 'bottomleft', maxWidth: 140 },
      onAdd(map) {
        this._bar = el('div', { class: 'scale-bar-line' });
        this._label = el('div', { class: 'scale-bar-label' });
        const box = el('div', { class: 'scale-bar', 'aria-hidden': 'true' }, [this._bar, this._label]);
        map.on('zoomend moveend resize', this._update, this);
        this._map = map;
        this._update();
        return box;
      },
      onRemove(map) {
        map.off('zoomend moveend resize', this._update, this);
      },
      _update() {
        const size = this._map.getSize();
        if (!size.x) return;
        const y = size.y / 2;
        const a = this._map.containerPointToLatLng([0, y]);
        const b = this._map.containerPointToLatLng([this.options.maxWidth, y]);
        const span = Math.abs(b.lng - a.lng);
        if (!(span > 0)) return;
        const nice = niceBelow(span);
        this._bar.style.width = `${Math.round((this.options.maxWidth * nice) / span)}px`;
        this._label.textContent = lengthLabel(nice);
      },
    }))();
  }

  /** The largest 1, 2 or 5 × 10^k not above x. */
  function niceBelow(x) {
    const p = Math.pow(10, Math.floor(Math.log10(x)));
    for (const m of [5, 2, 1]) if (m * p <= x * (1 + 1e-9)) return m * p;
    return p;
  }

  function lengthLabel(m) {
    if (m >= 1000) return `${+(m / 1000).toPrecision(3)} km`;
    if (m >= 1) return `${+m.toPrecision(3)} m`;
    if (m >= 0.01) return `${+(m * 100).toPrecision(3)} cm`;
    return `${+(m * 1000).toPrecision(3)} mm`;
  }

  /** A button that fits the map to the survey's extent again. */
  function fitControl() {
    return new (L.Control.extend({
      options: { position: 'topleft' },
      onAdd() {
        const a = el('a', { id: 'map-fit', href: '#', role: 'button', title: 'Fit to survey extent',
          'aria-label': 'Fit to survey extent', text: '⤢' });
        const box = el('div', { class: 'leaflet-bar leaflet-control map-fit' }, a);
        L.DomEvent.disableClickPropagation(box);
        L.DomEvent.on(a, 'click', (e) => {
          L.DomEvent.preventDefault(e);
          if (state.fitExtent) state.fitExtent();
        });
        return box;
      },
    }))();
  }

  /** The survey's extent: the stated one, else what the trajectory and damages cover. */
  function surveyBounds(report) {
    const m = report.map || {};
    const b = L.latLngBounds([]);
    if (Array.isArray(m.extent) && m.extent.length === 2) b.extend(m.extent[0]).extend(m.extent[1]);
    if (!b.isValid()) {
      for (const p of m.trajectory || []) b.extend(p);
      for (const d of report.damages || []) if (Array.isArray(d.centroid)) b.extend(d.centroid);
    }
    return b.isValid() ? padBounds(b, 1) : null;
  }

  /** Bounds grown by a margin in metres (L.LatLngBounds.pad is relative, useless on a point). */
  function padBounds(b, margin) {
    return L.latLngBounds([b.getSouth() - margin, b.getWest() - margin], [b.getNorth() + margin, b.getEast() + margin]);
  }

  function orthoLayer(ortho) {
    if (!ortho || !Array.isArray(ortho.pieces) || !ortho.pieces.length) return null;
    return L.layerGroup(ortho.pieces.map((p) => L.imageOverlay(p.file, p.bounds, {
      className: 'ortho-piece', interactive: false, alt: '',
    })));
  }

  function trajectoryLayer(trajectory) {
    if (!Array.isArray(trajectory) || trajectory.length < 2) return null;
    return L.layerGroup([
      L.polyline(trajectory, { color: '#0b3d91', weight: 2, opacity: 0.8, dashArray: '6 4', interactive: false,
        className: 'trajectory' }),
      L.circleMarker(trajectory[0], { radius: 5, color: '#0b3d91', weight: 2, fillColor: '#fff', fillOpacity: 1,
        className: 'trajectory-start' }).bindTooltip('Start of the survey (chainage 0)'),
    ]);
  }

  function damageStyle(d, selected) {
    const colour = SEVERITY_COLOURS[severityOf(d)];
    const line = d.geometry && d.geometry.type === 'LineString';
    return {
      color: selected ? SELECTED_STROKE : colour,
      weight: (line ? 4 : 2) + (selected ? 3 : 0),
      opacity: 1,
      fillColor: colour,
      fillOpacity: selected ? 0.6 : 0.35,
    };
  }

  /** One damage's map layer: polygon for depressions, polyline for cracks, a dot otherwise. */
  function damageLayer(d) {
    const g = d.geometry || {};
    const opts = Object.assign(damageStyle(d, false), { className: `damage-path damage-id-${d.id}` });
    let layer;
    if (g.type === 'Polygon' && Array.isArray(g.coordinates)) layer = L.polygon(g.coordinates, opts);
    else if (g.type === 'LineString' && Array.isArray(g.coordinates)) layer = L.polyline(g.coordinates, opts);
    else if (Array.isArray(d.centroid)) layer = L.circleMarker(d.centroid, Object.assign(opts, { radius: 6 }));
    else return null;
    layer.bindTooltip(`#${d.id} ${d.type}, ${severityOf(d)}`, { sticky: true });
    layer.on('click', () => selectDamage(d.id, { zoom: false, scroll: true }));
    // Leaflet builds a new <path> each time a layer is added (filters remove and add layers).
    layer.on('add', () => markLayer(d.id, layer));
    return layer;
  }

  function markLayer(id, layer) {
    const path = layer.getElement && layer.getElement();
    if (!path) return;
    path.setAttribute('data-id', String(id));
    path.classList.toggle('damage-selected', id === state.selectedId);
  }

  function renderMap(report) {
    const m = report.map;
    if (!hasMap(report)) {
      renderNoMap(report);
      return;
    }
    const map = L.map('map', {
      crs: L.CRS.Simple, minZoom: -6, maxZoom: MAX_ZOOM, zoomSnap: 0.25, zoomDelta: 0.5,
      attributionControl: false, preferCanvas: false,
    });
    state.map = map;

    const bases = {};
    const overlays = {};
    const ortho = orthoLayer(m.ortho);
    if (ortho) bases['Orthophoto'] = ortho.addTo(map);
    bases['Blank'] = ortho ? L.layerGroup() : L.layerGroup().addTo(map);
    const traj = trajectoryLayer(m.trajectory);
    if (traj) overlays['Trajectory'] = traj.addTo(map);
    const damages = L.featureGroup();
    for (const d of state.damages) {
      const layer = damageLayer(d);
      if (!layer) continue;
      state.layers.set(d.id, layer);
      damages.addLayer(layer);
    }
    overlays['Damages'] = damages.addTo(map);
    state.damageGroup = damages;

    // The view first: the scale bar measures the map as soon as it is added.
    const bounds = surveyBounds(report);
    state.fitExtent = () => (bounds ? map.fitBounds(bounds, { animate: false }) : map.setView([0, 0], 0));
    state.fitExtent();

    L.control.layers(bases, overlays, { collapsed: false, position: 'topright' }).addTo(map);
    scaleBar().addTo(map);
    fitControl().addTo(map);

    byId('map-note').textContent = [
      ortho ? `Orthophoto at ${isNum(m.ortho.cell_m) ? mm(m.ortho.cell_m) + ' mm' : 'reduced'} cells.`
        : 'No orthophoto: the surface model was not computed.',
      `Coordinates in metres east and north of ${originText(report)}.`,
      state.damages.length ? 'Click a damage to select it in the table.' : '',
    ].filter(Boolean).join(' ');
  }

  /** Without georeferenced cameras there is no map frame: say so where the map would be. */
  function renderNoMap(report) {
    const box = byId('map');
    box.classList.add('no-map');
    const georef = report.survey && report.survey.georeferenced;
    box.appendChild(el('p', { class: 'note', text: georef === false
      ? 'No map: the cameras are not georeferenced, so nothing can be placed in a map frame.'
      : 'No map: the report data has no map frame.' }));
    byId('map-note').textContent = '';
  }

  function zoomToDamage(id) {
    const layer = state.layers.get(id);
    if (!layer || !state.map) return;
    const b = layer.getBounds ? layer.getBounds() : L.latLngBounds([layer.getLatLng()]);
    const size = Math.max(b.getNorth() - b.getSouth(), b.getEast() - b.getWest());
    state.map.fitBounds(padBounds(b, Math.max(ZOOM_MARGIN_M, 0.75 * size)), { maxZoom: MAX_ZOOM - 1 });
  }

  // Print pages are narrower than a screen: Leaflet must measure the map again and refit.
  function refitForMedia() {
    if (!state.map) return;
    state.map.invalidateSize({ animate: false });
    if (state.selectedId !== null && state.layers.has(state.selectedId)) zoomToDamage(state.selectedId);
    else if (state.fitExtent) state.fitExtent();
  }

  // ---------------------------------------------------------------------------------------------
  // Damage table

  const COLUMNS = [
    { key: 'id', label: 'ID', numeric: true, value: (d) => d.id, cell: (d) => String(d.id) },
    { key: 'type', label: 'Type', value: (d) => d.type, cell: typeCell },
    { key: 'chainage_m', label: 'Chainage (m)', numeric: true, cell: (d) => fixed(props(d).chainage_m, 2) },
    { key: 'offset_m', label: 'Offset (m)', numeric: true, cell: (d) => offset(props(d).offset_m) },
    { key: 'area_m2', label: 'Area (m²)', numeric: true,
      cell: (d) => measure(props(d).area_m2, props(d).sigma_area_m2, M2) },
    { key: 'max_depth_m', label: 'Max depth (mm)', numeric: true, cell: depthCell },
    { key: 'volume_m3', label: 'Volume', numeric: true,
      cell: (d) => volume(props(d).volume_m3, props(d).sigma_volume_m3) },
    { key: 'severity', label: 'Severity', numeric: true, align: 'left',
      value: (d) => SEVERITY_RANK[severityOf(d)], cell: severityCell },
    { key: 'observations', label: 'Observations', numeric: true, cell: observationsCell },
  ];

  /** Figures align right; a column that sorts by a rank but shows words stays left. */
  function alignClass(col) {
    return col.numeric && col.align !== 'left' ? 'num' : null;
  }

  function columnValue(col, d) {
    const v = col.value ? col.value(d) : props(d)[col.key];
    if (col.numeric) return isNum(v) ? v : null;
    return isText(v) ? v : null;
  }

  function typeCell(d) {
    if (props(d).outline_complete !== false) return d.type || DASH;
    return [d.type || DASH, ' ', el('span', { class: 'mark', text: 'partial',
      title: 'No view held the whole outline: area and volume are lower bounds' })];
  }

  function depthCell(d) {
    const p = props(d);
    const value = measure(p.max_depth_m, p.sigma_max_depth_m, MM);
    if (p.floor_visible !== false || !isNum(p.max_depth_m)) return value;
    const interval = `floor hidden: max depth in [${mm(p.max_depth_seen_m)}, ${mm(p.max_depth_bound_m)}] mm`;
    return [value, ' ', el('span', { class: 'mark', text: 'floor hidden', title: interval })];
  }

  function severityCell(d) {
    const p = props(d);
    const g = governingRule(d);
    const parts = [severityBadge(d)];
    if (g.standard) parts.push(' ', el('span', { class: 'rule-src', text: g.standard, title: g.rule }));
    if (p.intervention === true) {
      parts.push(' ', el('span', { class: 'mark mark-alert', text: 'intervention',
        title: `Intervention needed: ${text(p.intervention_rule)}` }));
    }
    return parts;
  }

  function observationsCell(d) {
    const p = props(d);
    if (!isNum(p.observations)) return DASH;
    return isNum(p.views_in_view) ? `${p.observations} of ${p.views_in_view}` : String(p.observations);
  }

  function renderTableHead() {
    const row = el('tr');
    for (const col of COLUMNS) {
      const th = el('th', { scope: 'col', 'data-key': col.key, class: alignClass(col), 'aria-sort': 'none' },
        el('button', { type: 'button', class: 'sort', title: `Sort by ${col.label.toLowerCase()}` },
          [col.label, el('span', { class: 'sort-arrow', 'aria-hidden': 'true' })]));
      th.addEventListener('click', () => sortBy(col.key));
      row.appendChild(th);
    }
    clear(document.querySelector('#damage-table thead')).appendChild(row);
  }

  function renderTableBody() {
    const body = clear(document.querySelector('#damage-table tbody'));
    if (!state.damages.length) {
      const why = hasMap(state.report) ? 'No damage was found on this survey.'
        : 'No damage map: damages are placed only on georeferenced surveys.';
      body.appendChild(el('tr', { class: 'empty' }, el('td', { colspan: COLUMNS.length, text: why })));
      return;
    }
    for (const d of state.damages) {
      const tr = el('tr', { 'data-id': d.id, 'data-type': d.type, 'data-severity': severityOf(d), tabindex: 0 });
      for (const col of COLUMNS) tr.appendChild(el('td', { class: alignClass(col) }, col.cell(d)));
      tr.addEventListener('click', () => selectDamage(d.id, { zoom: true, scroll: false }));
      tr.addEventListener('keydown', (e) => {
        if (e.key === 'Enter' || e.key === ' ') {
          e.preventDefault();
          selectDamage(d.id, { zoom: true, scroll: false });
        }
      });
      state.rows.set(d.id, tr);
      body.appendChild(tr);
    }
  }

  /** Numbers numerically, text alphabetically; missing values last in either direction. */
  function compareDamages(col, dir) {
    const sign = dir === 'asc' ? 1 : -1;
    return (a, b) => {
      const va = columnValue(col, a);
      const vb = columnValue(col, b);
      if (va === null || vb === null) {
        if (va === vb) return a.id - b.id;
        return va === null ? 1 : -1;
      }
      const c = col.numeric ? va - vb : String(va).localeCompare(String(vb));
      return c !== 0 ? sign * c : a.id - b.id;
    };
  }

  function sortBy(key) {
    if (state.sortKey === key) state.sortDir = state.sortDir === 'asc' ? 'desc' : 'asc';
    else {
      state.sortKey = key;
      state.sortDir = 'asc';
    }
    applySort();
  }

  function applySort() {
    const col = COLUMNS.find((c) => c.key === state.sortKey) || COLUMNS[0];
    for (const th of document.querySelectorAll('#damage-table thead th')) {
      const active = th.getAttribute('data-key') === col.key;
      th.setAttribute('aria-sort', active ? (state.sortDir === 'asc' ? 'ascending' : 'descending') : 'none');
    }
    const body = document.querySelector('#damage-table tbody');
    for (const d of state.damages.slice().sort(compareDamages(col, state.sortDir))) {
      const tr = state.rows.get(d.id);
      if (tr) body.appendChild(tr);
    }
  }

  /** The deciding rule of every damage, for paper, where tooltips cannot be read. */
  function renderGradingRules() {
    const list = clear(byId('grading-rules'));
    const box = byId('grading-rules-box');
    if (!state.damages.length) {
      box.remove();
      return;
    }
    for (const d of state.damages.slice().sort((a, b) => a.id - b.id)) {
      const p = props(d);
      const g = governingRule(d);
      const parts = [`${severityOf(d)}: ${g.rule || 'no grading rule recorded'}`];
      if (isText(p.intervention_rule)) {
        parts.push(`intervention ${p.intervention === true ? 'needed' : 'not needed'}: ${p.intervention_rule}`);
      }
      list.appendChild(el('li', {}, [el('span', { class: 'rid', text: `#${d.id}` }), ' ', parts.join('; ')]));
    }
  }

  // ---------------------------------------------------------------------------------------------
  // Filters

  function renderFilters() {
    const typeSel = byId('filter-type');
    const sevSel = byId('filter-severity');
    const types = TYPE_ORDER.concat(state.damages.map((d) => d.type).filter((t) => isText(t) && !TYPE_ORDER.includes(t)));
    for (const t of [...new Set(types)]) {
      const n = state.damages.filter((d) => d.type === t).length;
      if (n) typeSel.appendChild(el('option', { value: t, text: `${t} (${n})` }));
    }
    for (const s of SEVERITIES) {
      const n = state.damages.filter((d) => severityOf(d) === s).length;
      if (n) sevSel.appendChild(el('option', { value: s, text: `${s} (${n})` }));
    }
    typeSel.addEventListener('change', () => { state.filterType = typeSel.value; applyFilters(); });
    sevSel.addEventListener('change', () => { state.filterSeverity = sevSel.value; applyFilters(); });
    byId('filter-search').addEventListener('input', (e) => {
      state.query = e.target.value.trim().toLowerCase();
      applyFilters();
    });
  }

  function passesFilters(d) {
    if (state.filterType && d.type !== state.filterType) return false;
    if (state.filterSeverity && severityOf(d) !== state.filterSeverity) return false;
    return !state.query || d._search.includes(state.query);
  }

  /** Filters hide table rows and the same damages on the map. */
  function applyFilters() {
    let shown = 0;
    for (const d of state.damages) {
      const pass = passesFilters(d);
      if (pass) shown += 1;
      const tr = state.rows.get(d.id);
      if (tr) tr.classList.toggle('filtered-out', !pass);
      const layer = state.layers.get(d.id);
      const group = state.damageGroup;
      if (layer && group) {
        if (pass && !group.hasLayer(layer)) group.addLayer(layer);
        if (!pass && group.hasLayer(layer)) group.removeLayer(layer);
      }
    }
    if (state.selectedId !== null && !passesFilters(state.byId.get(state.selectedId))) selectDamage(null, {});
    byId('damage-count').textContent = state.damages.length
      ? `${shown} of ${count(state.damages.length, 'damage')} shown` : '';
  }

  // ---------------------------------------------------------------------------------------------
  // Selection and detail panel

  /** Selects a damage everywhere: table row, map outline, detail panel. null clears it. */
  function selectDamage(id, options) {
    const d = id === null ? null : state.byId.get(id);
    state.selectedId = d ? d.id : null;
    for (const [rid, tr] of state.rows) {
      const on = rid === state.selectedId;
      tr.classList.toggle('selected', on);
      tr.setAttribute('aria-selected', on ? 'true' : 'false');
    }
    for (const [lid, layer] of state.layers) {
      const on = lid === state.selectedId;
      layer.setStyle(damageStyle(state.byId.get(lid), on));
      markLayer(lid, layer);
      if (on && layer.bringToFront && state.map && state.map.hasLayer(layer)) layer.bringToFront();
    }
    renderDetail(d);
    if (!d) return;
    if (options.zoom) zoomToDamage(d.id);
    if (options.scroll) {
      const tr = state.rows.get(d.id);
      if (tr) tr.scrollIntoView({ block: 'nearest', behavior: 'smooth' });
    }
  }

  function detailRow(label, value, note) {
    return el('tr', {}, [el('th', { scope: 'row', text: label }),
      el('td', {}, [value, note ? el('div', { class: 'rule', text: note }) : null])]);
  }

  function gradeBadge(level) {
    if (!isText(level)) return DASH;
    return el('span', { class: `sev sev-${SEVERITY_COLOURS[level] ? level : 'none'}`, text: level });
  }

  function renderDetail(d) {
    const box = clear(byId('damage-detail'));
    box.classList.toggle('empty', !d);
    if (!d) {
      box.appendChild(el('p', { class: 'note', text: state.damages.length
        ? 'Select a damage in the table or on the map to see its measurements.' : 'No damage to show.' }));
      return;
    }
    const p = props(d);
    box.appendChild(el('h3', {}, [`Damage ${d.id}: ${d.type || DASH} `, severityBadge(d)]));
    box.appendChild(thumbnailFigure(d));
    box.appendChild(el('table', { class: 'detail-table' }, el('tbody', {}, detailRows(d, p))));
  }

  function thumbnailFigure(d) {
    const p = props(d);
    if (!isText(d.thumbnail)) return el('p', { class: 'note no-thumb', text: 'No thumbnail for this damage.' });
    return el('figure', { class: 'thumb' }, [
      el('img', { id: 'detail-thumbnail', src: d.thumbnail, alt: `Damage ${d.id} in its best view` }),
      el('figcaption', { text: isNum(p.best_frame) ? `Best view: frame ${p.best_frame}, outline drawn` : 'Best view' }),
    ]);
  }

  // Fields that only one kind of damage measures: the other kind leaves them empty, and a row
  // of dashes there would read as a failed measurement.
  const CRACK_ONLY = ['length_m', 'width_m', 'max_width_m'];
  const DEPRESSION_ONLY = ['area_m2', 'max_depth_m', 'mean_depth_m', 'volume_m3', 'max_diameter_m', 'floor_visible'];

  function detailRows(d, p) {
    const rows = [];
    const notMeasuredHere = d.type === 'crack' ? DEPRESSION_ONLY : CRACK_ONLY;
    const shown = (k) => Object.prototype.hasOwnProperty.call(p, k)
      && (!notMeasuredHere.includes(k) || (p[k] !== null && p[k] !== undefined));
    const add = (keys, label, value, note) => {
      if ([].concat(keys).some(shown)) rows.push(detailRow(label, value, note));
    };
    add('chainage_m', 'Chainage', unit(fixed(p.chainage_m, 2), 'm'));
    add('offset_m', 'Offset', offsetWords(p.offset_m));
    add('area_m2', 'Area', unit(measure(p.area_m2, p.sigma_area_m2, M2), 'm²'),
      p.outline_complete === false ? 'lower bound: no view held the whole outline' : null);
    add('max_depth_m', 'Max depth', unit(measure(p.max_depth_m, p.sigma_max_depth_m, MM), 'mm'),
      p.floor_visible === false ? 'floor hidden by the near rim in every view used' : null);
    if (p.floor_visible === false) {
      add(['max_depth_seen_m', 'max_depth_bound_m'], 'Max depth interval',
        `[${mm(p.max_depth_seen_m)}, ${mm(p.max_depth_bound_m)}] mm`, 'seen, and the deepest the geometry allows');
    }
    add('mean_depth_m', 'Mean depth', unit(measure(p.mean_depth_m, p.sigma_mean_depth_m, MM), 'mm'));
    add('volume_m3', 'Volume', volume(p.volume_m3, p.sigma_volume_m3));
    if (isNum(p.volume_upper_m3)) add('volume_upper_m3', 'Volume upper bound', volume(p.volume_upper_m3, null));
    add('length_m', 'Length', unit(measure(p.length_m, p.sigma_length_m, M), 'm'));
    add('width_m', 'Mean width', unit(measure(p.width_m, p.sigma_width_m, MM), 'mm'));
    add('max_width_m', 'Max width', unit(mm(p.max_width_m), 'mm'));
    add('max_diameter_m', 'Max diameter', unit(mm(p.max_diameter_m), 'mm'));
    add('severity', 'Severity', severityBadge(d), governingRule(d).standard
      ? `set by ${governingRule(d).standard}` : null);
    add('astm_d6433', 'ASTM D6433', gradeBadge(p.astm_d6433), isText(p.astm_d6433_rule) ? p.astm_d6433_rule : null);
    add('fhwa_ltpp', 'FHWA LTPP', gradeBadge(p.fhwa_ltpp), isText(p.fhwa_ltpp_rule) ? p.fhwa_ltpp_rule : null);
    add('intervention', 'Intervention', p.intervention === true
      ? el('span', { class: 'mark mark-alert', text: 'needed' }) : yesNo(p.intervention),
    isText(p.intervention_rule) ? p.intervention_rule : null);
    add('observations', 'Observations', isNum(p.observations)
      ? `${p.observations} view${p.observations === 1 ? '' : 's'}${isNum(p.views_in_view) ? ` of ${p.views_in_view} in view` : ''}`
      : DASH);
    add('detection_rate', 'Detection rate', percent(p.detection_rate));
    add('observation_frames', 'Observation frames', isText(p.observation_frames)
      ? p.observation_frames.split(';').join(', ') : DASH);
    add('best_frame', 'Best frame', text(p.best_frame));
    add('outline_complete', 'Outline complete', yesNo(p.outline_complete));
    add('floor_visible', 'Floor visible', yesNo(p.floor_visible));
    add('basis', 'Basis', text(p.basis));
    return rows;
  }

  function unit(value, u) {
    return value === DASH ? DASH : `${value} ${u}`;
  }

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

  // ---------------------------------------------------------------------------------------------
  // Files

  function renderFiles(report) {
    const list = clear(byId('files'));
    const files = Array.isArray(report.files) ? report.files : [];
    if (!files.length) {
      list.appendChild(el('li', { class: 'note', text: 'No product file listed.' }));
      return;
    }
    for (const f of files) {
      if (!isText(f.path)) continue;
      list.appendChild(el('li', {}, [el('a', { href: f.path, text: f.label || f.path }), ' ', el('code', { text: f.path })]));
    }
  }

  // ---------------------------------------------------------------------------------------------
  // Print

  /** Printing opens the collapsed lists (a PDF cannot expand them) and refits the map. */
  function setUpPrint() {
    // Chromium signals printing twice (beforeprint and the media query): act once per print.
    let printing = false;
    let reopen = [];
    const before = () => {
      if (printing) return;
      printing = true;
      reopen = [...document.querySelectorAll('details:not([open])')];
      for (const d of reopen) d.open = true;
      refitForMedia();
    };
    const after = () => {
      if (!printing) return;
      printing = false;
      for (const d of reopen) d.open = false;
      reopen = [];
      refitForMedia();
    };
    window.addEventListener('beforeprint', before);
    window.addEventListener('afterprint', after);
    const mq = window.matchMedia('print');
    const onChange = (e) => (e.matches ? before() : after());
    if (mq.addEventListener) mq.addEventListener('change', onChange);
  }

  // ---------------------------------------------------------------------------------------------
  // Start

  function showError(message) {
    const box = byId('report-error');
    box.textContent = message;
    box.hidden = false;
  }

  function prepareDamages(report) {
    const list = Array.isArray(report.damages) ? report.damages.filter((d) => d && d.id !== undefined) : [];
    for (const d of list) {
      d._search = searchText(d);
      state.byId.set(d.id, d);
    }
    return list;
  }

  function main() {
    const report = window.ROADSURVEY_REPORT;
    if (!report || typeof report !== 'object') {
      showError('The report data (data/report.js) is missing: this folder is incomplete.');
      return;
    }
    if (typeof L === 'undefined') {
      showError('The map library (leaflet/leaflet.js) is missing: this folder is incomplete.');
      return;
    }
    state.report = report;
    state.run = window.ROADSURVEY_RUN || null;
    state.damages = prepareDamages(report);

    renderHeader(report, state.run);
    renderSummary(report);
    renderRunTimes(state.run);
    renderNotices(report, state.run);
    renderTableHead();
    renderTableBody();
    renderGradingRules();
    renderFilters();
    applySort();
    renderMap(report);
    applyFilters();
    renderDetail(null);
    renderCountCharts(report);
    renderDepthHistogram();
    renderResiduals(report);
    renderTrajectoryError(report);
    renderFiles(report);
    setUpPrint();
    document.addEventListener('keydown', (e) => {
      if (e.key === 'Escape' && state.selectedId !== null) selectDamage(null, {});
    });

    // Tests and readers of the page can tell when everything is drawn.
    document.documentElement.setAttribute('data-report-ready', 'true');
    if (window.performance && performance.mark) performance.mark('roadsurvey-report-rendered');
  }

  try {
    main();
  } catch (err) {
    showError(`The report could not be drawn: ${err && err.message ? err.message : err}`);
    throw err;
  }
})();
