// What the main view shows, from the page state: one cloud per view placed by its sensor's pose
// (nominal before, calibrated after, the running estimate during a run), sensor axes, the ROI.
// Clouds are uploaded once per view and sensor; a pose change only moves objects, and the
// colouring (by sensor, height, intensity or distance to the reference) is made in the render
// worker.
import { multiply } from '../transforms.js';

const PALETTE = [0xff6b6b, 0x4dabf7, 0x69db7c, 0xffd43b, 0xda77f2, 0xff922b, 0x38d9a9, 0xf783ac];

export const sensorColour = (i) => PALETTE[i % PALETTE.length];
const ROI_COLOUR = 0xffcc44;
const AUTO_ROI_COLOUR = 0x9aa4b1;

export class Display {
  #viewer;
  #uploaded = new Map(); // view id -> sensor it was uploaded as
  #colouring = '';
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
    this.#colouring = '';
  }

  // `poses`: sensor -> row-major T_vehicle_sensor to draw with. `preview`: draw a sample of the
  // points only (the viewer's budget), for redraws on every iteration of a run.
  // The ROI drawn is the rig's, or with 'auto' the one the last result cropped to.
  // `hidden`: the sensors not to show.
  update({ scans, rig, colour, allFrames, results, hidden = new Set() }, poses, { preview = false } = {}) {
    const firstFrame = new Map();
    for (const v of scans) if (!firstFrame.has(v.sensor)) firstFrame.set(v.sensor, v.frame);
    const live = new Set(scans.map((v) => v.id));
    for (const id of this.#uploaded.keys()) {
      if (!live.has(id)) {
        this.#viewer.remove(id);
        this.#uploaded.delete(id);
      }
    }
    const shown = scans.filter((v) => (allFrames || firstFrame.get(v.sensor) === v.frame) && !hidden.has(v.sensor));
    this.#viewer.setPreview(preview);
    for (const view of scans) {
      const index = rig.sensors.indexOf(view.sensor);
      const pose = poses[view.sensor];
      if (this.#uploaded.get(view.id) !== `${index}/${view.sensor}`) {
        this.#viewer.setCloud(view.id, view.points, { intensity: view.intensity ?? null, sensor: view.sensor, color: sensorColour(index) });
        this.#uploaded.set(view.id, `${index}/${view.sensor}`);
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
    const colouring = `${colour}/${rig.reference}`;
    if (colouring !== this.#colouring) this.#viewer.setColouring(colour, rig.reference);
    this.#colouring = colouring;
    // A ROI given is drawn with handles to drag (roi-editor.js); the one auto found, in
    // another colour, without.
    const roi = rig.roi ?? results?.[0]?.roi ?? null;
    const roiKey = JSON.stringify([roi, Boolean(rig.roi)]);
    if (roiKey !== this.#roiKey) {
      if (roi) this.#viewer.setBox('roi', roi, rig.roi ? ROI_COLOUR : AUTO_ROI_COLOUR, Boolean(rig.roi));
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
