// Browser test of the HTML survey report (stages/report/assets), in headless Chromium.
//
//   node report_browser_test.mjs <report_dir> <artifact_dir>
//
// <report_dir> is a published report/ folder; its damages are checked against ../damage.geojson.
// Chromium: $CHROMIUM, else /usr/bin/chromium. Screenshots and report.pdf go to <artifact_dir>.
// Every check runs and reports; exit 0 when all pass, 1 otherwise.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

import { chromium } from 'playwright-core';

const LOAD_LIMIT_S = 2.0;
const PDF_MIN_BYTES = 10 * 1024;
const PDF_TIMEOUT_MS = 120000;
const VIEWPORT = { width: 1400, height: 1000 };

const results = [];

function record(name, ok, detail) {
  results.push({ name, ok });
  console.log(ok ? `ok    ${name}` : `FAIL  ${name}: ${detail}`);
}

function note(message) {
  console.log(`note  ${message}`);
}

/** Runs one check; an exception fails it with its message instead of stopping the test. */
async function check(name, fn) {
  try {
    const detail = await fn();
    if (detail === undefined || detail === true) record(name, true);
    else record(name, false, detail === false ? 'check failed' : String(detail));
  } catch (err) {
    record(name, false, err && err.message ? err.message.split('\n')[0] : String(err));
  }
}

function usage() {
  console.error('usage: node report_browser_test.mjs <report_dir> <artifact_dir>');
  process.exit(1);
}

// ---------------------------------------------------------------------------------------------
// The damages the report must show, from the damage map beside it

function readGeoJson(reportDir) {
  const file = path.join(reportDir, '..', 'damage.geojson');
  if (!fs.existsSync(file)) return { file, features: null, error: `${file} not found` };
  try {
    const fc = JSON.parse(fs.readFileSync(file, 'utf8'));
    if (!Array.isArray(fc.features)) return { file, features: null, error: `${file} has no "features" array` };
    return { file, features: fc.features, error: null };
  } catch (err) {
    return { file, features: null, error: `${file} is not valid JSON: ${err.message}` };
  }
}

/** Whether damage.geojson names thumbnails that exist beside it. */
function geoJsonHasThumbnails(file, features) {
  const dir = path.dirname(file);
  return (features || []).some((f) => {
    const t = f.properties && f.properties.thumbnail;
    return typeof t === 'string' && t.length > 0 && fs.existsSync(path.join(dir, t));
  });
}

// ---------------------------------------------------------------------------------------------
// Page queries and actions

async function rowIds(page) {
  return page.$$eval('#damage-table tbody tr[data-id]', (rows) => rows.map((r) => r.getAttribute('data-id')));
}

async function visibleRowIds(page) {
  return page.$$eval('#damage-table tbody tr[data-id]', (rows) =>
    rows.filter((r) => r.getClientRects().length > 0).map((r) => r.getAttribute('data-id')));
}

async function selectedRowIds(page) {
  return page.$$eval('#damage-table tbody tr.selected', (rows) => rows.map((r) => r.getAttribute('data-id')));
}

/** Waits until Leaflet has finished zooming and panning. */
async function mapSettled(page) {
  await page.waitForFunction(() => !document.querySelector('#map .leaflet-zoom-anim, #map .leaflet-pan-anim'),
    null, { timeout: 5000 });
  await page.waitForTimeout(350);
}

/** A point on screen where the damage's path is the topmost element, or null. */
async function hitPoint(page, id) {
  return page.evaluate((id) => {
    const el = document.querySelector(`#map path[data-id="${id}"]`);
    const map = document.getElementById('map');
    if (!el || !map) return null;
    const m = map.getBoundingClientRect();
    const b = el.getBoundingClientRect();
    const x0 = Math.max(b.left, m.left, 0);
    const x1 = Math.min(b.right, m.right, window.innerWidth);
    const y0 = Math.max(b.top, m.top, 0);
    const y1 = Math.min(b.bottom, m.bottom, window.innerHeight);
    if (x1 - x0 < 1 || y1 - y0 < 1) return null;
    const points = [[(x0 + x1) / 2, (y0 + y1) / 2]];
    const n = 8;
    for (let i = 1; i < n; i += 1) for (let j = 1; j < n; j += 1) points.push([x0 + ((x1 - x0) * i) / n, y0 + ((y1 - y0) * j) / n]);
    for (const [x, y] of points) if (document.elementFromPoint(x, y) === el) return { x, y, size: Math.min(b.width, b.height) };
    return null;
  }, String(id));
}

