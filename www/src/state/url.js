// Settings, the rig's ROI, reference and vehicle frame name, and a demo's parameters in the URL
// hash (`#method=jrmpc&roi=8.5,-3,-1,11,4,2&reference=sensor_2`, `#demo=paper&seed=3`), so a
// copied link opens the page with them (and the same demo). Only values that differ from the
// defaults are written; a demo's own keys only while a demo is loaded (files dropped on a demo's
// page leave no seed behind).
//
// The calibration's own settings start from the library's defaults (`defaults()`, written to
// pkg/defaults.json when the wasm is built); the rest are the page's.
import library from '../../pkg/defaults.json' with { type: 'json' };

export const DEFAULTS = Object.freeze({
  method: library.method, // gmm | jrmpc | cad | p2p | p2l | gicp | all
  components: library.components,
  iterations: library.iterations,
  target: library.target, // the target: cube:EDGE | box:W,D,H | sphere:DIAMETER | none (m)
  global: 'auto', // global alignment first: auto (gmm only) | on | off | refine (refine only, from the nominal)
  initialSigma: library.initialSigma, // bbox | prior
  workers: 'auto', // auto | 1 | 2 | 4 | 8: workers sharing JRMPC's E-step
  eStepDevice: 'auto', // auto | gpu | cpu: where JRMPC's E-step runs (gpu-estep.js)
  exact: library.exact, // the E-step as the paper states it (on the CPU, whatever the device)
  demo: '', // preset of a demo to load on open: '' | paper | os1-128
  frames: 4,
  seed: 1,
  maxAngleDeg: 3,
  maxTranslation: 0.1,
});

// Keys that describe a demo, written only with `demo`.
const DEMO_KEYS = new Set(['frames', 'seed', 'maxAngleDeg', 'maxTranslation']);
const NUMBERS = new Set(['components', 'iterations', 'frames', 'seed', 'maxAngleDeg', 'maxTranslation']);
const BOOLEANS = new Set(['exact']);

// The settings a hash gives, only those it names (known keys, numbers checked).
export function explicitSettings(hash = location.hash) {
  const out = {};
  for (const [key, value] of new URLSearchParams(hash.replace(/^#/, ''))) {
    // Links saved before the device and `exact` were two settings: `estep=auto|gpu|cpu|exact`.
    if (key === 'estep') Object.assign(out, value === 'exact' ? { exact: true } : { eStepDevice: value });
    if (!(key in DEFAULTS)) continue;
    if (BOOLEANS.has(key)) {
      if (value === 'true' || value === 'false') out[key] = value === 'true';
      continue;
    }
    const v = NUMBERS.has(key) ? Number(value) : value;
    if (NUMBERS.has(key) && !Number.isFinite(v)) continue;
    out[key] = v;
  }
  return out;
}

// Every setting: the hash's, the defaults for the rest.
export const readHash = (hash = location.hash) => ({ ...DEFAULTS, ...explicitSettings(hash) });

// The rig a hash gives: {roi: {min, max} | null, reference, parent} (absent: null).
export function readRig(hash = location.hash) {
  const params = new URLSearchParams(hash.replace(/^#/, ''));
  const roi = params.get('roi')?.split(',').map(Number);
  const valid = roi?.length === 6 && roi.every(Number.isFinite) && [0, 1, 2].every((a) => roi[a] < roi[a + 3]);
  return { roi: valid ? { min: roi.slice(0, 3), max: roi.slice(3) } : null, reference: params.get('reference'), parent: params.get('vehicle') };
}

// The hash for `settings` and `rig` ({roi, reference, parent}; the reference is written only
// with files, a demo names its own).
export function hashOf(settings, rig = {}) {
  const params = new URLSearchParams();
  for (const key of Object.keys(DEFAULTS)) {
    if (DEMO_KEYS.has(key) && !settings.demo) continue;
    if (settings[key] !== DEFAULTS[key]) params.set(key, settings[key]);
  }
  if (rig.roi) params.set('roi', [...rig.roi.min, ...rig.roi.max].map((v) => +v.toFixed(3)).join(','));
  if (rig.reference && !settings.demo) params.set('reference', rig.reference);
  if (rig.parent && rig.parent !== 'vehicle') params.set('vehicle', rig.parent);
  return params.toString();
}

export function writeHash(settings, rig) {
  const hash = hashOf(settings, rig);
  history.replaceState(null, '', hash ? `#${hash}` : location.pathname + location.search);
}
