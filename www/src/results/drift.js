// @ts-check
// The drift check in the results: a stored calibration (our JSON, its tf YAML
// export, or the exported URDF), picked or dropped on the control, compared with the current result
// by the library (`compareCalibrations`, the same check as `gmmcalib drift`), against fixed
// limits or K sigma of the combined precision. Per sensor the rotation and translation change,
// the precision, the limit and moved / within; the outcome in the library's words. A comparison
// outlives the result it was made with, marked out of date, so Compare again is one click.
import { degrees } from '../transforms.js';
import { esc } from './answer.js';

// Names the library puts in its error messages for the current side.
const CURRENT_NAME = 'the current result';

const CONTROLS = `
  <h3>Has a sensor moved? Drift check</h3>
  <div class="buttons drift-drop" data-testid="drift-drop" title="Pick or drop a stored calibration here: our result JSON, its /tf_static YAML export, or the exported URDF">
    <label class="button">Compare with a stored calibration… <input data-testid="drift-input" type="file" accept=".json,.urdf,.xml,.yaml,.yml" hidden /></label>
    <button type="button" data-testid="drift-again" disabled title="Compare the same stored file with the current result and limits">Compare again</button>
    <span class="hint" data-testid="drift-file"></span>
  </div>
  <div class="settings drift-tolerance">
    <label title="A sensor whose rotation changed by more than this angle has moved; empty: the library's default">rotation (deg) <input name="rotationDeg" type="number" min="0" step="0.01" placeholder="default" /></label>
    <label title="A sensor whose position changed by more than this distance has moved; empty: the library's default">translation (cm) <input name="translationCm" type="number" min="0" step="0.1" placeholder="default" /></label>
    <label title="Instead: moved when the change on any axis exceeds K times the combined one-sigma precision of both calibrations (the limits above for a sensor without a precision)"><input name="useSigmas" type="checkbox" /> or K sigma</label>
    <label title="K: how many combined sigmas count as moved">K <input name="sigmas" type="number" min="0" step="0.5" value="3" disabled /></label>
  </div>
  <p class="stale" data-testid="drift-stale" hidden></p>
  <p class="error" data-testid="drift-error" role="alert" hidden></p>
  <div data-testid="drift-result" aria-live="polite"></div>`;

const mm = (/** @type {number} */ m) => (m * 1000).toFixed(1);
const max = (/** @type {number[]} */ v) => Math.max(...v);

// Limits and precisions read "deg / mm" (the columns say so); a per-axis one by its largest axis.
/** @param {import('../result').LimitReport} limit */
function limitText(limit) {
  if (limit.kind === 'fixed') return `${degrees(limit.rotation).toFixed(3)} / ${mm(limit.translation)}`;
  return `${limit.sigmas}σ: ${degrees(max(limit.rotation)).toFixed(3)} / ${mm(max(limit.position))}`;
}

/** @param {import('../result').SensorDriftReport} s */
function sensorRow(s) {
  const precision = s.precision ? `${degrees(max(s.precision.rotation)).toFixed(4)} / ${mm(max(s.precision.position))}` : 'none';
  return `<tr data-testid="drift-sensor" data-sensor="${esc(s.name)}" data-moved="${s.moved}" class="${s.moved ? 'moved' : 'within'}">
    <td>${esc(s.name)}</td><td>${degrees(s.angle).toFixed(3)}</td><td>${mm(s.distance)}</td><td>${precision}</td><td>${limitText(s.limit)}</td>
    <td${s.unresolved ? ' title="Beyond the limit, but within 3 sigma of both calibrations\' precision: they cannot tell this change from their own scatter"' : ''}>${s.moved ? 'moved' : s.unresolved ? 'within their scatter' : 'within'}</td></tr>`;
}

// The comparison: the outcome first (the library's findings: what moved, and what changed
// beyond the limit within both calibrations' scatter), then the table.
/** @param {import('../result').DriftReport} report @param {string} storedName */
function reportHtml(report, storedName) {
  const n = report.sensors.length;
  const outcome = report.passed
    ? [`No sensor moved since ${storedName}: ${n} sensor${n === 1 ? '' : 's'} within the limits relative to ${report.reference}.`, ...report.findings]
    : report.findings;
  const added = report.added.map((name) => `${name} is not in ${storedName}: not compared.`);
  const head = `<tr><th title="The sensor, compared by its pose relative to the reference">sensor</th>
    <th title="Rotation change: the angle from the stored mount to the current one">rotation (deg)</th>
    <th title="Translation change: the distance from the stored position to the current one">translation (mm)</th>
    <th title="The current result's one-sigma precision, rotation / position, largest axis (gmm only)">1σ (deg / mm)</th>
    <th title="What counts as moved for this sensor: an angle / a distance, or K sigma of the combined precision per axis (largest axis shown)">limit (deg / mm)</th>
    <th title="Beyond the limit (moved), or not (within); beyond a fixed limit yet within 3 sigma of both calibrations' precision is within their scatter">moved?</th></tr>`;
  return `<div class="drift-outcome ${report.passed ? 'passed' : 'failed'}" data-testid="drift-outcome" data-passed="${report.passed}">
      ${outcome.map((line) => `<p>${esc(line)}</p>`).join('')}${added.map((line) => `<p class="hint">${esc(line)}</p>`).join('')}
    </div>
    ${n ? `<div class="table-wrap"><table class="drift-table">${head}${report.sensors.map(sensorRow).join('')}</table></div>` : ''}`;
}