/** Zooms the map in around a damage with the mouse wheel until it is large enough to click. */
async function zoomOnto(page, id) {
  for (let i = 0; i < 6; i += 1) {
    const box = await page.locator(`#map path[data-id="${id}"]`).boundingBox();
    if (!box || Math.min(box.width, box.height) >= 12) return;
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.wheel(0, -240);
    await mapSettled(page);
  }
}

function depthsInOrder(ids, depthById) {
  return ids.map((id) => {
    const v = depthById.get(id);
    return typeof v === 'number' && Number.isFinite(v) ? v : null;
  });
}

/** Non-null values ordered (asc or desc) with every null after them; else a description. */
function orderProblem(values, dir) {
  let seenNull = false;
  for (let i = 0; i < values.length; i += 1) {
    if (values[i] === null) {
      seenNull = true;
      continue;
    }
    if (seenNull) return `a depth follows a missing one at row ${i + 1}`;
    if (i > 0 && values[i - 1] !== null) {
      const bad = dir === 'asc' ? values[i] < values[i - 1] : values[i] > values[i - 1];
      if (bad) return `rows ${i} and ${i + 1}: ${values[i - 1]} then ${values[i]}`;
    }
  }
  return null;
}

// ---------------------------------------------------------------------------------------------
// PDF through Chromium's own command line, as a reader would print the report

function printPdf(executable, url, pdfPath) {
  fs.rmSync(pdfPath, { force: true });
  const args = ['--headless', '--no-sandbox', '--disable-gpu', `--print-to-pdf=${pdfPath}`, url];
  return new Promise((resolve) => {
    const child = spawn(executable, args, { stdio: ['ignore', 'pipe', 'pipe'] });
    let output = '';
    child.stdout.on('data', (d) => { output += d; });
    child.stderr.on('data', (d) => { output += d; });
    const timer = setTimeout(() => child.kill('SIGKILL'), PDF_TIMEOUT_MS);
    child.on('error', (err) => {
      clearTimeout(timer);
      resolve({ code: -1, output: `${output}${err.message}` });
    });
    child.on('close', (code, signal) => {
      clearTimeout(timer);
      resolve({ code: signal ? `signal ${signal}` : code, output });
    });
  });
}

async function checkPdf(executable, url, artifactDir) {
  const pdfPath = path.join(artifactDir, 'report.pdf');
  const { code, output } = await printPdf(executable, url, pdfPath);
  const tail = output.trim().split('\n').slice(-8).join('\n');
  await check('PDF printed by `chromium --headless --print-to-pdf`', () => {
    if (!fs.existsSync(pdfPath)) return `no ${pdfPath} (exit ${code}); chromium said:\n${tail}`;
    const bytes = fs.readFileSync(pdfPath);
    if (bytes.subarray(0, 4).toString('latin1') !== '%PDF') return `${pdfPath} does not start with %PDF`;
    if (bytes.length <= PDF_MIN_BYTES) return `${pdfPath} is ${bytes.length} bytes (expected > ${PDF_MIN_BYTES})`;
    console.log(`      report.pdf: ${(bytes.length / 1024).toFixed(0)} kB`);
    return true;
  });
}

// ---------------------------------------------------------------------------------------------
// The browser checks

/** Loads the report; returns the load time in seconds (navigation start to loaded and drawn). */
async function loadReport(page, url) {
  await page.goto(url, { waitUntil: 'load' });
  await page.waitForSelector('html[data-report-ready="true"]', { state: 'attached', timeout: 10000 });
  // A survey without georeferenced cameras has no map (the page says so instead).
  const hasMap = await page.evaluate(() => Boolean(window.ROADSURVEY_REPORT && window.ROADSURVEY_REPORT.map));
  if (hasMap) await page.waitForSelector('#map.leaflet-container .leaflet-map-pane', { state: 'attached', timeout: 10000 });
  else note('the report has no map (cameras not georeferenced)');
  const t = await page.evaluate(() => {
    const nav = performance.getEntriesByType('navigation')[0];
    const mark = performance.getEntriesByName('roadsurvey-report-rendered')[0];
    return { load: nav ? nav.loadEventEnd : null, rendered: mark ? mark.startTime : null };
  });
  if (t.load === null || t.rendered === null) throw new Error('navigation timing or the report\'s render mark is missing');
  return Math.max(t.load, t.rendered) / 1000;
}

