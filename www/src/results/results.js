// @ts-check
// The results panel: the verdict first (good, check or failed, with its evidence one click
// away), then the answer (answer.js: per sensor the corrected extrinsic and the
// sensor-to-sensor transform, with their directions, precision and spread); everything else
// folds below: the 4x4 matrices and corrections, the target's plausibility, the ground
// levelling, the notes. With several methods, one comparison table with each method's verdict
// and the methods it agrees with. The convergence plot is drawn here too.
import { degrees, matrixFromXyzRpy, poseDifference, quaternionOf, rpyOf, xyzOf } from '../transforms.js';
import { answerHtml, concerns, errorVsTruth, esc, wireCopy } from './answer.js';

export { errorVsTruth };

/** @typedef {import('../result').PageResult} Result */
/** @typedef {import('./answer.js').Truth} Truth */

const IDENTITY = matrixFromXyzRpy([0, 0, 0], [0, 0, 0]);
const f = (v, d) => v.map((x) => x.toFixed(d)).join(', ');

function matrixHtml(m) {
  const rows = [0, 1, 2, 3].map((r) => `<tr>${[0, 1, 2, 3].map((c) => `<td>${m[r * 4 + c].toFixed(6)}</td>`).join('')}</tr>`);
  return `<table class="matrix">${rows.join('')}</table>`;
}

function poseHtml(title, m) {
  const rpy = rpyOf(m);
  return `<div class="pose"><h4>${title}</h4>${matrixHtml(m)}
    <p>xyz ${f(xyzOf(m), 4)} m</p>
    <p>rpy ${f(rpy.map(degrees), 4)} deg = ${f(rpy, 6)} rad</p>
    <p>quaternion xyzw ${f(quaternionOf(m), 6)}</p></div>`;
}

const VERDICT_TITLE = {
  good: 'Good: the evidence supports this calibration.',
  check: 'Check: some evidence does not support this calibration; read the reasons before you use it.',
  failed: 'Failed: do not use this extrinsic.',
};

// The verdict in a few words, as a PNG of the view carries it across its top.
const VERDICT_SHORT = { good: 'Good: the evidence supports this calibration', check: 'Check: read the reasons before using this calibration', failed: 'Failed: do not use this extrinsic' };
export const verdictTitle = (level) => VERDICT_SHORT[level] ?? level;

// An advice of the page (panels/advice.js) with its buttons; main.js acts on their data-advice.
export const adviceHtml = ({ html, actions = [] }) => `<p class="advice" data-testid="advice">${html}${actions.map((a) => ` <button type="button" data-advice="${esc(JSON.stringify({ what: a.what, value: a.value }))}">${esc(a.label)}</button>`).join('')}</p>`;

/** @param {import('../result').ReasonReport[]} reasons */
function reasonsHtml(reasons) {
  return `<ul>${reasons.map((r) => `<li class="${r.level}">${esc(r.text)}</li>`).join('')}</ul>`;
}

// The verdict: its level, the run's own concerns (the reconstruction, the methods), which
// sensors have theirs (said on each sensor's card, not here), `advice` (html lines the page
// adds), and the evidence that supports it folded below. Each reason is said once: a
// concern where it belongs, a supporting finding under Evidence.
/** @param {Result} r @param {{html: string, actions?: {label: string, what: string, value?: string}[]}[]} advice */
function verdictHtml(r, advice = []) {
  const v = r.verdict;
  const flagged = Object.entries(v.sensors).filter(([, s]) => s.level !== 'good').map(([name]) => name);
  const support = Object.entries(v.sensors).map(([name, s]) => /** @type {const} */ ([name, s.reasons.filter((x) => x.level === 'good')])).filter(([, list]) => list.length);
  // A run-level finding the advice quotes (no target found) is said there only, whatever its
  // level.
  const quoted = (x) => advice.length && x.kind === 'noTarget';
  const runReasons = v.reasons.filter((x) => !quoted(x));
  const runSupport = runReasons.filter((x) => x.level === 'good');
  const evidence = support.map(([name, list]) => `<p><b>${esc(name)}</b></p>${reasonsHtml(list)}`).join('') +
    (runSupport.length ? `<p><b>reconstruction and run</b></p>${reasonsHtml(runSupport)}` : '');
  return `<div class="verdict ${v.level}" data-testid="verdict" data-level="${v.level}">
    <p><strong>${VERDICT_TITLE[v.level]}</strong>${flagged.length ? ` <span class="flagged">Reasons on the card of ${flagged.map(esc).join(', ')} below.</span>` : ''}</p>
    ${concerns(runReasons).length ? reasonsHtml(concerns(runReasons)) : ''}
    ${advice.map(adviceHtml).join('')}
    ${evidence ? `<details><summary>Evidence that supports it</summary>${evidence}</details>` : ''}
  </div>`;
}

