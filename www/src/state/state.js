// The page's state: the scans loaded, the rig, the settings, the last results. One object,
// changed through these functions, so what invalidates a result is decided in one place.
import { natural } from '../files/files.js';
import { matrixFromXyzRpy } from '../transforms.js';
import { DEFAULTS, readHash, readRig } from './url.js';

// The ROI a user starts editing from when they turn 'auto' off (m, vehicle frame).
export const DEFAULT_ROI = Object.freeze({ min: Object.freeze([-5, -5, -2]), max: Object.freeze([5, 5, 3]) });

// The state a page opens with: the link's settings and rig (ROI, reference, vehicle frame).
export function createState() {
  const link = readRig();
  return {
    settings: readHash(),
    scans: [], // {id, path, sensor, frame, points, intensity?, count, dropped, format}
    bad: [], // {path, error}
    rig: { sensors: [], nominal: {}, roi: link.roi, reference: link.reference ?? '', parent: link.parent ?? 'vehicle' },
    truth: null, // sensor -> {xyz, rpy}, for a demo
    results: null, // reports of the last run, one per method that ran
    failures: [], // {method, error} of the methods of the last run that failed
    resultJson: null, // what the JSON view holds: the report, or every method's outcome
    resultContext: null, // what the last run had: {target, roiAuto}
    methods: [], // the library's methods: {name, label, jrmpc, pairs}
    show: 'before',
    colour: 'sensor',
    allFrames: false,
    hidden: new Set(), // sensors not shown in the view
    stale: null, // what changed since the result shown (it is out of date), or null
    running: false,
    recording: null, // {handle, path}: the recording open in the worker
  };
}

// Forgets the loaded scans, the rig and the results.
export function clearState(state) {
  Object.assign(state, { scans: [], bad: [], truth: null, results: null, rig: { sensors: [], nominal: {}, roi: null, reference: '', parent: 'vehicle' } });
}

// Sensors from the scans (natural order); nominal, ROI, reference and settings taken from
// `config` (the library's config reader's shape) where it has them, else kept or defaulted. No
// ROI (null) is 'auto': the library crops around the targets it finds, else to the clouds' overlap.
export function rebuildRig(state, config = {}) {
  const rig = state.rig;
  rig.sensors = [...new Set(state.scans.map((v) => v.sensor))].sort(natural);
  for (const [name, pose] of Object.entries(config.nominal ?? {})) rig.nominal[name] = { xyz: [...pose.xyz], rpy: [...pose.rpy] };
  for (const s of rig.sensors) rig.nominal[s] ??= { xyz: [0, 0, 0], rpy: [0, 0, 0] };
  if (config.roi) rig.roi = { min: [...config.roi.min], max: [...config.roi.max] };
  if (config.reference) rig.reference = String(config.reference);
  if (config.parent) rig.parent = String(config.parent);
  if (!rig.sensors.includes(rig.reference)) rig.reference = mostPoints(state.scans) ?? '';
  for (const key of ['method', 'target', 'components', 'iterations', 'initialSigma']) if (config[key] != null) state.settings[key] = config[key];
  // `global` is on or off in the config, one of four choices on the page.
  if (config.global != null) state.settings.global = config.global ? 'on' : 'off';
  if (typeof config.exact === 'boolean') state.settings.exact = config.exact;
  // `refine` is a choice of the global alignment setting.
  if (config.refine === true) state.settings.global = 'refine';
  if (config.refine === false && state.settings.global === 'refine') state.settings.global = DEFAULTS.global;
}

// The sensor with the most points (the first such in natural order), or null: the reference
// when nothing names one. A sensor that sees most of the scene is the one the others overlap;
// the alphabetically first could be a side unit that sees the ground only.
export function mostPoints(scans) {
  const counts = new Map();
  for (const v of scans) counts.set(v.sensor, (counts.get(v.sensor) ?? 0) + v.points.length / 3);
  let best = null;
  for (const [name, n] of [...counts].sort(([a], [b]) => natural(a, b))) if (best === null || n > counts.get(best)) best = name;
  return best;
}

export const sortScans = (state) => state.scans.sort((a, b) => natural(a.sensor, b.sensor) || natural(a.frame, b.frame));

// Nominal T_vehicle_sensor per sensor, as 4x4 row-major matrices.
export const nominalPoses = (state) =>
  Object.fromEntries(state.rig.sensors.map((s) => [s, matrixFromXyzRpy(state.rig.nominal[s].xyz, state.rig.nominal[s].rpy)]));

// The poses the view shows: calibrated after a run when asked, else nominal.
export function shownPoses(state) {
  const poses = nominalPoses(state);
  if (state.show === 'after' && state.results) for (const s of state.results[0].sensors) poses[s.name] = s.extrinsic;
  return poses;
}

