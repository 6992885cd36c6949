// Wires the page: DOM events -> state (state.js) -> worker requests (run.js for a calibration)
// -> view, results, exports. Every error goes to one place (showError). The state lives here,
// not in the worker, so a crashed or cancelled worker is replaced without losing the loaded
// files.
import { WorkerClient } from './calibrate/rpc.js';
import { Viewer } from './view/viewer.js';
import { Display, livePoses } from './view/display.js';
import { fromDrop, fromInput } from './files/files.js';
import { renderFiles } from './files/filelist.js';
import { renderRig, showRoi } from './panels/rig.js';
import { drawConvergence, renderResults, verdictTitle } from './results/results.js';
import { exportItems, exportTexts, renderExports, resultJson } from './results/exports.js';
import { targetBounds } from './view/target.js';
import { writeHash } from './state/url.js';
import { describeDone, describeTime } from './calibrate/progress.js';
import { clearState, createState, nominalPoses, rebuildRig, shownPoses, sortScans } from './state/state.js';
import { focusBox, openingBox } from './view/focus.js';
import { initRoiEditor } from './view/roi-editor.js';
import { adviceForError, adviceForResult, autoRoiFound } from './panels/advice.js';
import { runCalibration } from './calibrate/run.js';
import { nextTask } from './calibrate/tasks.js';
import { foldSetup, initInset, initLayout } from './panels/layout.js';
import { initViewTools } from './view/viewtools.js';
import { calibrateBlocker, countLine, describeRig, describeScans } from './panels/summary.js';
import { initSettings } from './panels/settings.js';
import { initDrift } from './results/drift.js';
import { initKeeping } from './state/keep.js';
import { initLoading } from './files/loading.js';

const $ = (id) => document.getElementById(id);
const client = new WorkerClient();
const mainViewer = new Viewer($('view'), { onError: showError, onScale: (scale) => tools.renderScale(scale) });
const display = new Display(mainViewer);
const targetViewer = new Viewer($('target-view'), { grid: false, onError: showError });
const state = createState();
let nextScanId = 1;
initLayout({ main: $('main'), side: $('side'), resizer: $('resizer'), toggle: $('side-toggle') });
const inset = initInset($('inset'), $('inset-close'));
const tools = initViewTools({
  viewer: mainViewer,
  state,
  el: {
    view: $('view'), pointSize: $('point-size'), looks: document.querySelectorAll('[data-look]'), focus: $('focus'),
    legend: $('legend'), measure: $('measure'), save: $('save-png'), readout: $('readout'),
    scale: $('scale'), scaleTitle: $('scale-title'), scaleLo: $('scale-lo'), scaleHi: $('scale-hi'),
  },
  focusBounds: (key) => focusBox(state, key),
  onChange: () => redraw(),
  onError: showError,
  verdictLine: () => {
    const r = state.results?.[0];
    if (!r) return null;
    const out = state.stale ? ` (out of date: the ${state.stale} changed)` : '';
    return { level: r.verdict.level, text: `${verdictTitle(r.verdict.level)}${out} — ${r.method}, reference ${r.reference}` };
  },
});

// The ROI's handles in the view: a drag moves a face, the panel's numbers follow, and the
// result goes out of date once the face is let go.
const roiEditor = initRoiEditor({
  viewer: mainViewer,
  canvas: $('view'),
  wrap: $('view').parentElement,
  getRoi: () => state.rig.roi,
  onDrag: (roi) => {
    state.rig.roi = roi;
    showRoi($('rig'), roi);
    redraw();
  },
  onDrop: (roi) => {
    state.rig.roi = roi;
    rigChanged('roi');
  },
});

const settings = initSettings({ $, state, client, changed, targetLoaded: () => forgetResults(), setStatus: (text) => setStatus(text), showError });
const drift = initDrift($('drift'), (request) => client.request('compare', request));
// What the browser keeps for the next visit, and the link; restored on opening.
const keeping = initKeeping({
  $, state, settings, setNextId: (n) => (nextScanId = n), setStatus: (text) => setStatus(text), renderPanels: () => renderPanels(),
  showResults: (...a) => showResults(...a), setStale: (what) => setStale(what), redraw: () => redraw(), viewerLookAt: () => viewerLookAt(), clearAll: () => clearAll(),
});
const persist = () => keeping.persist();
const { loadFiles } = initLoading({
  $, state, client, settings, nextId: () => `scan:${nextScanId++}`, setStatus: (text) => setStatus(text), showError,
  clearAll: () => clearAll(), showLoaded: (config) => showLoaded(config), showResults: (...a) => showResults(...a),
  forgetResults: () => forgetResults(), setStale: (what) => setStale(what), rigFrom: (config) => rigFrom(config),
  renderPanels: () => renderPanels(), changed: (what) => changed(what), redraw: () => redraw(),
});

