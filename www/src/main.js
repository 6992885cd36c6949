// Wires the page: inputs and panels -> state -> worker requests -> view, results, exports.
// Every error goes to one place (showError). The state lives here, not in the worker, so a
// crashed or cancelled worker is replaced without losing the loaded files.
import { WorkerClient } from './rpc.js';
import { Viewer } from './viewer.js';
import { Display, livePoses, sensorColour } from './display.js';
import { fromDrop, fromInput, natural, pair, readEntries } from './files.js';
import { renderFiles } from './filelist.js';
import { renderRig } from './rig.js';
import { drawConvergence, renderResults } from './results.js';
import { exportsOf, renderExports, resultJson } from './exports.js';
import { targetBounds } from './target.js';
import { matrixFromXyzRpy } from './transforms.js';
import { DEFAULTS, readHash, writeHash } from './url.js';
import { describeDone, describeProgress } from './progress.js';

const $ = (id) => document.getElementById(id);
const client = new WorkerClient();
const mainViewer = new Viewer($('view'), { onError: showError });
const display = new Display(mainViewer);
const targetViewer = new Viewer($('target-view'), { grid: false, onError: showError });
const METHODS = ['gmm', 'jrmpc', 'p2p', 'p2l', 'gicp'];

const state = {
  settings: readHash(),
  views: [], // {id, path, sensor, frame, points, intensity?, count, dropped, format}
  bad: [], // {path, error}
  rig: { sensors: [], nominal: {}, roi: null, reference: '' },
  truth: null, // sensor -> {xyz, rpy}, for a demo
  results: null, // reports of the last run, one per method
  show: 'before',
  colour: 'sensor',
  allFrames: false,
  running: false,
};
let nextViewId = 1;

function showError(error) {
  $('error').hidden = !error;
  $('error').textContent = error ? String(error.message ?? error) : '';
}
const setStatus = (text) => ($('status').textContent = text);
const nextTask = () => new Promise((resolve) => setTimeout(resolve));

// --- view -------------------------------------------------------------------------------------

const nominalPoses = () =>
  Object.fromEntries(state.rig.sensors.map((s) => [s, matrixFromXyzRpy(state.rig.nominal[s].xyz, state.rig.nominal[s].rpy)]));

function shownPoses() {
  const poses = nominalPoses();
  if (state.show === 'after' && state.results) for (const s of state.results[0].sensors) poses[s.name] = s.extrinsic;
  return poses;
}

const redraw = (poses = shownPoses(), options) => display.update(state, poses, options);

function renderLegend() {
  $('legend').replaceChildren(...state.rig.sensors.map((s, i) => {
    const span = document.createElement('span');
    span.textContent = `● ${s}`;
    span.style.color = `#${sensorColour(i).toString(16).padStart(6, '0')}`;
    return span;
  }));
}

// --- loading ----------------------------------------------------------------------------------

function forgetResults() {
  state.results = null;
  state.show = 'before';
  document.querySelector('input[name=show][value=before]').checked = true;
  $('show-after').disabled = true;
  $('result-json').textContent = '';
  $('results').innerHTML = '<p class="hint">No result yet.</p>';
  $('exports').replaceChildren();
  targetViewer.clear();
  drawConvergence($('convergence'), { meanSigma: [], maxChange: [] });
}

// Sensors from the views (natural order); nominal, ROI and reference kept or defaulted.
function rebuildRig(config = {}) {
  const rig = state.rig;
  rig.sensors = [...new Set(state.views.map((v) => v.sensor))].sort(natural);
  for (const [name, pose] of Object.entries(config.nominal ?? {})) rig.nominal[name] = { xyz: [...pose.xyz], rpy: [...pose.rpy] };
  for (const s of rig.sensors) rig.nominal[s] ??= { xyz: [0, 0, 0], rpy: [0, 0, 0] };
  if (config.roi) rig.roi = { min: [...config.roi.min], max: [...config.roi.max] };
  rig.roi ??= { min: [-5, -5, -2], max: [5, 5, 3] };
  if (config.reference) rig.reference = String(config.reference);
  if (!rig.sensors.includes(rig.reference)) rig.reference = rig.sensors[0] ?? '';
  for (const [key, value] of Object.entries(config)) if (key in DEFAULTS) state.settings[key] = value;
  syncSettingsInputs();
}

function renderPanels() {
  renderFiles($('files'), { views: state.views, bad: state.bad, sensors: state.rig.sensors }, reassign);
  if (state.rig.sensors.length) renderRig($('rig'), state.rig, rigChanged);
  renderLegend();
  $('calibrate').disabled = state.running || state.rig.sensors.length < 2;
}

