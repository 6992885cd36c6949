// Strict-typed use of the package, checked by `tsc --noEmit` (test/package.test.mjs): the
// declarations must type real calls, and a wrong call must fail (see the @ts-expect-error).
import { calibrate, compareCalibrations, placeScans, simulateRig, type CalibrationResult, type DriftReport, type Layout, type Progress } from 'gmmcalib';

const rig = simulateRig({ preset: 'sampled', frames: 2, seed: 1 });
const result: CalibrationResult = calibrate(
  { scans: rig.scans, nominal: rig.nominal, roi: rig.roi, reference: rig.reference, method: 'gmm' },
  (p: Progress) => p.iteration < 1000,
);
const sigma: number | undefined = result.sensors[1]?.precision?.rotation[2];
// The result's types are generated from the Rust ones (result.d.ts): a level is one of three.
const level: 'good' | 'check' | 'failed' = result.verdict.level;
const means: Float32Array = result.reconstruction.means;
// Every export the result carries, written by the library (json is the CLI's --json).
const urdf: string = result.exports.urdf;
const ply: string | undefined = result.exports.targetPly;
// @ts-expect-error a level that does not exist
const wrong: typeof result.verdict.level = 'fine';
const all = calibrate({ scans: rig.scans, nominal: rig.nominal, method: 'all' });
for (const r of all) {
  if ('error' in r) console.log(r.method, r.error);
  else console.log(r.verdict.level);
}
const drift: DriftReport = compareCalibrations('{}', 'a.json', '{}', 'b.json', { rotationDeg: 0.1, sigmas: 3 });
const moved: string[] = drift.sensors.filter((s) => s.moved).map((s) => s.name);
if (drift.sensors[0]?.limit.kind === 'sigmas') console.log(drift.sensors[0].limit.position[0]);
// @ts-expect-error a method that does not exist
calibrate({ scans: [], nominal: {}, method: 'ndt' });
// A folder's files placed as the CLI and the page place them.
const layout: Layout = placeScans(['up/100.pcd', 'down/100.03.pcd']);
const sensors: string[] = layout.scans.map((s) => s.sensor);
console.log(sigma, level, means.length, urdf, ply, wrong, moved, sensors, layout.pairings.join('; '));
