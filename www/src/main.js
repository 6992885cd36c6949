// Wires the page: inputs -> worker requests -> result table and JSON. Every error goes to one
// place (showError); the worker is replaced after a crash or a cancel, nothing else is lost.
import { WorkerClient } from './rpc.js';
import { matrixFromXyzRpy, poseDifference, degrees, rows } from './transforms.js';

const $ = (id) => document.getElementById(id);
const client = new WorkerClient();

function showError(error) {
  $('error').hidden = !error;
  $('error').textContent = error ? String(error.message ?? error) : '';
}

function setRunning(running) {
  $('demo').disabled = running;
  $('cancel').disabled = !running;
}

// The result in the CLI's --json shape: 4x4 matrices as rows, typed arrays as plain arrays.
function resultJson(result) {
  const triples = (a) => Array.from({ length: a.length / 3 }, (_, i) => Array.from(a.slice(i * 3, i * 3 + 3)));
  return {
    method: result.method,
    reference: result.reference,
    iterations: result.iterations,
    converged: result.converged,
    sensors: result.sensors.map((s) => ({
      ...s,
      correction: rows(s.correction),
      extrinsic: rows(s.extrinsic),
      relative: rows(s.relative),
    })),
    target: {
      means: triples(result.target.means),
      sigmas: Array.from(result.target.sigmas),
      rms: result.target.rms,
      edge: result.target.edge,
    },
    skipped: result.skipped,
  };
}

function showResult(result, truth) {
  const fmt = (v, digits) => v.map((x) => x.toFixed(digits)).join(', ');
  const header = '<tr><th>sensor</th><th>xyz (m)</th><th>rpy (deg)</th><th>error vs truth</th></tr>';
  const body = result.sensors.map((s) => {
    const t = truth[s.name];
    const { angle, distance } = poseDifference(s.extrinsic, matrixFromXyzRpy(t.xyz, t.rpy));
    return `<tr><td>${s.name}</td><td>${fmt(s.xyz, 4)}</td><td>${fmt(s.rpy.map(degrees), 3)}</td>` +
      `<td>${degrees(angle).toFixed(3)}° / ${(distance * 1000).toFixed(1)} mm</td></tr>`;
  });
  $('result-table').innerHTML = header + body.join('');
  $('result-json').textContent = JSON.stringify(resultJson(result), null, 2);
}

async function runDemo() {
  showError(null);
  setRunning(true);
  const options = { sensors: +$('sensors').value, frames: +$('frames').value, seed: +$('seed').value };
  try {
    $('status').textContent = 'Generating scans…';
    const rig = await client.request('synthetic', { options });
    // The synthetic ROI holds only the cube: start the mixture at the cube's size.
    const input = { views: rig.views, nominal: rig.nominal, roi: rig.roi, initialSigma: 'prior' };
    const started = performance.now();
    const result = await client.request('calibrate', { input }, {
      onProgress: (p) => {
        const elapsed = (performance.now() - started) / 1000;
        const eta = (elapsed / p.iteration) * (p.maxIterations - p.iteration);
        $('progress').value = p.iteration / p.maxIterations;
        $('status').textContent = `Iteration ${p.iteration}/${p.maxIterations}, σ ${(p.meanSigma * 100).toFixed(2)} cm, about ${eta.toFixed(1)} s left`;
      },
    });
    $('progress').value = 1;
    $('status').textContent = `Done: ${result.iterations} iterations${result.converged ? ' (converged)' : ''}.`;
    showResult(result, rig.truth);
  } catch (error) {
    $('status').textContent = error.cancelled ? 'Cancelled.' : 'Failed.';
    if (!error.cancelled) showError(error);
  } finally {
    setRunning(false);
  }
}

$('demo').addEventListener('click', runDemo);
$('cancel').addEventListener('click', () => client.cancel());
