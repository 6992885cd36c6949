// What the main view shows, from the page state: one cloud per view placed by its sensor's pose
// (nominal before, calibrated after, the running estimate during a run), sensor axes, the ROI.
// Clouds are uploaded once per view and colour mode; a pose change only moves objects.
import { multiply } from './transforms.js';

const PALETTE = [0xff6b6b, 0x4dabf7, 0x69db7c, 0xffd43b, 0xda77f2, 0xff922b, 0x38d9a9, 0xf783ac];

export const sensorColour = (i) => PALETTE[i % PALETTE.length];

// Per-point colours: by height (vehicle z under `pose`, over the ROI's z range) or by intensity.
function ramp(values, lo, hi) {
  const out = new Float32Array(values.length * 3);
  for (let i = 0; i < values.length; i++) {
    const t = Math.min(1, Math.max(0, (values[i] - lo) / (hi - lo)));
    out[3 * i] = t;
    out[3 * i + 1] = 0.3 + 0.7 * (1 - Math.abs(2 * t - 1));
    out[3 * i + 2] = 1 - t;
  }
  return out;
}

function colours(view, mode, sensorIndex, pose, roi) {
  if (mode === 'intensity' && view.intensity) {
    let hi = 0;
    for (const v of view.intensity) hi = Math.max(hi, v);
    return ramp(view.intensity, 0, hi || 1);
  }
  if (mode === 'height') {
    const p = view.points;
    const z = new Float32Array(p.length / 3);
    for (let i = 0; i < z.length; i++) z[i] = pose[8] * p[3 * i] + pose[9] * p[3 * i + 1] + pose[10] * p[3 * i + 2] + pose[11];
    return ramp(z, roi?.min[2] ?? -0.5, roi?.max[2] ?? 3);
  }
  return sensorColour(sensorIndex);
}

export class Display {
  #viewer;
  #uploaded = new Map(); // view id -> colour mode it was uploaded with
  #axes = new Set();
  #roiKey = '';

  constructor(viewer) {
    this.#viewer = viewer;
  }

  clear() {
    this.#viewer.clear();
    this.#uploaded.clear();
    this.#axes.clear();
    this.#roiKey = '';
  }

  // `poses`: sensor -> row-major T_vehicle_sensor to draw with. `preview`: draw a sample of the
  // points only (the viewer's budget), for redraws on every iteration of a run.
  // The ROI drawn is the rig's, or with 'auto' the one the last result cropped to.
  update({ scans, rig, colour, allFrames, results }, poses, { preview = false } = {}) {
    const firstFrame = new Map();
    for (const v of scans) if (!firstFrame.has(v.sensor)) firstFrame.set(v.sensor, v.frame);
    const live = new Set(scans.map((v) => v.id));
    for (const id of this.#uploaded.keys()) {
      if (!live.has(id)) {
        this.#viewer.remove(id);
        this.#uploaded.delete(id);
      }
    }
    const shown = scans.filter((v) => allFrames || firstFrame.get(v.sensor) === v.frame);
    this.#viewer.setPreview(preview);
    for (const view of scans) {
      const index = rig.sensors.indexOf(view.sensor);
      const pose = poses[view.sensor];
      if (this.#uploaded.get(view.id) !== `${colour}/${view.sensor}`) {
        this.#viewer.setCloud(view.id, view.points, colours(view, colour, index, pose, rig.roi));
        this.#uploaded.set(view.id, `${colour}/${view.sensor}`);
      }
      this.#viewer.setPose(view.id, pose);
      this.#viewer.setVisible(view.id, shown.includes(view));
    }
    for (const id of this.#axes) if (!rig.sensors.includes(id.slice(5))) this.#viewer.remove(id);
    for (const name of rig.sensors) {
      const id = `axes:${name}`;
      if (!this.#axes.has(id)) this.#viewer.setAxes(id);
      this.#axes.add(id);
      this.#viewer.setPose(id, poses[name]);
    }
    const roi = rig.roi ?? results?.[0]?.roi ?? null;
    const roiKey = JSON.stringify(roi);
    if (roiKey !== this.#roiKey) {
      if (roi) this.#viewer.setBox('roi', roi);
      else this.#viewer.remove('roi');
    }
    this.#roiKey = roiKey;
  }
}

// Poses during a run: the running correction C_ref_s times the nominal.
export function livePoses(progress, nominalPoses) {
  const poses = { ...nominalPoses };
  progress.sensors.forEach((name, i) => {
    if (nominalPoses[name]) poses[name] = multiply(progress.corrections[i], nominalPoses[name]);
  });
  return poses;
}
