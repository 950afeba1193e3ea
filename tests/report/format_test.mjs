// Unit test of the report page's value formatting (stages/report/assets/js/format.js) in plain
// Node.js, no browser: every number a reader sees goes through these functions.
//   node format_test.mjs <path/to/format.js>
import fs from 'node:fs';
import vm from 'node:vm';
import assert from 'node:assert/strict';

const file = process.argv[2];
if (!file) {
  console.error('usage: node format_test.mjs <format.js>');
  process.exit(2);
}
const context = { window: {} };
vm.runInNewContext(fs.readFileSync(file, 'utf8'), context, { filename: file });
const R = context.window.RoadsurveyReport;

const cases = [
  // Missing values read as a dash, never 0.
  ['null depth', () => R.mm(null), '\u2014'],
  ['null volume', () => R.volume(undefined, 0.1), '\u2014'],
  ['null offset', () => R.offset(null), '\u2014'],
  ['zero is a value', () => R.mm(0), '0.0'],
  // A value to the precision its σ supports (σ to one significant digit, two when it starts with 1).
  ['area ± σ', () => R.measure(0.6134, 0.0512, R.M2), '0.61 ± 0.05'],
  ['area σ starting with 1', () => R.measure(0.0281, 0.0163, R.M2), '0.028 ± 0.016'],
  ['depth in mm ± σ', () => R.measure(0.0921, 0.0302, R.MM), '92 ± 30'],
  ['depth without σ', () => R.mm(0.0044), '4.4'],
  // Volumes below a cubic metre in litres.
  ['volume in litres', () => R.volume(0.0321, 0.0029), '32 ± 3 L'],
  ['volume in cubic metres', () => R.volume(2.4, 0.31), '2.4 ± 0.3 m³'],
  // Offsets: right of the direction of travel is positive.
  ['offset right', () => R.offset(1.934), '1.93 R'],
  ['offset left', () => R.offset(-0.755), '0.76 L'],
  ['offset on the line', () => R.offset(0.001), '0.00'],
  ['offset in words', () => R.offsetWords(-2.5), '2.50 m left of the line'],
  // Durations round once: 179.8 s is 3 min, not "2 min 60 s".
  ['seconds', () => R.seconds(4.333), '4.33 s'],
  ['tens of seconds', () => R.seconds(46.53), '46.5 s'],
  ['just under a minute', () => R.seconds(59.97), '1 min 00 s'],
  ['minutes', () => R.seconds(179.81), '3 min 00 s'],
  ['hours', () => R.seconds(3599.6), '1 h 00 min'],
  ['hours and minutes', () => R.seconds(5430), '1 h 31 min'],
  ['percent', () => R.percent(0.875), '88 %'],
  ['UTC without the browser locale', () => R.utc('2026-12-07T16:01:47Z'), '2026-12-07 16:01:47 UTC'],
  ['plural', () => R.count(1, 'frame'), '1 frame'],
  ['plural many', () => R.count(3, 'frame'), '3 frames'],
];

let failed = 0;
for (const [name, fn, expected] of cases) {
  try {
    assert.equal(fn(), expected);
    console.log(`ok    ${name}`);
  } catch (e) {
    failed += 1;
    console.log(`FAIL  ${name}: ${e.message.split('\n')[0]} (got ${JSON.stringify(safe(fn))}, expected ${JSON.stringify(expected)})`);
  }
}
function safe(fn) {
  try {
    return fn();
  } catch (e) {
    return String(e);
  }
}
console.log(failed ? `${failed} of ${cases.length} failed` : `format test passed: ${cases.length} checks`);
process.exit(failed ? 1 : 0);
