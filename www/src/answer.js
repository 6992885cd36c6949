// The answer of a calibration, first in the results: per non-reference sensor the corrected
// extrinsic T_vehicle_s and the sensor-to-sensor transform T_ref_s, each in the notation users
// paste (xyz m, rpy deg, quaternion x y z w) and labelled with the way it maps, with the
// precision, the spread and (for a demo) the error against the truth beside them. The reference
// sensor is one line. Everything else (4x4 matrices, corrections, notes) folds below it
// (results.js).
import { degrees, matrixFromXyzRpy, poseDifference, quaternionOf, rpyOf, xyzOf } from './transforms.js';

const f = (v, d) => v.map((x) => x.toFixed(d)).join(' ');
export const esc = (s) => String(s).replace(/[&<>"]/g, (c) => `&#${c.charCodeAt(0)};`);

// Error of a sensor's calibrated extrinsic against the truth: deg and mm.
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

// One transform `T_{to}_{from}` with its direction in words.
function transformHtml(name, from, to, m, testid) {
  const lines = transformLines(m);
  const title = `${name}: maps ${from}'s points into ${to}`;
  return `<div class="transform" data-testid="${testid}" data-sensor="${esc(from)}">
    <p class="direction"><code>${esc(name)}</code>: maps <b>${esc(from)}</b>'s points into <b>${esc(to)}</b>
      <button type="button" class="copy" data-copy="${esc(`# ${title}\n${lines.join('\n')}`)}" aria-label="Copy ${esc(name)}">Copy</button></p>
    <pre>${lines.map(esc).join('\n')}</pre></div>`;
}

// The run in one line: method, EM iterations and whether EM converged.
export function runLine(r) {
  const em = r.iterations
    ? `, ${r.iterations} EM iterations, ${r.converged ? 'converged' : '<span class="not-converged">not converged</span> (stopped at the iteration limit; the later stages refine from there)'}`
    : '';
  return `<p class="run" data-testid="run-summary" data-converged="${r.converged}">method ${esc(r.method)}${em}${r.cancelled ? ', cancelled' : ''}</p>`;
}

function sensorVerdict(r, name) {
  const s = r.verdict.sensors[name];
  if (!s) return '';
  const shown = s.reasons.filter((x) => x.level !== 'good');
  return `<span class="sensor-verdict ${s.level}" data-testid="sensor-verdict" data-sensor="${esc(name)}" data-level="${s.level}">${s.level}${shown.length ? ` — ${shown.map((x) => esc(x.text)).join('; ')}` : ''}</span>`;
}

// The reference: one line (it keeps its nominal).
function referenceHtml(s, truth) {
  const rpy = rpyOf(s.extrinsic).map(degrees);
  const error = errorVsTruth(s, truth);
  return `<p class="reference" data-testid="reference-line"><b>${esc(s.name)}</b> is the reference: it keeps its nominal
    <code>T_vehicle_${esc(s.name)}</code> (xyz ${f(xyzOf(s.extrinsic), 3)} m, rpy ${f(rpy, 3)} deg)${error ? `; <span class="truth ${truthClass(error)}" data-sensor="${esc(s.name)}">error vs the truth <b>${error.deg.toFixed(3)} deg / ${error.mm.toFixed(1)} mm</b></span>` : ''}.</p>`;
}

function sensorHtml(s, r, truth) {
  const error = errorVsTruth(s, truth);
  const precision = s.precision
    ? `<p class="precision" title="One-sigma uncertainty of the final estimate from the joint plane adjustment">precision (1 sigma): position ${s.precision.position.map((v) => (v * 1000).toFixed(1)).join(', ')} mm, rotation about x, y, z ${s.precision.rotation.map((v) => degrees(v).toFixed(4)).join(', ')} deg</p>`
    : '';
  const spread = `<p class="spread" title="Standard deviation, per axis, of the corrections found frame by frame">spread over ${s.spread.frames} frames: xyz ${s.spread.xyz.map((v) => (v * 1000).toFixed(1)).join(', ')} mm, rpy ${s.spread.rpy.map((v) => degrees(v).toFixed(3)).join(', ')} deg</p>`;
  const errorText = error ? `<p class="truth ${truthClass(error)}" data-sensor="${esc(s.name)}">error vs the simulated truth: <b>${error.deg.toFixed(3)} deg / ${error.mm.toFixed(1)} mm</b></p>` : '';
  return `<section class="answer-sensor" data-sensor="${esc(s.name)}">
    <h3>${esc(s.name)} ${sensorVerdict(r, s.name)}</h3>${errorText}
    ${transformHtml(`T_vehicle_${s.name}`, s.name, 'vehicle', s.extrinsic, 'extrinsic')}
    ${transformHtml(`T_${r.reference}_${s.name}`, s.name, r.reference, s.relative, 'relative')}
    ${precision}${spread}</section>`;
}

// The answer of result `r`: run line, then every non-reference sensor, the reference last in
// one line.
export function answerHtml(r, truth) {
  const reference = r.sensors.find((s) => s.name === r.reference);
  return `${runLine(r)}${r.sensors.filter((s) => s !== reference).map((s) => sensorHtml(s, r, truth)).join('')}${reference ? referenceHtml(reference, truth) : ''}`;
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
