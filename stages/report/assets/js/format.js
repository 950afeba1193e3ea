/* roadsurvey survey report: shared constants, the page's shared state, value formatting and DOM
 * helpers. Loaded first; the other scripts take what they need from window.RoadsurveyReport.
 * Data text is only ever inserted as text (never as HTML): el() and svgEl() set textContent.
 */
(function () {
  'use strict';

  const R = (window.RoadsurveyReport = window.RoadsurveyReport || {});

  const DASH = '\u2014';
  const SVG_NS = 'http://www.w3.org/2000/svg';
  const SEVERITIES = ['high', 'medium', 'low', 'none'];
  const SEVERITY_COLOURS = { high: '#d7191c', medium: '#ff8000', low: '#ffcc00', none: '#808080' };
  const TYPE_ORDER = ['pothole', 'crack', 'other'];
  const TYPE_COLOURS = { pothole: '#5e3c99', crack: '#1b7837', other: '#2b83ba' };

  // The page's shared state (R.state): the data, the table rows and map layers by damage id, the
  // sort, filters and selection.
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
    if (s < 59.95) return `${s.toFixed(s < 10 ? 2 : 1)} s`;
    // Round once, then split: 179.8 s is "3 min 00 s", not "2 min 60 s".
    const whole = Math.round(s);
    if (whole < 3600) return `${Math.floor(whole / 60)} min ${String(whole % 60).padStart(2, '0')} s`;
    const minutes = Math.round(s / 60);
    return `${Math.floor(minutes / 60)} h ${String(minutes % 60).padStart(2, '0')} min`;
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

  Object.assign(R, { DASH, SEVERITIES, SEVERITY_COLOURS, TYPE_ORDER, TYPE_COLOURS, state, isNum, isText, el,
    svgEl, clear, byId, fixed, MM, M, M2, measure, mm, volume, offset, offsetWords, percent, yesNo, seconds,
    utc, text, count });
})();