// A sensor's full detail: the correction and the extrinsic as 4x4, xyz, rpy (deg and rad) and
// quaternion.
/** @param {import('../result').SensorReport} s @param {string} reference @param {string} parent */
function sensorDetailHtml(s, reference, parent) {
  return `<section class="sensor"><h4>${esc(s.name)}${s.name === reference ? ' (reference)' : ''}</h4>
    <div class="poses">${poseHtml(`correction C_${esc(reference)}_${esc(s.name)}: maps ${esc(s.name)}'s nominally placed points onto ${esc(reference)}'s`, s.correction)}${poseHtml(`extrinsic T_${esc(parent)}_${esc(s.name)}: maps ${esc(s.name)}'s points into ${esc(parent)}`, s.extrinsic)}</div></section>`;
}

/** @param {string} title @param {import('../result').NoteReport[]} notes */
function notesHtml(title, notes) {
  if (!notes.length) return '';
  return `<p>${title}:</p><ul>${notes.map((n) => `<li>${esc(n.sensor)}/${esc(n.frame)}: ${esc(n.reason)}</li>`).join('')}</ul>`;
}

// Ground levelling (gmm): per sensor, the ground found and the tilt applied, or why not.
/** @param {import('../result').LevellingReport[]} levelling */
function levellingHtml(levelling = []) {
  if (!levelling.length) return '';
  const row = (l) => {
    if (l.note) return `<li>${esc(l.sensor)}: ${esc(l.note)}</li>`;
    const tilt = degrees(poseDifference(IDENTITY, l.motion).angle);
    const bev = l.bev
      ? `; seen from above, turned ${degrees(l.bev.yaw).toFixed(1)} deg and shifted ${f(l.bev.shift.slice(0, 2), 2)} m`
      : '';
    return `<li>${esc(l.sensor)}: ground from ${l.inliers} points, moved by ${tilt.toFixed(3)} deg in all${bev}</li>`;
  };
  return `<p title="Before registration, each sensor's ground plane is found and levelled, then a bird's-eye search turns and shifts it onto the reference's; 'moved by' is the whole rotation of those two steps">ground levelling (before registration; "moved by": the whole rotation of levelling and bird's-eye search):</p><ul>${levelling.map(row).join('')}</ul>`;
}

// Which other methods agree with `r` (the library's comparison, a reason of its verdict).
const agreeing = (/** @type {Result} */ r) => {
  const agree = r.verdict.reasons.find((x) => x.kind === 'methods')?.values.agree;
  return Array.isArray(agree) ? agree : [];
};

/** @param {Result[]} results @param {Truth} truth @param {import('../result').MethodFailure[]} failures */
function comparisonHtml(results, truth, failures) {
  const head = `<tr><th>method</th><th>verdict</th><th>agrees with</th><th>sensor</th><th>xyz (m)</th><th>rpy (deg)</th><th>spread xyz (mm)</th><th>spread rpy (deg)</th>${truth ? '<th>error vs truth</th>' : ''}</tr>`;
  const body = results.flatMap((r) => r.sensors.map((s, i) => {
    const e = errorVsTruth(s, truth);
    const first = i === 0 ? `<td class="${r.verdict.level}" data-testid="method-verdict" data-method="${r.method}">${r.verdict.level}</td><td>${agreeing(r).join(', ') || 'none'}</td>` : '<td></td><td></td>';
    return `<tr><td>${r.method}</td>${first}<td>${esc(s.name)}</td><td>${f(s.xyz, 4)}</td><td>${f(s.rpy.map(degrees), 3)}</td>` +
      `<td>${f(s.spread.xyz.map((v) => v * 1000), 1)}</td><td>${f(s.spread.rpy.map(degrees), 3)}</td>` +
      `${e ? `<td>${e.deg.toFixed(3)} deg / ${e.mm.toFixed(1)} mm</td>` : ''}</tr>`;
  }));
  const failed = failures.map((x) => `<tr class="failed"><td>${esc(x.method)}</td><td colspan="${truth ? 8 : 7}">failed: ${esc(x.error)}</td></tr>`);
  return `<table class="compare">${head}${body.join('')}${failed.join('')}</table>`;
}