function reassign(view, sensor, frame = view.frame) {
  Object.assign(view, { sensor, frame });
  state.views.sort((a, b) => natural(a.sensor, b.sensor) || natural(a.frame, b.frame));
  rebuildRig();
  forgetResults();
  renderPanels();
  redraw();
}

function rigChanged(what) {
  if (what !== 'reference') forgetResults();
  redraw();
}

async function loadFiles(entries) {
  showError(null);
  if (!entries.length) return;
  if (state.truth) clearAll(); // user files replace a demo
  const parse = (bytes, name) => client.request('parse', { bytes, name }, { transfer: [bytes] });
  const { scans, bad, config } = await readEntries(entries, parse, (path, i, n) => setStatus(`Reading ${path} (${i}/${n})…`));
  const paths = new Set(scans.map((s) => s.path));
  const fresh = scans.map((s) => ({ id: `view:${nextViewId++}`, ...s }));
  state.views = [...state.views.filter((v) => !paths.has(v.path)), ...fresh];
  const paired = pair(state.views, fresh);
  state.bad.push(...bad);
  state.views.sort((a, b) => natural(a.sensor, b.sensor) || natural(a.frame, b.frame));
  state.settings.demo = '';
  writeHash(state.settings);
  rebuildRig(config);
  forgetResults();
  renderPanels();
  redraw();
  viewerLookAt();
  const sensors = state.rig.sensors.length;
  setStatus(`${state.views.length} scans of ${sensors} sensor${sensors === 1 ? '' : 's'} loaded${paired ? ` (${paired})` : ''}${state.bad.length ? `, ${state.bad.length} file(s) with problems` : ''}.`);
  if (state.bad.length) showError(state.bad.map((b) => `${b.path}: ${b.error}`).join('\n'));
}

function clearAll() {
  Object.assign(state, { views: [], bad: [], truth: null, rig: { sensors: [], nominal: {}, roi: null, reference: '' } });
  display.clear();
  forgetResults();
  $('rig').innerHTML = '<p class="hint">Load scans first.</p>';
  renderPanels();
}