async function checkSelection(page, damages, thumbnailsExpected, artifactDir) {
  const ids = await rowIds(page);
  const withThumb = ids.filter((id) => damages.get(id) && damages.get(id).thumbnail);
  let id = ids[0];
  if (!(damages.get(id) && damages.get(id).thumbnail) && withThumb.length) id = withThumb[0];
  const hasThumb = Boolean(damages.get(id) && damages.get(id).thumbnail);

  await check('thumbnails in the report when damage.geojson has them', () =>
    !thumbnailsExpected || withThumb.length > 0 || 'damage.geojson lists thumbnails, but no report damage has one');

  await page.click(`#damage-table tbody tr[data-id="${id}"]`);
  await mapSettled(page);
  await check(`clicking row ${id} selects it`, async () => {
    const sel = await selectedRowIds(page);
    return (sel.length === 1 && sel[0] === id) || `selected rows: [${sel.join(', ')}]`;
  });
  await check('the selected damage is highlighted on the map (path.damage-selected)', async () => {
    const n = await page.locator('#map path.damage-selected').count();
    const own = await page.locator(`#map path.damage-selected[data-id="${id}"]`).count();
    return (n === 1 && own === 1) || `${n} path(s) with class damage-selected, ${own} of damage ${id}`;
  });
  await check('the detail panel shows the selected damage', async () => {
    const txt = await page.locator('#damage-detail').innerText();
    return new RegExp(`Damage ${id}\\b`).test(txt) || `#damage-detail reads "${txt.slice(0, 80)}…"`;
  });
  if (hasThumb) {
    await check(`#detail-thumbnail of damage ${id} is visible and loaded`, async () => {
      const img = page.locator('#detail-thumbnail');
      await img.waitFor({ state: 'visible', timeout: 5000 });
      await page.waitForFunction(() => {
        const i = document.getElementById('detail-thumbnail');
        return i && i.complete;
      }, null, { timeout: 5000 });
      const w = await img.evaluate((i) => i.naturalWidth);
      return w > 0 || `the image did not load (naturalWidth 0, src ${await img.getAttribute('src')})`;
    });
  } else {
    note('no damage has a thumbnail: thumbnail check skipped');
  }
  await page.locator('#map-section').screenshot({ path: path.join(artifactDir, 'report_map_selected.png') });
  return id;
}

async function checkMapClick(page, damages, selectedId) {
  const polygons = [...damages.values()].filter((d) => d.geometry === 'Polygon').map((d) => String(d.id));
  if (!polygons.length) {
    note('no polygon damage: map click check skipped');
    return;
  }
  const order = polygons.filter((id) => id !== selectedId).concat(polygons.filter((id) => id === selectedId));
  await page.locator('#map').scrollIntoViewIfNeeded();
  await page.click('#map-fit');
  await mapSettled(page);
  let target = null;
  let point = null;
  for (const id of order) {
    await zoomOnto(page, id);
    point = await hitPoint(page, id);
    if (point) {
      target = id;
      break;
    }
    await page.click('#map-fit');
    await mapSettled(page);
  }
  await check('clicking a damage polygon on the map selects its row', async () => {
    if (!target) return `no polygon (${order.join(', ')}) could be hit on the map`;
    note(`clicking damage ${target} on the map at (${Math.round(point.x)}, ${Math.round(point.y)})`);
    await page.mouse.click(point.x, point.y);
    await page.waitForFunction((id) => {
      const tr = document.querySelector(`#damage-table tbody tr[data-id="${id}"]`);
      return tr && tr.classList.contains('selected');
    }, target, { timeout: 3000 }).catch(() => {});
    const sel = await selectedRowIds(page);
    return (sel.length === 1 && sel[0] === target) || `clicked damage ${target}; selected rows: [${sel.join(', ')}]`;
  });
}