// `root`: the section to build in; `compare({stored, storedName, current, currentName,
// tolerance})`: the worker's `compare` request. Returns the hooks main.js calls.
export function initDrift(root, compare) {
  root.innerHTML = CONTROLS;
  const el = (testid) => root.querySelector(`[data-testid=${testid}]`);
  const input = (name) => root.querySelector(`[name=${name}]`);
  let current = null; // the current result's JSON, as exported
  let stored = null; // {text, name}: the stored calibration last picked
  let shownWith = null; // the current JSON the shown comparison was made with

  const setError = (message) => {
    el('drift-error').hidden = !message;
    el('drift-error').textContent = message ?? '';
  };
  const setOutdated = (why) => {
    el('drift-stale').hidden = !why;
    el('drift-stale').textContent = why ? `Out of date: ${why}. Compare again for the current result.` : '';
    el('drift-result').classList.toggle('out-of-date', Boolean(why));
  };
  const update = () => {
    root.hidden = !current && !shownWith;
    input('sigmas').disabled = !input('useSigmas').checked;
    el('drift-input').disabled = !current;
    el('drift-again').disabled = !(current && stored);
    el('drift-file').textContent = stored ? stored.name : '';
  };

  // Empty fields leave the library's defaults; the library checks the numbers.
  const tolerance = () => {
    const value = (name) => (input(name).value === '' ? undefined : Number(input(name).value));
    const cm = value('translationCm');
    return {
      rotationDeg: value('rotationDeg'),
      translation: cm === undefined ? undefined : cm / 100,
      sigmas: input('useSigmas').checked ? value('sigmas') : undefined,
    };
  };

  async function run() {
    if (!current || !stored) return;
    const made = current;
    setError(null);
    try {
      const report = await compare({ stored: stored.text, storedName: stored.name, current: made, currentName: CURRENT_NAME, tolerance: tolerance() });
      if (made !== current) return; // a new result arrived meanwhile
      el('drift-result').innerHTML = reportHtml(report, stored.name);
      shownWith = made;
      setOutdated(null);
      // Once the library has said its defaults, the empty fields show them.
      const fixed = report.sensors.find((s) => s.limit.kind === 'fixed')?.limit;
      if (fixed && input('rotationDeg').value === '') input('rotationDeg').placeholder = `${+degrees(fixed.rotation).toFixed(6)}`;
      if (fixed && input('translationCm').value === '') input('translationCm').placeholder = `${+(fixed.translation * 100).toFixed(6)}`;
    } catch (error) {
      // A bad file or limit: the library's words (file, place, problem); the result stays.
      el('drift-result').replaceChildren();
      shownWith = null;
      setOutdated(null);
      setError(error.message ?? String(error));
    }
    update();
  }

  async function pick(file) {
    if (!file) return;
    stored = { text: await file.text(), name: file.name };
    await run();
  }

  el('drift-input').addEventListener('change', async (e) => {
    await pick(e.target.files[0]);
    e.target.value = '';
  });
  // A file dropped on the control is a stored calibration, not scans for the page.
  const drop = el('drift-drop');
  drop.addEventListener('dragover', (e) => {
    e.preventDefault();
    e.stopPropagation();
    drop.classList.add('dropping');
  });
  drop.addEventListener('dragleave', () => drop.classList.remove('dropping'));
  drop.addEventListener('drop', async (e) => {
    e.preventDefault();
    e.stopPropagation();
    drop.classList.remove('dropping');
    document.body.classList.remove('dragging');
    if (!current) setError('No current result to compare with: calibrate first.');
    else await pick(e.dataTransfer.files[0]);
  });
  el('drift-again').addEventListener('click', run);
  for (const name of ['rotationDeg', 'translationCm', 'useSigmas', 'sigmas']) {
    input(name).addEventListener('change', () => {
      update();
      if (shownWith && shownWith === current) run(); // new limits, same files: compare at once
    });
  }
  update();

  return {
    // The current result's JSON (null: none, a run under way or the result forgotten). A
    // comparison made with another result stays, marked out of date.
    setResult(json) {
      current = json;
      if (shownWith && shownWith !== json) setOutdated('it compared an earlier result');
      update();
    },
    // The result's scans, rig or settings changed (main.js's stale marking): so did what was compared.
    setStale(what) {
      if (what && shownWith) setOutdated(`the ${what} changed after the run it compared`);
    },
    // Clear: forget the stored file and the comparison.
    clear() {
      current = stored = shownWith = null;
      el('drift-result').replaceChildren();
      setError(null);
      setOutdated(null);
      update();
    },
  };
}
