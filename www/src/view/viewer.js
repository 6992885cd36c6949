// A 3D view of a canvas: clouds (one object per view, placed by a pose), sensor axes, the ROI
// box, a grid. The camera and its orbit controls live here, on the main thread, where the pointer
// events are; everything three.js draws lives in render-worker.js, which owns the canvas (see
// there why). Every method posts one message; the worker renders on demand.
import { PerspectiveCamera, Raycaster, Vector2, Vector3 } from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { frame } from './framing.js';

const INTERACTION_SETTLE_MS = 250;
// From the framed box's centre towards the camera, per preset view.
const DIRECTIONS = { default: [-1.3, -0.5, 0.7], top: [-0.001, 0, 1.6], side: [0, -1.6, 0.001], front: [-1.6, 0, 0.001] };

export class Viewer {
  #canvas;
  #worker;
  #camera = new PerspectiveCamera(50, 1, 0.05, 500);
  #controls;
  #frames = 0;
  #frameMs = 0;
  #replies = new Map(); // request id -> resolve, for pick and snapshot
  #nextId = 1;
  #onScale;
  #framed = null; // the box the last lookAt framed: preset views frame it again
  #size = { width: 1, height: 1 }; // the canvas's CSS size, as the last resize gave it
  #onCamera = new Set();