// The error line, and under it what to do about it where the page knows (panels/advice.js),
// with its one action as a button.
function showError(error, advice = null) {
  $('error').hidden = !error;
  $('error').textContent = error ? String(error.message ?? error) : '';
  $('error-advice').hidden = !advice;
  $('error-advice').replaceChildren();
  if (!advice) return;
  const button = Object.assign(document.createElement('button'), { type: 'button', textContent: advice.action.label });
  button.addEventListener('click', () => applyAdvice(advice.action));
  $('error-advice').append(`${advice.text} `, button);
}

// An advice's action: make a sensor the reference, set the target, or start drawing the ROI.
function applyAdvice({ what, value }) {
  showError(null);
  if (what === 'reference') {
    state.rig.reference = value;
    $('rig-panel').open = true;
    renderPanels();
    rigChanged('reference');
    setStatus(`${value} is the reference now: Calibrate again.`);
  } else if (what === 'target') {
    settings.setTarget(value);
    setStatus(`The target is ${value} now: Calibrate again.`);
  } else if (what === 'roi') {
    state.rig.roi = startRoi();
    $('rig-panel').open = true;
    renderPanels();
    rigChanged('roi');
    mainViewer.lookAt(state.rig.roi, 'top');
    setStatus('Drag the white handles of the ROI in the view around the targets (or type its bounds), then Calibrate.');
  }
}

// The box a user starts drawing the ROI from: the last auto ROI, else the data's robust extent
// (to the centimetre).
function startRoi() {
  const box = state.results?.[0]?.roi ?? focusBox(state, 'all') ?? { min: [-5, -5, -2], max: [5, 5, 3] };
  const cm = (v) => Math.round(v * 100) / 100;
  return { min: box.min.map(cm), max: box.max.map(cm) };
}
const setStatus = (text) => ($('status').textContent = text);

// --- view -------------------------------------------------------------------------------------

function redraw(poses = shownPoses(state), options) {
  display.update(state, poses, options);
  roiEditor.update();
  if (!options?.preview) persist();
}

// --- loading ----------------------------------------------------------------------------------

function forgetResults() {
  Object.assign(state, { results: null, failures: [], resultJson: null });
  setStale(null);
  inset.show(false);
  $('convergence-box').hidden = true;
  tools.renderFocus();
  state.show = 'before';
  document.querySelector('input[name=show][value=before]').checked = true;
  $('show-after').disabled = true;
  $('result-json').textContent = '';
  $('results').innerHTML = '<p class="hint">No result yet.</p>';
  $('exports').innerHTML = '<p class="hint">After a run.</p>';
  targetViewer.clear();
  drift.setResult(null);
}

// A result that no longer matches the scans, rig or settings stays readable, marked out of date
// (`what` changed); null: current again.
function setStale(what) {
  state.stale = what;
  $('stale').hidden = !what;
  $('stale').textContent = what ? `Out of date: the ${what} changed after this run. Calibrate again for a current result.` : '';
  $('results').classList.toggle('out-of-date', Boolean(what));
  drift.setStale(what);
}

function changed(what) {
  if (state.results && !state.running) {
    setStale(what);
    setStatus(`The ${what} changed: the result below is out of date. Calibrate again.`);
  }
  updateSummaries();
  updateCalibrate();
  persist();
}

function rigFrom(config) {
  rebuildRig(state, config);
  settings.sync();
}

// New scans are in: the rig from them and `config`, no result, every panel and the view anew.
function showLoaded(config) {
  rigFrom(config);
  forgetResults();
  renderPanels();
  redraw();
  viewerLookAt();
}

function renderPanels() {
  renderFiles($('files'), { scans: state.scans, bad: state.bad, sensors: state.rig.sensors }, reassign);
  if (state.rig.sensors.length) renderRigPanel();
  tools.renderLegend();
  tools.renderFocus();
  updateSummaries();
  updateCalibrate();
}

const renderRigPanel = () => renderRig($('rig'), state.rig, rigChanged, { found: autoRoiFound(state.results?.[0], state.resultContext), startRoi });

function updateSummaries() {
  $('load-summary').textContent = describeScans(state);
  $('rig-summary').textContent = describeRig(state);
}

// Calibrate is enabled when a run can start; when not, the line beside it says why.
function updateCalibrate() {
  const why = state.running ? '' : calibrateBlocker(state);
  $('calibrate').disabled = state.running || Boolean(why);
  $('calibrate-why').textContent = why;
}

function reassign(scan, sensor, frame = scan.frame) {
  const what = sensor !== scan.sensor ? 'sensors' : 'frames';
  // Placed by hand: the library's placement leaves it so when more files come.
  Object.assign(scan, { sensor, frame, manual: true });
  sortScans(state);
  rigFrom();
  renderPanels();
  // The count first: it is what the reassignment changed (a stale result's line follows).
  setStatus(`${countLine(state)} loaded; ${scan.path} is now ${sensor}'s, frame ${frame}.`);
  changed(what);
  redraw();
}

