/* roadsurvey survey report: the header, summary cards, processing times, warnings and skipped
 * frames, and the list of product files.
 */
(function () {
  'use strict';

  const R = (window.RoadsurveyReport = window.RoadsurveyReport || {});
  const { DASH, isNum, isText, el, clear, byId, fixed, M, measure, mm, seconds, utc, text } = R;

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

  Object.assign(R, { renderHeader, hasMap, originText, renderSummary, renderRunTimes, renderNotices,
    renderFiles });
})();
