// Settings and demo parameters in the URL hash (`#method=gmm&seed=3&demo=paper`), so a copied
// link reproduces the same demo run. Only values that differ from the defaults are written.

export const DEFAULTS = Object.freeze({
  method: 'gmm', // gmm | jrmpc | cad | p2p | p2l | gicp | all
  components: 400,
  iterations: 100,
  target: 'cube:0.5', // the target: cube:EDGE | box:W,D,H | sphere:DIAMETER | none (m)
  global: 'auto', // global alignment first: auto (gmm only) | on | off
  initialSigma: 'bbox', // bbox | prior
  workers: 'auto', // auto | 1 | 2 | 4 | 8: workers sharing JRMPC's E-step
  estep: 'auto', // auto | gpu | cpu | exact: where JRMPC's E-step runs (gpu-estep.js), or exact
  demo: '', // preset of a demo to load on open: '' | paper | os1-128
  frames: 4,
  seed: 1,
  maxAngleDeg: 3,
  maxTranslation: 0.1,
});

const NUMBERS = new Set(['components', 'iterations', 'frames', 'seed', 'maxAngleDeg', 'maxTranslation']);

export function readHash(hash = location.hash) {
  const settings = { ...DEFAULTS };
  for (const [key, value] of new URLSearchParams(hash.replace(/^#/, ''))) {
    if (!(key in DEFAULTS)) continue;
    const v = NUMBERS.has(key) ? Number(value) : value;
    if (NUMBERS.has(key) && !Number.isFinite(v)) continue;
    settings[key] = v;
  }
  return settings;
}

export function writeHash(settings) {
  const params = new URLSearchParams();
  for (const key of Object.keys(DEFAULTS)) if (settings[key] !== DEFAULTS[key]) params.set(key, settings[key]);
  const hash = params.toString();
  history.replaceState(null, '', hash ? `#${hash}` : location.pathname + location.search);
}