// A stage's name as the selection reports it, in words; a levelling with the root it levelled
// (every root is levelled).
/** @param {import('../result').HypothesisReport} h @param {import('../result').HypothesisReport[]} all @returns {string} */
const stageText = (h, all) => (h.stage === 'levelled' && h.parent != null && all[h.parent]
  ? `levelled ${stageText(all[h.parent], all)}`
  : ({
    nominal: 'nominal', global: `global candidate ${h.rank + 1}`, levelled: 'levelled',
    jrmpc: 'JRMPC', cad: 'CAD registration', refinedFromNominal: 'refined from the nominal',
    refinedFromStart: 'refined from the start', refined: 'refined',
    refinedOnScene: 'refined on the whole scans', planes: 'plane adjustment',
  })[h.stage] ?? h.stage);

// How far a 4×4 row-major correction moves a sensor: rotation (deg) and translation (m).
function moved(m) {
  const angle = Math.acos(Math.min(1, Math.max(-1, (m[0] + m[5] + m[10] - 1) / 2)));
  return [degrees(angle), Math.hypot(m[3], m[7], m[11])];
}

// How far a hypothesis's ground lies from the other sensors', where they share ground patches.
/** @param {import('../result').GroundReport | null} g */
const groundText = (g) => (g ? `${(1000 * g.height).toFixed(1)} mm / ${degrees(g.tilt).toFixed(3)} deg` : '');

// Every stage's hypothesis per sensor, scored on the whole scans, the chosen first in the
// summary: how the answer was decided.
/** @param {import('../result').SelectionReport[]} selection */
function selectionHtml(selection) {
  if (!selection.length) return '';
  const summary = selection.map((s) => {
    const c = s.hypotheses[s.chosen];
    return `${esc(s.sensor)}: ${stageText(c, s.hypotheses)} (score ${(100 * c.score).toFixed(1)} %; nominal ${(100 * s.hypotheses[0].score).toFixed(1)} %)`;
  }).join('; ');
  const rows = selection.flatMap((s) => s.hypotheses.map((h, i) => {
    const [deg, m] = moved(h.correction);
    const chosen = i === s.chosen;
    return `<tr${chosen ? ' class="chosen"' : ''} data-testid="hypothesis" data-sensor="${esc(s.sensor)}" data-stage="${h.stage}"${chosen ? ' data-chosen' : ''}>` +
      `<td>${i === 0 ? esc(s.sensor) : ''}</td><td>${chosen ? '▶ ' : ''}${stageText(h, s.hypotheses)}</td>` +
      `<td>${(100 * h.score).toFixed(1)} %</td><td>${(100 * h.landing).toFixed(1)} %</td><td>${(100 * h.contradiction).toFixed(1)} %</td><td>${(100 * h.overlap).toFixed(1)} %</td><td>${deg.toFixed(3)} deg / ${m.toFixed(3)} m</td><td>${groundText(h.ground)}</td></tr>`;
  }));
  return `<details class="selection" data-testid="selection"><summary>Selection: ${summary}</summary>
    <p class="hint">Every stage proposes a placement; each is scored on the whole scans by the share of points landing on the other sensors' surfaces (and theirs on its), less three times the share standing where another sensor saw through (its free space: a chance overlay lands points on broad planes, a right one rarely stands in free space), and the rule picks one: never below the nominal, never one whose ground lies apart from the other sensors' (patch by patch) beyond what is usable while another meets it, the latest stage among those the scans cannot tell apart.</p>
    <div class="table-wrap"><table class="compare"><tr><th>sensor</th><th>hypothesis</th><th>score</th><th>landing</th><th>in free space</th><th>overlap</th><th>from the nominal</th><th>grounds apart</th></tr>${rows.join('')}</table></div></details>`;
}

// `results`: one report per method run; the first is shown in detail. `failures`: {method, error}
// of the methods compared that failed. `parent`: the vehicle frame's name; `advice`: what the
// page adds to the verdict ({html, actions}: what to do when no target was found).
/**
 * @param {HTMLElement} container @param {Result[]} results @param {Truth} truth
 * @param {import('../result').MethodFailure[]} [failures]
 * @param {{parent?: string, advice?: {html: string, actions?: {label: string, what: string, value?: string}[]}[]}} [options]
 */