  // `onError(error)`: the renderer failed (no WebGL, a crashed worker). `onScale({mode, range,
  // missing})`: the colours were made (range [lo, hi] of the ramp, or null; the sensors
  // without intensity).
  constructor(canvas, { grid = true, onError = (error) => console.error(error), onScale = () => {} } = {}) {
    this.#canvas = canvas;
    this.#onScale = onScale;
    this.#worker = new Worker(new URL('./render-worker.js', import.meta.url), { type: 'module' });
    this.#worker.onmessage = ({ data }) => {
      if (data.type === 'frame') this.#drawn(data);
      else if (data.type === 'scale') this.#onScale(data);
      else {
        this.#replies.get(data.id)?.(data);
        this.#replies.delete(data.id);
      }
    };
    this.#worker.onerror = (event) => {
      event.preventDefault();
      onError(new Error(`the 3D view failed: ${event.message || 'unknown error'}`));
    };
    const offscreen = canvas.transferControlToOffscreen();
    this.#post({ type: 'init', canvas: offscreen, grid }, [offscreen]);
    this.#camera.up.set(0, 0, 1); // vehicle frame: z up
    this.#camera.position.set(-8, -6, 8);
    this.#controls = new OrbitControls(this.#camera, canvas);
    this.#controls.zoomToCursor = true; // the wheel zooms towards what is under the pointer
    this.#controls.addEventListener('change', () => this.render());
    // While the user orbits, the worker draws a sample; the full clouds once they stop (a pause
    // between wheel steps keeps the sample).
    let settle;
    this.#controls.addEventListener('start', () => {
      clearTimeout(settle);
      this.#post({ type: 'interacting', on: true });
    });
    this.#controls.addEventListener('end', () => {
      settle = setTimeout(() => this.#post({ type: 'interacting', on: false }), INTERACTION_SETTLE_MS);
    });
    new ResizeObserver(() => this.#resize()).observe(canvas);
    this.#resize();
  }

  // Test and bench hook: `data-frames` counts the frames drawn, `data-points` the points in the
  // last one, `data-frame-ms` the time it took in the worker.
  #drawn({ points, ms }) {
    this.#frameMs = ms;
    this.#canvas.dataset.points = points;
    this.#canvas.dataset.frameMs = ms.toFixed(1);
    this.#canvas.dataset.frames = ++this.#frames;
  }

  // How long the last frame took to draw (ms, in the render worker).
  get frameMs() {
    return this.#frameMs;
  }

  #post(message, transfer = []) {
    this.#worker.postMessage(message, transfer);
  }

  #resize() {
    const { clientWidth: width, clientHeight: height } = this.#canvas;
    if (!width || !height) return;
    this.#size = { width, height };
    this.#post({ type: 'size', width, height, pixelRatio: Math.min(window.devicePixelRatio, 2) });
    this.#camera.aspect = width / height;
    this.#camera.updateProjectionMatrix();
    this.render();
  }

  // Sends the camera; the worker draws a frame with it.
  render() {
    const { position, quaternion, aspect } = this.#camera;
    this.#post({ type: 'camera', position: position.toArray(), quaternion: quaternion.toArray(), aspect });
    for (const listener of this.#onCamera) listener();
  }

  // Points (flat xyz, in the object's own frame; copied, the caller keeps them), their
  // intensity (or null; copied), their sensor's name and colour (hex).
  setCloud(id, positions, { intensity = null, sensor = '', color = 0xffffff } = {}) {
    this.#post({ type: 'cloud', id, positions, intensity, sensor, color });
  }

  // Colour by 'sensor', 'height', 'intensity' or 'distance' (to `reference`'s points).
  setColouring(mode, reference = '') {
    this.#post({ type: 'colouring', mode, reference });
  }

  setPointSize(size) {
    this.#post({ type: 'pointSize', size });
  }

  // Marked points (vehicle frame, [[x, y, z], ...]), a line between two.
  setMarks(points) {
    this.#post({ type: 'marks', points });
  }

  #ask(message) {
    const id = this.#nextId++;
    return new Promise((resolve) => {
      this.#replies.set(id, resolve);
      this.#post({ ...message, id });
    });
  }

  // The point drawn nearest the canvas pixel (clientX, clientY), within `reach` CSS pixels:
  // {id, sensor, point} or null.
  async pick(clientX, clientY, reach = 6) {
    const r = this.#canvas.getBoundingClientRect();
    const x = ((clientX - r.left) / r.width) * 2 - 1;
    const y = 1 - ((clientY - r.top) / r.height) * 2;
    const { hit } = await this.#ask({ type: 'pick', x, y, radius: [(2 * reach) / r.width, (2 * reach) / r.height] });
    return hit;
  }

  // The view, drawn in full, as a PNG blob, with `overlay` drawn over it (view/snapshot.js).
  async snapshot(overlay = null) {
    const { blob } = await this.#ask({ type: 'snapshot', overlay });
    return blob;
  }

  // The axes of a frame (x red, y green, z blue), `length` m.
  setAxes(id, length = 0.6) {
    this.#post({ type: 'axes', id, length });
  }

  // An axis-aligned box {min, max} as lines, with `handles` a square on each face's centre.
  setBox(id, { min, max }, color = 0xffcc44, handles = false) {
    this.#post({ type: 'box', id, min, max, color, handles });
  }

  // The reconstructed target (target.js builds it in the worker).
  setTarget(id, target) {
    this.#post({ type: 'target', id, target });
  }

  // Places an object by a row-major 4x4 T_vehicle_object.
  setPose(id, matrix) {
    this.#post({ type: 'pose', id, matrix: [...matrix] });
  }

  // Draws a sample of the points only (the worker's RUN_POINTS), for redraws on every iteration
  // of a run; `false`: everything again.
  setPreview(on) {
    this.#post({ type: 'preview', on });
  }

  setVisible(id, visible) {
    this.#post({ type: 'visible', id, visible });
  }

  remove(id) {
    this.#post({ type: 'remove', id });
  }

  clear() {
    this.#post({ type: 'clear' });
  }

  // Frames a box {min, max}: the camera centred on it, as close as shows all of it, from
  // behind (-x) a little to the right and above, or from `direction` ('top', 'side': from -y,
  // 'front': from behind, along +x).
  lookAt(box, direction = 'default') {
    this.#framed = { min: [...box.min], max: [...box.max] };
    const from = DIRECTIONS[direction] ?? DIRECTIONS.default;
    const { target, position } = frame(box, from, this.#camera.fov, this.#camera.aspect || 1);
    this.#controls.target.set(...target);
    this.#camera.position.set(...position);
    this.#controls.update();
    this.render();
  }

  // Frames what was framed last (or what the view looks at now) from `direction`: every preset
  // centres the data, however the user orbited or zoomed since.
  lookFrom(direction) {
    if (this.#framed) return this.lookAt(this.#framed, direction);
    const target = this.#controls.target.clone();
    const half = this.#camera.position.distanceTo(target) / 3;
    this.lookAt({ min: target.clone().subScalar(half).toArray(), max: target.clone().addScalar(half).toArray() }, direction);
  }

  // Canvas pixel (CSS, relative to the canvas) of each point ([x, y, z], vehicle frame), or
  // null for one behind the camera.
  project(points) {
    // The size kept from the last resize: reading the canvas's would force a layout, and this
    // runs after every change to the page (the handles follow the camera and the ROI).
    const { width: w, height: h } = this.#size;
    this.#camera.updateMatrixWorld();
    return points.map((p) => {
      const v = new Vector3(...p).project(this.#camera);
      return v.z > 1 || v.z < -1 ? null : [((v.x + 1) / 2) * w, ((1 - v.y) / 2) * h];
    });
  }

  // The ray under a canvas pixel (CSS, relative to the canvas): {origin, direction}.
  ray(x, y) {
    const { width: w, height: h } = this.#size;
    const caster = new Raycaster();
    caster.setFromCamera(new Vector2((x / w) * 2 - 1, 1 - (y / h) * 2), this.#camera);
    return { origin: caster.ray.origin.toArray(), direction: caster.ray.direction.toArray() };
  }

  // Orbiting by the pointer on or off (off while a handle is dragged).
  set orbiting(on) {
    this.#controls.enabled = on;
  }

  // `listener()` runs after every camera change (the ROI's handles follow it).
  onCamera(listener) {
    this.#onCamera.add(listener);
  }
}