function rigChanged(what) {
  // The vehicle frame's name changes no number: the result and its exports take it at once.
  if (what === 'parent') {
    if (state.results) renderOutcome(state.results, state.failures ?? [], state.resultJson);
    updateSummaries();
    return;
  }
  changed({ reference: 'reference sensor', roi: 'ROI', nominal: 'nominal extrinsics' }[what] ?? 'rig');
  redraw();
}

function clearAll() {
  clearState(state);
  display.clear();
  forgetResults();
  $('rig').innerHTML = '<p class="hint">Load scans first.</p>';
  $('recording').replaceChildren();
  $('loose').replaceChildren();
  $('progress').value = 0;
  state.hidden.clear();
  tools.clearPicks();
  drift.clear();
  renderPanels();
}

async function loadDemo() {
  showError(null);
  const s = state.settings;
  s.demo = $('demo-preset').value || 'paper';
  s.seed = Number($('demo-seed').value);
  s.frames = Number($('demo-frames').value);
  writeHash(s, state.rig);
  setStatus(`Simulating ${s.frames} frames of the ${s.demo} rig…`);
  $('demo').disabled = true;
  try {
    const options = { preset: s.demo, frames: s.frames, seed: s.seed, maxAngleDeg: s.maxAngleDeg, maxTranslation: s.maxTranslation };
    const rig = await client.request('simulate', { options });
    clearAll();
    state.scans = rig.scans.map((v) => ({ id: `scan:${nextScanId++}`, path: `${v.sensor}_${v.frame}`, sensor: v.sensor, frame: v.frame, points: v.points, count: v.points.length / 3, dropped: v.dropped, format: 'simulated' }));
    state.truth = rig.truth;
    // The scene's own target: its cube, its CAD model, or none.
    if (rig.targetObj) await settings.loadTargetMesh({ path: 'target.obj', file: new Blob([rig.targetObj]) });
    else state.settings.target = rig.target;
    rigFrom({ nominal: rig.nominal, roi: rig.roi, reference: rig.reference });
    renderPanels();
    redraw();
    viewerLookAt();
    setStatus(`Demo: ${s.demo} rig, seed ${s.seed}, ${s.frames} frames; every non-reference sensor miscalibrated. Calibrate next.`);
  } catch (error) {
    setStatus('Demo failed.');
    showError(error);
  } finally {
    $('demo').disabled = state.running;
  }
}

// --- run --------------------------------------------------------------------------------------

function setRunning(running) {
  state.running = running;
  $('cancel').disabled = !running;
  $('demo').disabled = running;
  updateCalibrate();
}

// During a run the moving clouds take at most this share of the time to draw: on a GPU a frame
// takes a few ms and every progress message (ten a second) redraws; with software rendering
// (SwiftShader here: 50-300 ms a frame) redrawing on each took the workers' cores.
const PREVIEW_SHARE = 0.2;

async function calibrate() {
  showError(null);
  forgetResults();
  setRunning(true);
  // What the advice on the result needs to know of the run: the target and the ROI it had.
  state.resultContext = { target: state.settings.target, roiAuto: !state.rig.roi };
  const nominal = nominalPoses(state);
  const started = performance.now();
  $('progress').value = 0;
  $('progress-time').textContent = '';
  setStatus('starting…');
  try {
    let drawnAt = -Infinity;
    const { results, failures, json } = await runCalibration(client, state, ({ fraction, text, elapsed, left, progress }) => {
      // The bar never goes back (a tick's estimate may run ahead of the next message).
      $('progress').value = Math.max($('progress').value, fraction);
      $('progress-time').textContent = describeTime({ elapsed, left });
      // A tick says what a silent stage does; a message, what the stage reports.
      if (text && text !== $('status').textContent) setStatus(text);
      if (!progress) return;
      if (performance.now() - drawnAt >= mainViewer.frameMs / PREVIEW_SHARE) {
        drawnAt = performance.now();
        redraw(livePoses(progress, nominal), { preview: true });
      }
    });
    $('progress').value = 1;
    $('progress-time').textContent = '';
    await showResults(results, failures, json);
    setStatus(describeDone(results, (performance.now() - started) / 1000, failures));
  } catch (error) {
    $('progress').value = 0;
    $('progress-time').textContent = '';
    setStatus(error.cancelled ? 'Cancelled.' : 'Failed.');
    if (!error.cancelled) showError(error, adviceForError(String(error.message ?? error), state));
    redraw();
  } finally {
    setRunning(false);
  }
}

