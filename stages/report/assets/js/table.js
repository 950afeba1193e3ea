/* roadsurvey survey report: the damage table (head, rows, sorting), its filters, the printed
 * grading rules, and selecting a damage with its detail panel.
 */
(function () {
  'use strict';

  const R = (window.RoadsurveyReport = window.RoadsurveyReport || {});
  const { DASH, SEVERITIES, SEVERITY_COLOURS, TYPE_ORDER, state, isNum, isText, el, clear, byId, fixed, MM, M,
    M2, measure, mm, volume, offset, offsetWords, percent, yesNo, text, count, props, governingRule,
    severityOf, severityBadge, hasMap, damageStyle, markLayer, zoomToDamage } = R;

  const SEVERITY_RANK = { none: 0, low: 1, medium: 2, high: 3 };

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
    { key: 'observations', label: 'Views', numeric: true, cell: observationsCell },
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

  // "detected in N of the M views that had it in sight": N counts frames, not observations (a crack
  // may be detected in several pieces in one frame).
  function observationsCell(d) {
    const p = props(d);
    if (!isNum(p.observations)) return DASH;
    const frames = isText(p.observation_frames) ? new Set(p.observation_frames.split(';')).size : null;
    if (frames === null || !isNum(p.views_in_view)) return String(p.observations);
    return `${frames} of ${p.views_in_view} views`;
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
    add(['observations', 'views_in_view'], 'Views', observationsCell(d),
      'frames that detected it, of those that had it in sight');
    add('observations', 'Observations', text(p.observations), 'detections merged (a crack may come in pieces)');
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

  Object.assign(R, { renderTableHead, renderTableBody, applySort, renderGradingRules, renderFilters,
    applyFilters, selectDamage, renderDetail });
})();