export function renderResults(container, results, truth, failures = [], { parent = 'vehicle', advice = [] } = {}) {
  const r = results[0];
  const t = r.reconstruction;
  const sizeText = (x) => ({ sphere: `diameter ${x.size.toFixed(3)}`, box: `box ${x.extents.map((e) => e.toFixed(3)).join(' × ')}`, mesh: `the model (${x.size.toFixed(2)}`})[x.shape] ?? `edge ${x.size.toFixed(3)}`;
  const fitText = (x) => `${sizeText(x)} m${x.shape === 'mesh' ? ' across)' : ''}, RMS ${(x.rms * 1000).toFixed(1)} mm`;
  const placed = t.placements?.length ? `; the CAD model found standing ${t.placements.length === 1 ? 'once' : `${t.placements.length} times`} in the reference's scans (${t.placements.map((p) => `${(100 * p.inliers).toFixed(0)} % of ${p.points} points within 3 cm`).join(', ')})` : '';
  const fit = t.fits.length
    ? `${t.fits.length === 1 ? 'target' : `${t.fits.length} targets`}: ${t.fits.map(fitText).join('; ')}`
    : t.means.length ? 'no target stands out from the ground' : 'no target reconstructed (none given, or an ICP method)';
  const targetText = fit + placed;
  const compared = results.length + failures.length > 1;
  // A bird's-eye warning the verdict already gives as a reason is not said twice.
  const said = new Set(Object.values(r.verdict.sensors).flatMap((s) => s.reasons.map((x) => x.text)));
  const warnings = /** @type {Record<string, string[]>} */ ({});
  for (const l of (r.levelling ?? []).filter((l) => l.warning && !said.has(l.warning))) (warnings[l.sensor] ??= []).push(l.warning);
  container.innerHTML = `
    ${verdictHtml(r, advice)}
    ${compared ? `<h3>The answer of ${esc(r.method)} (the first method that ran)</h3>` : ''}
    ${answerHtml(r, { truth, parent, warnings })}
    ${selectionHtml(r.selection ?? [])}
    ${compared ? `<details class="compare-box" open><summary>All methods: ${results.length} ran${failures.length ? `, ${failures.length} failed` : ''}</summary><div class="table-wrap">${comparisonHtml(results, truth, failures)}</div></details>` : ''}
    <details class="more"><summary>More: 4×4 matrices and corrections, target fit, ground levelling, notes</summary>
      <p>reference ${esc(r.reference)}; ${targetText}</p>
      ${r.sensors.map((s) => sensorDetailHtml(s, r.reference, parent)).join('')}
      ${levellingHtml(r.levelling)}
      ${notesHtml('views left out', r.skipped)}
      ${notesHtml('joint plane adjustment (every frame)', r.planeAdjustment ?? [])}
      <p class="hint">Notes read <i>sensor/frame: what happened</i>; frame <i>all</i> is a note on every frame of that sensor.</p>
    </details>`;
  wireCopy(container);
}

// Convergence: mean sigma (m, left axis, log) and max transform change (right axis, log).
/** @param {HTMLCanvasElement} canvas @param {import('../result').HistoryReport} history */
export function drawConvergence(canvas, history) {
  const ctx = canvas.getContext('2d');
  const { width: w, height: h } = canvas;
  ctx.clearRect(0, 0, w, h);
  const n = history.meanSigma.length;
  ctx.fillStyle = '#9aa4b1';
  ctx.font = '11px system-ui, sans-serif';
  if (n < 2) {
    ctx.fillText('no EM iterations to plot', 8, 16);
    return;
  }
  const series = [
    { values: history.meanSigma, color: '#7fd1ff', label: 'mean σ (m)' },
    { values: history.maxChange, color: '#ffb054', label: 'max change (rad | m)' },
  ];
  // One legend line per series: side by side they overflow the panel's width.
  const pad = { l: 8, r: 8, t: 32, b: 14 };
  series.forEach(({ values, color, label }, i) => {
    const logs = values.map((v) => Math.log10(Math.max(v, 1e-12)));
    const [lo, hi] = [Math.min(...logs), Math.max(...logs) + 1e-9];
    ctx.strokeStyle = color;
    ctx.beginPath();
    logs.forEach((v, k) => {
      const x = pad.l + (k / (n - 1)) * (w - pad.l - pad.r);
      const y = pad.t + (1 - (v - lo) / (hi - lo)) * (h - pad.t - pad.b);
      k ? ctx.lineTo(x, y) : ctx.moveTo(x, y);
    });
    ctx.stroke();
    ctx.fillStyle = color;
    ctx.fillText(`${label}: ${values[0].toExponential(1)} → ${values[n - 1].toExponential(1)} (log)`, pad.l, 12 + 13 * i);
  });
  ctx.fillStyle = '#9aa4b1';
  ctx.fillText(`iteration 1 … ${n}`, pad.l, h - 2);
}