async function checkSorting(page, damages) {
  const depthById = new Map([...damages.values()].map((d) => [String(d.id), d.max_depth_m]));
  const th = page.locator('#damage-table th[data-key="max_depth_m"]');
  for (const dir of ['asc', 'desc']) {
    const label = dir === 'asc' ? 'ascending' : 'descending';
    await th.click();
    await check(`sorting by max depth, ${label} (missing depths last)`, async () => {
      const aria = await th.getAttribute('aria-sort');
      if (aria !== label) return `aria-sort is "${aria}"`;
      const problem = orderProblem(depthsInOrder(await rowIds(page), depthById), dir);
      return problem === null || problem;
    });
  }
}

async function checkTypeFilter(page, damages) {
  const types = [...new Set([...damages.values()].map((d) => d.type))];
  const total = damages.size;
  const counts = new Map(types.map((t) => [t, [...damages.values()].filter((d) => d.type === t).length]));
  const type = types.find((t) => counts.get(t) < total) || types[0];
  await page.selectOption('#filter-type', type);
  await check(`filtering by type "${type}" shows its ${counts.get(type)} damage(s) only`, async () => {
    const shown = await visibleRowIds(page);
    const wrong = shown.filter((id) => damages.get(id).type !== type);
    if (wrong.length) return `rows of other types shown: ${wrong.join(', ')}`;
    return shown.length === counts.get(type) || `${shown.length} rows shown`;
  });
  await page.selectOption('#filter-type', '');
  await check('clearing the type filter shows every row again', async () => {
    const shown = await visibleRowIds(page);
    return shown.length === total || `${shown.length} of ${total} rows shown`;
  });
}

// "Repair first" lists every damage an intervention rule flags, most severe first; selecting one
// selects its row.
async function checkRepairFirst(page, damages) {
  const rank = { high: 3, medium: 2, low: 1, none: 0 };
  const flagged = [...damages.values()].filter((d) => d.intervention);
  const items = page.locator('#priorities .priority-list button');
  await check(`"repair first" lists the ${flagged.length} damage(s) flagged for intervention`, async () =>
    (await items.count()) === flagged.length || `${await items.count()} listed`);
  if (!flagged.length) return;
  const ids = await items.evaluateAll((buttons) => buttons.map((b) => b.getAttribute('data-id')));
  await check('"repair first" puts the most severe first', () => {
    const ranks = ids.map((id) => rank[damages.get(id).severity] || 0);
    return ranks.every((r, i) => i === 0 || r <= ranks[i - 1]) || `severities ${ids.map((id) => damages.get(id).severity)}`;
  });
  await items.first().click();
  await check('selecting the first "repair first" damage selects its row', async () => {
    const selected = await selectedRowIds(page);
    return (selected.length === 1 && selected[0] === ids[0]) || `selected rows [${selected.join(', ')}]`;
  });
}

// ---------------------------------------------------------------------------------------------

async function main() {
  const [reportArg, artifactArg] = process.argv.slice(2);
  if (!reportArg || !artifactArg) usage();
  const reportDir = path.resolve(reportArg);
  const artifactDir = path.resolve(artifactArg);
  const index = path.join(reportDir, 'index.html');
  const executable = process.env.CHROMIUM || '/usr/bin/chromium';
  fs.mkdirSync(artifactDir, { recursive: true });
  if (!fs.existsSync(index)) {
    record('report folder', false, `${index} not found`);
    return finish();
  }
  const url = pathToFileURL(index).href;
  console.log(`report: ${url}`);

  const geo = readGeoJson(reportDir);
  await check(`damage.geojson beside the report (${geo.file})`, () => geo.error === null || geo.error);
  const thumbnailsExpected = geo.features ? geoJsonHasThumbnails(geo.file, geo.features) : false;

  let browser;
  try {
    browser = await chromium.launch({ executablePath: executable, args: ['--no-sandbox'], headless: true });
  } catch (err) {
    record(`Chromium starts (${executable})`, false, err.message.split('\n')[0]);
    return finish();
  }
  try {
    await browserChecks(browser, { url, reportDir, artifactDir, geo, thumbnailsExpected });
  } finally {
    await browser.close();
  }
  await checkPdf(executable, url, artifactDir);
  return finish();
}