// A result in (`results` the reports that ran; `failures` {method, error} of the methods that
// failed; `json` what the JSON view holds: the report, or every method's outcome in order when
// comparing, as the CLI writes it): the view shows the calibrated poses, the setup panels fold to
// their one-line summaries so the verdict and the extrinsics are in view.
async function showResults(results, failures, json) {
  Object.assign(state, { results, failures, resultJson: json });
  state.show = 'after';
  $('show-after').disabled = false;
  $('show-after').checked = true;
  redraw();
  foldSetup([$('load-panel'), $('rig-panel')], $('side'));
  await renderOutcome(results, failures, json);
}

// Everything a result shows, in three tasks of a few ms each: on a busy machine a task waits for
// a core several times as long as it computes, and the page must not stall. A result
// forgotten meanwhile (new files, a new run) stops here.
async function renderOutcome(results, failures, json) {
  const parent = state.rig.parent;
  renderResults($('results'), results, state.truth, failures, { parent, advice: adviceForResult(results[0], state.resultContext) });
  // What the result changes elsewhere: what ROI auto held (the rig panel) and the targets to
  // focus on; the file table stays as it is.
  if (!state.rig.roi && state.rig.sensors.length) renderRigPanel();
  tools.renderFocus();
  await nextTask();
  if (state.results !== results) return;
  $('convergence-box').hidden = results[0].history.meanSigma.length < 2;
  drawConvergence($('convergence'), results[0].history);
  const remake = (input) => client.request('exports', input);
  const items = exportItems(await exportTexts(results[0], parent, remake));
  if (state.results !== results) return;
  renderExports($('exports'), items);
  // The drift check compares what the JSON export holds.
  drift.setResult(items.find((item) => item.key === 'json').text);
  await nextTask();
  if (state.results !== results) return;
  $('result-json').textContent = resultJson(json);
  const gmm = results.find((r) => r.reconstruction.priors.length);
  targetViewer.clear();
  const bounds = gmm && targetBounds(gmm.reconstruction);
  if (bounds) {
    targetViewer.setTarget('target', gmm.reconstruction);
    targetViewer.lookAt(bounds);
  }
  inset.show(Boolean(bounds));
}

// --- controls ---------------------------------------------------------------------------------

function viewerLookAt() {
  const box = openingBox(state);
  if (box) mainViewer.lookAt(box);
}

$('file-input').addEventListener('change', async (e) => {
  await loadFiles(fromInput(e.target.files));
  e.target.value = '';
});
$('folder-input').addEventListener('change', async (e) => {
  await loadFiles(fromInput(e.target.files));
  e.target.value = '';
});
$('clear').addEventListener('click', async () => {
  clearAll();
  await keeping.forget();
  setStatus('Cleared: the scans, the rig and the result are forgotten, also in this browser\'s storage.');
});
// The link to this page with its settings and rig (and a demo's parameters), copied.
$('copy-link').addEventListener('click', async () => {
  writeHash(state.settings, state.rig);
  try {
    await navigator.clipboard.writeText(location.href);
    setStatus(`Link copied: ${location.href}${state.scans.length && !state.settings.demo ? ' (it holds the settings; the scans stay in this browser)' : ''}`);
  } catch (error) {
    showError(`Could not copy the link (${error.message}); it is the address in the address bar.`);
  }
});
$('demo').addEventListener('click', loadDemo);
$('results').addEventListener('click', (e) => {
  const button = e.target.closest('button[data-advice]');
  if (button) applyAdvice(JSON.parse(button.dataset.advice));
});
$('calibrate').addEventListener('click', calibrate);
$('cancel').addEventListener('click', () => client.cancel());
for (const radio of document.querySelectorAll('input[name=show]')) {
  radio.addEventListener('change', () => {
    state.show = radio.value;
    redraw();
  });
}
$('colour').addEventListener('change', () => {
  state.colour = $('colour').value;
  tools.renderLegend();
  redraw();
});
$('all-frames').addEventListener('change', () => {
  state.allFrames = $('all-frames').checked;
  redraw();
});
document.addEventListener('dragover', (e) => {
  e.preventDefault();
  document.body.classList.add('dragging');
});
document.addEventListener('dragleave', (e) => {
  if (!e.relatedTarget) document.body.classList.remove('dragging');
});
document.addEventListener('drop', async (e) => {
  e.preventDefault();
  document.body.classList.remove('dragging');
  await loadFiles(await fromDrop(e.dataTransfer));
});

// The method picker lists what the library offers (and compare all).
async function loadMethods() {
  state.methods = await client.request('methods', {});
  const options = state.methods.map((m) => new Option(m.label, m.name));
  $('method').replaceChildren(...options, new Option('compare all', 'all'));
  $('method').value = state.settings.method;
}

settings.sync();
updateCalibrate();
keeping.start(loadMethods, loadDemo).catch(showError);
