// @ts-check
// The answer of a calibration, first in the results. One table holds every sensor's corrected
// extrinsic T_parent_s (xyz m, rpy deg; the parent is the vehicle frame, under the name the user
// or the recording gives it), so at 1280x720 the verdict and every extrinsic are in view
// without scrolling, even for five sensors. Below it a card per sensor holds what belongs to
// that sensor only: its verdict's reasons, the error against a demo's truth, the
// sensor-to-sensor transform T_ref_s (not printed again when it equals the extrinsic: a
// reference at the parent's origin), the precision, and the spread over frames (none for one
// frame). Everything else (4x4 matrices, corrections, notes) folds below (results.js).
import { degrees, matrixFromXyzRpy, poseDifference, quaternionOf, rpyOf, xyzOf } from '../transforms.js';

const f = (v, d) => v.map((x) => x.toFixed(d)).join(' ');
// Fixed-width columns, so the table's numbers line up.
const cols = (v, d, w) => v.map((x) => x.toFixed(d).padStart(w)).join(' ');
const numbers = (m) => `xyz ${cols(xyzOf(m), 4, 8)} m\nrpy ${cols(rpyOf(m).map(degrees), 3, 8)} °`;
export const esc = (s) => String(s).replace(/[&<>"]/g, (c) => `&#${c.charCodeAt(0)};`);
// A name that may wrap after '_', '/' or '-' (lidar_front_left), never inside a word.
const breakable = (name) => esc(name).replace(/([_/-])/g, '$1<wbr>');

// Two matrices whose entries differ by less than this print alike at the digits shown: one
// transform, said once.
const SAME = 1e-8;

/** @typedef {import('../result').PageResult} Result */
/** @typedef {import('../result').SensorReport} Sensor */
/** @typedef {Record<string, {xyz: [number, number, number], rpy: [number, number, number]}> | null} Truth */

// Error of a sensor's calibrated extrinsic against the truth: deg and mm.
/** @param {Sensor} sensor @param {Truth} truth */
export function errorVsTruth(sensor, truth) {
  const t = truth?.[sensor.name];
  if (!t) return null;
  const { angle, distance } = poseDifference(sensor.extrinsic, matrixFromXyzRpy(t.xyz, t.rpy));
  return { deg: degrees(angle), mm: distance * 1000 };
}

// Green within the twin's accuracy bound (0.1 deg and 10 mm, docs/accuracy.md), amber beyond.
const truthClass = ({ deg, mm }) => (deg < 0.1 && mm < 10 ? 'near' : 'off');

// The three lines of a transform as users paste them; also what its Copy button copies.
export function transformLines(m) {
  return [
    `xyz (m)         ${f(xyzOf(m), 6)}`,
    `rpy (deg)       ${f(rpyOf(m).map(degrees), 5)}`,
    `quat (x y z w)  ${f(quaternionOf(m), 7)}`,
  ];
}

const copyButton = (name, from, to, m) => {
  const text = `# ${name}: maps ${from}'s points into ${to}\n${transformLines(m).join('\n')}`;
  return `<button type="button" class="copy" data-copy="${esc(text)}" aria-label="Copy ${esc(name)}" title="Copy ${esc(name)} (xyz, rpy, quaternion) with its direction">Copy</button>`;
};

// One transform `T_{to}_{from}` with its direction in words, in full (a sensor's card).
function transformHtml(name, from, to, m, testid) {
  return `<div class="transform" data-testid="${testid}" data-sensor="${esc(from)}">
    <p class="direction"><code>${esc(name)}</code>: maps <b>${esc(from)}</b>'s points into <b>${esc(to)}</b> ${copyButton(name, from, to, m)}</p>
    <pre>${transformLines(m).map(esc).join('\n')}</pre></div>`;
}

// The run in one line: method, EM iterations and whether EM converged.
/** @param {Result} r */
export function runLine(r) {
  const em = r.iterations
    ? `, ${r.iterations} EM iterations, ${r.converged ? 'converged' : '<span class="not-converged">not converged</span> (stopped at the iteration limit; the later stages refine from there)'}`
    : '';
  return `<p class="run" data-testid="run-summary" data-converged="${r.converged}">method ${esc(r.method)}${em}${r.cancelled ? ', cancelled' : ''}</p>`;
}

// The reasons that set a sensor's level (not good): its card says them, and only it.
export const concerns = (/** @type {import('../result').ReasonReport[]} */ reasons) => reasons.filter((x) => x.level !== 'good');

// A row of the table: the sensor and its level, its extrinsic's xyz and rpy, Copy.
/** @param {Sensor} s @param {Result} r @param {string} parent */
function extrinsicRow(s, r, parent) {
  const level = r.verdict.sensors[s.name]?.level ?? '';
  const name = `T_${parent}_${s.name}`;
  return `<tr data-testid="extrinsic" data-sensor="${esc(s.name)}">
    <th scope="row"><a href="#card-${esc(s.name)}">${breakable(s.name)}</a><span class="sensor-verdict ${level}" data-testid="sensor-verdict" data-sensor="${esc(s.name)}" data-level="${level}">${level}</span></th>
    <td class="numbers">${numbers(s.extrinsic)}</td>
    <td>${copyButton(name, s.name, parent, s.extrinsic)}</td></tr>`;
}

// The reference's row: it keeps its nominal.
/** @param {Sensor} s @param {string} parent @param {Truth} truth */
function referenceRow(s, parent, truth) {
  const error = errorVsTruth(s, truth);
  return `<tr class="reference" data-testid="reference-line" data-sensor="${esc(s.name)}">
    <th scope="row">${breakable(s.name)}<span class="hint">reference</span></th>
    <td class="numbers">${numbers(s.extrinsic)}</td>
    <td class="hint" title="${esc(s.name)} is the reference: it keeps its nominal T_${esc(parent)}_${esc(s.name)}; the others are calibrated to it">nominal</td></tr>
    ${error ? `<tr><td colspan="3" class="hint"><span class="truth ${truthClass(error)}" data-sensor="${esc(s.name)}">${esc(s.name)}'s nominal vs the simulated truth: <b>${error.deg.toFixed(3)} deg / ${error.mm.toFixed(1)} mm</b></span></td></tr>` : ''}`;
}

// A sensor's card: its reasons, truth, T_ref_s, precision, spread.
/** @param {Sensor} s @param {Result} r @param {{truth: Truth, parent: string, warnings: string[]}} context */
function sensorCard(s, r, { truth, parent, warnings }) {
  const error = errorVsTruth(s, truth);
  const verdict = r.verdict.sensors[s.name];
  const reasons = [...(verdict ? concerns(verdict.reasons).map((x) => `<li class="${x.level}">${esc(x.text)}</li>`) : []),
    ...warnings.map((w) => `<li class="check" data-testid="warning">${esc(w)}</li>`)];
  const sameAsExtrinsic = Array.from(s.extrinsic).every((v, i) => Math.abs(v - s.relative[i]) < SAME);
  const relative = sameAsExtrinsic
    ? `<p class="direction" data-testid="relative" data-sensor="${esc(s.name)}"><code>T_${esc(r.reference)}_${esc(s.name)}</code> = <code>T_${esc(parent)}_${esc(s.name)}</code> (the table above): ${esc(r.reference)} sits at ${esc(parent)}'s origin. Quaternion (x y z w) ${f(quaternionOf(s.extrinsic), 7)}</p>`
    : transformHtml(`T_${r.reference}_${s.name}`, s.name, r.reference, s.relative, 'relative');
  const precision = s.precision
    ? `<p class="precision" title="One-sigma uncertainty of the final estimate: the larger of the joint plane adjustment's and the smallest move the scans tell apart (at 2 standard errors, divided by 2)">precision (1 sigma): position ${s.precision.position.map((v) => (v * 1000).toFixed(1)).join(', ')} mm, rotation about x, y, z ${s.precision.rotation.map((v) => degrees(v).toFixed(4)).join(', ')} deg</p>`
    : '';
  // One frame has no spread to speak of.
  const spread = s.spread.frames > 1
    ? `<p class="spread" title="Standard deviation, per axis, of the corrections found frame by frame">spread over ${s.spread.frames} frames: xyz ${s.spread.xyz.map((v) => (v * 1000).toFixed(1)).join(', ')} mm, rpy ${s.spread.rpy.map((v) => degrees(v).toFixed(3)).join(', ')} deg</p>`
    : '';
  const errorText = error ? `<p class="truth ${truthClass(error)}" data-sensor="${esc(s.name)}">error vs the simulated truth: <b>${error.deg.toFixed(3)} deg / ${error.mm.toFixed(1)} mm</b></p>` : '';
  return `<section class="answer-sensor" id="card-${esc(s.name)}" data-sensor="${esc(s.name)}">
    <h3>${esc(s.name)} <span class="sensor-verdict ${verdict?.level ?? ''}">${verdict?.level ?? ''}</span></h3>
    ${reasons.length ? `<ul class="reasons" data-testid="sensor-reasons">${reasons.join('')}</ul>` : ''}
    ${errorText}${relative}${precision}${spread}</section>`;
}

// The reference's card, only when it has concerns of its own (a scan given twice): they belong
// to it, and nowhere else.
/** @param {Sensor} s @param {Result} r @param {string[]} warnings */
function referenceCard(s, r, warnings) {
  const reasons = [...concerns(r.verdict.sensors[s.name]?.reasons ?? []).map((x) => `<li class="${x.level}">${esc(x.text)}</li>`),
    ...warnings.map((w) => `<li class="check" data-testid="warning">${esc(w)}</li>`)];
  if (!reasons.length) return '';
  const level = r.verdict.sensors[s.name]?.level ?? '';
  return `<section class="answer-sensor" id="card-${esc(s.name)}" data-sensor="${esc(s.name)}">
    <h3>${esc(s.name)} (reference) <span class="sensor-verdict ${level}">${level}</span></h3>
    <ul class="reasons" data-testid="sensor-reasons">${reasons.join('')}</ul></section>`;
}

// The answer of result `r`: the table of extrinsics (the reference last), the run line, then a
// card per non-reference sensor. `parent`: the vehicle frame's name; `warnings`: sensor -> lines
// to show on its card besides its verdict's reasons.
/**
 * @param {Result} r
 * @param {{truth?: Truth, parent?: string, warnings?: Record<string, string[]>}} [options]
 */
export function answerHtml(r, { truth = null, parent = 'vehicle', warnings = {} } = {}) {
  const reference = r.sensors.find((s) => s.name === r.reference);
  const others = r.sensors.filter((s) => s !== reference);
  return `<div class="answer-table">
    <p class="direction"><code>T_${esc(parent)}_s</code>: maps each sensor's points into <b>${esc(parent)}</b></p>
    <table class="extrinsics">${others.map((s) => extrinsicRow(s, r, parent)).join('')}${reference ? referenceRow(reference, parent, truth) : ''}</table></div>
    ${runLine(r)}
    ${others.map((s) => sensorCard(s, r, { truth, parent, warnings: warnings[s.name] ?? [] })).join('')}
    ${reference ? referenceCard(reference, r, warnings[reference.name] ?? []) : ''}`;
}

// Copy buttons of a container (data-copy): one listener, set once per render.
export function wireCopy(container) {
  container.onclick = async (event) => {
    const button = event.target.closest('button[data-copy]');
    if (!button) return;
    await navigator.clipboard.writeText(button.dataset.copy);
    button.textContent = 'Copied';
    setTimeout(() => (button.textContent = 'Copy'), 1500);
  };
}
