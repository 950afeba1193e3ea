/* roadsurvey survey report.
 *
 * Draws window.ROADSURVEY_REPORT (data/report.js) and window.ROADSURVEY_RUN (data/run.js) into
 * index.html: summary, map, damage table with detail panel, charts and file links. Plain ES2017
 * and Leaflet, no build step and no network, so the folder opens from file:// anywhere.
 * Data text is only ever inserted as text (never as HTML): rule texts and warnings come from logs.
 *
 * The drawing is split by job into js/format.js, js/damage.js, js/summary.js, js/priorities.js,
 * js/map.js, js/table.js and js/charts.js, plain deferred scripts that share window.RoadsurveyReport
 * (ES module scripts are refused on file:// pages). This one, loaded last, starts the drawing.
 */
(function () {
  'use strict';

  const R = (window.RoadsurveyReport = window.RoadsurveyReport || {});
  const { state, byId, searchText, renderHeader, renderSummary, renderRunTimes, renderNotices, renderFiles,
    renderPriorities,
    renderMap, refitForMedia, renderTableHead, renderTableBody, applySort, renderGradingRules, renderFilters,
    applyFilters, selectDamage, renderDetail, renderCountCharts, renderDepthHistogram, renderResiduals,
    renderTrajectoryError } = R;

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
    renderPriorities(state.damages);
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