async function browserChecks(browser, { url, reportDir, artifactDir, geo, thumbnailsExpected }) {
  const page = await browser.newPage({ viewport: VIEWPORT });
  page.setDefaultTimeout(10000);
  const consoleErrors = [];
  const pageErrors = [];
  const failedRequests = [];
  page.on('console', (msg) => {
    const where = msg.location() && msg.location().url ? ` (${msg.location().url}:${msg.location().lineNumber})` : '';
    if (msg.type() === 'error') {
      consoleErrors.push(`${msg.text()}${where}`);
    } else if (msg.type() === 'warning') {
      // Warnings from the report's own files count as errors; Chromium's own are only shown.
      if (where.includes(pathToFileURL(reportDir).href)) consoleErrors.push(`warning: ${msg.text()}${where}`);
      else note(`console warning: ${msg.text()}${where}`);
    }
  });
  page.on('pageerror', (err) => pageErrors.push(err.message));
  page.on('requestfailed', (req) => failedRequests.push(`${req.url()} (${req.failure() && req.failure().errorText})`));

  let loaded = false;
  await check(`report loads within ${LOAD_LIMIT_S} s`, async () => {
    const seconds = await loadReport(page, url);
    loaded = true;
    console.log(`report load: ${seconds.toFixed(3)} s`);
    return seconds <= LOAD_LIMIT_S || `${seconds.toFixed(3)} s`;
  });
  if (!loaded) {
    reportErrors(consoleErrors, pageErrors, failedRequests);
    return;
  }
  await page.screenshot({ path: path.join(artifactDir, 'report_full.png'), fullPage: true });

  const data = await page.evaluate(() => {
    const r = window.ROADSURVEY_REPORT || {};
    return (Array.isArray(r.damages) ? r.damages : []).map((d) => ({
      id: String(d.id), type: d.type, thumbnail: d.thumbnail || null,
      geometry: d.geometry ? d.geometry.type : null,
      max_depth_m: d.properties ? d.properties.max_depth_m : null,
      intervention: Boolean(d.properties && d.properties.intervention === true), severity: d.severity,
    }));
  });
  const damages = new Map(data.map((d) => [d.id, d]));
  const rows = await rowIds(page);

  if (geo.features) {
    await check(`damage table has one row per damage.geojson feature (${geo.features.length})`, () =>
      rows.length === geo.features.length || `${rows.length} rows`);
    await check('the report\'s damages are those of damage.geojson', () => {
      const byNumber = (a, b) => Number(a) - Number(b) || a.localeCompare(b);
      const want = geo.features.map((f) => String(f.properties && f.properties.id !== undefined ? f.properties.id : f.id))
        .sort(byNumber);
      const have = data.map((d) => d.id).sort(byNumber);
      return JSON.stringify(want) === JSON.stringify(have) || `report ids [${have.join(', ')}], geojson ids [${want.join(', ')}]`;
    });
  }
  await check('every table row is a damage of the report data', () => {
    const unknown = rows.filter((id) => !damages.has(id));
    return (rows.length === damages.size && !unknown.length) || `${rows.length} rows for ${damages.size} damages`;
  });

  if (!rows.length) {
    note('no damage in this report: selection, map, sorting and filter checks skipped');
    await page.locator('#map-section').screenshot({ path: path.join(artifactDir, 'report_map_selected.png') });
  } else {
    const selected = await checkSelection(page, damages, thumbnailsExpected, artifactDir);
    await checkMapClick(page, damages, selected);
    await checkSorting(page, damages);
    await checkTypeFilter(page, damages);
    await checkRepairFirst(page, damages);
  }
  reportErrors(consoleErrors, pageErrors, failedRequests);
  await page.close();
}

function reportErrors(consoleErrors, pageErrors, failedRequests) {
  record('no console errors', consoleErrors.length === 0, `\n        ${consoleErrors.join('\n        ')}`);
  record('no page errors', pageErrors.length === 0, `\n        ${pageErrors.join('\n        ')}`);
  record('every file of the report loads', failedRequests.length === 0, `\n        ${failedRequests.join('\n        ')}`);
}

function finish() {
  const failed = results.filter((r) => !r.ok);
  if (failed.length) {
    console.log(`\nFAILED: ${failed.length} of ${results.length} checks:`);
    for (const f of failed) console.log(`  - ${f.name}`);
    process.exitCode = 1;
  } else {
    console.log(`\nreport browser test passed: ${results.length} checks`);
    process.exitCode = 0;
  }
}

main().catch((err) => {
  console.error(`report browser test could not run: ${err && err.stack ? err.stack : err}`);
  process.exitCode = 1;
});