async function loadDemo() {
  showError(null);
  const s = state.settings;
  s.demo = $('demo-preset').value || 'paper';
  s.seed = Number($('demo-seed').value);
  s.frames = Number($('demo-frames').value);
  writeHash(s);
  setStatus(`Simulating ${s.frames} frames of the ${s.demo} rig…`);
  $('demo').disabled = true;
  try {
    const options = { preset: s.demo, frames: s.frames, seed: s.seed, maxAngleDeg: s.maxAngleDeg, maxTranslation: s.maxTranslation };
    const rig = await client.request('simulate', { options });
    clearAll();
    state.views = rig.views.map((v) => ({ id: `view:${nextViewId++}`, path: `${v.sensor}_${v.frame}`, sensor: v.sensor, frame: v.frame, points: v.points, count: v.points.length / 3, dropped: v.dropped, format: 'simulated' }));
    state.truth = rig.truth;
    rebuildRig({ nominal: rig.nominal, roi: rig.roi, reference: rig.reference });
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

// The views are copied (the originals stay loaded, whatever happens to the worker) one per task:
// copying millions of points at once would block the page for 100 ms and more.
async function calibrateInput(method) {
  const s = state.settings;
  const views = [];
  for (const v of [...state.views]) {
    views.push({ sensor: v.sensor, frame: v.frame, points: v.points.slice() });
    await nextTask();
  }
  const input = {
    views,
    nominal: Object.fromEntries(state.rig.sensors.map((n) => [n, state.rig.nominal[n]])),
    roi: state.rig.roi,
    reference: state.rig.reference,
    method,
    target: { kind: 'cube', edge: s.edge },
    components: s.components,
    iterations: s.iterations,
    initialSigma: s.initialSigma,
  };
  return { input, transfer: views.map((v) => v.points.buffer) };
}

// Workers sharing the registration: one per core (the page's own thread mostly waits), at
// most 4; a single core runs it in the calibration worker alone.
function workerCount(setting) {
  const n = setting === 'auto' ? Math.min(navigator.hardwareConcurrency || 1, 4) : Number(setting);
  return Number.isInteger(n) && n >= 1 ? n : 1;
}

function setRunning(running) {
  state.running = running;
  $('cancel').disabled = !running;
  $('demo').disabled = running;
  $('calibrate').disabled = running || state.rig.sensors.length < 2;
}

async function runCalibration() {
  showError(null);
  forgetResults();
  setRunning(true);
  const methods = state.settings.method === 'all' ? METHODS : [state.settings.method];
  // Per method, in order: its report, or {method, error} when comparing and it failed. A method
  // that fails is then a finding like any other: the others still run and are shown.
  const outcomes = [];
  const nominal = nominalPoses();
  const started = performance.now();
  try {
    for (const method of methods) {
      const done = outcomes.length;
      const label = methods.length > 1 ? `${method} (${done + 1}/${methods.length}): ` : '';
      setStatus(`${label}starting…`);
      const { input, transfer } = await calibrateInput(method);
      // A stage starts at the method's start or at the previous stage's last message.
      let stage = { name: null, started: performance.now() };
      let lastMessage = stage.started;
      const request = client.request('calibrate', { input, workers: workerCount(state.settings.workers) }, {
        transfer,
        onProgress: (p) => {
          const now = performance.now();
          if (p.stage !== stage.name) stage = { name: p.stage, started: stage.name ? lastMessage : stage.started };
          lastMessage = now;
          const { fraction, text } = describeProgress(method, p, (now - stage.started) / 1000);
          $('progress').value = (done + fraction) / methods.length;
          setStatus(label + text);
          redraw(livePoses(p, nominal), { preview: true });
        },
      });
      if (methods.length === 1) {
        outcomes.push(await request);
        continue;
      }
      outcomes.push(await request.catch((error) => {
        if (error.cancelled) throw error;
        return { method, error: error.message };
      }));
    }
    const results = outcomes.filter((o) => !o.error);
    const failures = outcomes.filter((o) => o.error);
    if (!results.length) throw new Error(failures.map((f) => `${f.method}: ${f.error}`).join('\n'));
    $('progress').value = 1;
    await showResults(results, failures, methods.length > 1 ? outcomes : results[0]);
    setStatus(describeDone(results, (performance.now() - started) / 1000, failures));
  } catch (error) {
    $('progress').value = 0;
    setStatus(error.cancelled ? 'Cancelled.' : 'Failed.');
    if (!error.cancelled) showError(error);
    redraw();
  } finally {
    setRunning(false);
  }
}

// In three tasks of a few ms each: on a busy machine a task waits for a core several times as
// long as it computes, and the page must not stall (issue 7). A result forgotten meanwhile (new
// files, a new run) stops here.
// `failures`: {method, error} of the methods that failed; `json`: what the JSON view holds (the
// report, or every method's outcome in order when comparing, as the CLI writes it).
async function showResults(results, failures, json) {
  state.results = results;
  state.show = 'after';
  $('show-after').disabled = false;
  $('show-after').checked = true;
  redraw();
  renderResults($('results'), results, state.truth, failures);
  await nextTask();
  if (state.results !== results) return;
  drawConvergence($('convergence'), results[0].history);
  renderExports($('exports'), exportsOf(results[0], { roi: state.rig.roi }));
  await nextTask();
  if (state.results !== results) return;
  $('result-json').textContent = resultJson(json);
  const gmm = results.find((r) => r.target.priors.length);
  targetViewer.clear();
  const bounds = gmm && targetBounds(gmm.target);
  if (bounds) {
    targetViewer.setTarget('target', gmm.target, { kind: 'cube' });
    targetViewer.lookAt(bounds);
  }
}

// --- controls ---------------------------------------------------------------------------------

const SETTING_INPUTS = ['method', 'edge', 'components', 'iterations', 'initialSigma', 'workers'];

function syncSettingsInputs() {
  for (const key of SETTING_INPUTS) $(key).value = state.settings[key];
  if (state.settings.demo) $('demo-preset').value = state.settings.demo; // else the last one picked
  $('demo-seed').value = state.settings.seed;
  $('demo-frames').value = state.settings.frames;
}

for (const key of SETTING_INPUTS) {
  $(key).addEventListener('change', () => {
    const el = $(key);
    const value = el.type === 'number' ? Number(el.value) : el.value;
    if (el.type === 'number' && !(Number.isFinite(value) && value > 0)) {
      el.value = state.settings[key];
      return;
    }
    state.settings[key] = value;
    writeHash(state.settings);
  });
}

function viewerLookAt() {
  if (state.rig.roi) mainViewer.lookAt(state.rig.roi);
}

$('file-input').addEventListener('change', async (e) => {
  await loadFiles(fromInput(e.target.files));
  e.target.value = '';
});
$('folder-input').addEventListener('change', async (e) => {
  await loadFiles(fromInput(e.target.files));
  e.target.value = '';
});
$('clear').addEventListener('click', () => {
  clearAll();
  setStatus('Cleared.');
});
$('demo').addEventListener('click', loadDemo);
$('calibrate').addEventListener('click', runCalibration);
$('cancel').addEventListener('click', () => client.cancel());
for (const radio of document.querySelectorAll('input[name=show]')) {
  radio.addEventListener('change', () => {
    state.show = radio.value;
    redraw();
  });
}
$('colour').addEventListener('change', () => {
  state.colour = $('colour').value;
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

syncSettingsInputs();
drawConvergence($('convergence'), { meanSigma: [], maxChange: [] });
if (state.settings.demo) loadDemo();
