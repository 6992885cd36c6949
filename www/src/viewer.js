// A 3D view of a canvas: clouds (one object per view, placed by a pose), sensor axes, the ROI
// box, a grid. The camera and its orbit controls live here, on the main thread, where the pointer
// events are; everything three.js draws lives in render-worker.js, which owns the canvas (see
// there why). Every method posts one message; the worker renders on demand.
import { PerspectiveCamera, Vector3 } from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

const INTERACTION_SETTLE_MS = 250;

export class Viewer {
  #canvas;
  #worker;
  #camera = new PerspectiveCamera(50, 1, 0.05, 500);
  #controls;
  #frames = 0;

  // `onError(error)`: the renderer failed (no WebGL, a crashed worker).
  constructor(canvas, { grid = true, onError = (error) => console.error(error) } = {}) {
    this.#canvas = canvas;
    this.#worker = new Worker(new URL('./render-worker.js', import.meta.url), { type: 'module' });
    this.#worker.onmessage = ({ data }) => this.#drawn(data);
    this.#worker.onerror = (event) => {
      event.preventDefault();
      onError(new Error(`the 3D view failed: ${event.message || 'unknown error'}`));
    };
    const offscreen = canvas.transferControlToOffscreen();
    this.#post({ type: 'init', canvas: offscreen, grid }, [offscreen]);
    this.#camera.up.set(0, 0, 1); // vehicle frame: z up
    this.#camera.position.set(-8, -6, 8);
    this.#controls = new OrbitControls(this.#camera, canvas);
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
    this.#canvas.dataset.points = points;
    this.#canvas.dataset.frameMs = ms.toFixed(1);
    this.#canvas.dataset.frames = ++this.#frames;
  }

  #post(message, transfer = []) {
    this.#worker.postMessage(message, transfer);
  }

  #resize() {
    const { clientWidth: width, clientHeight: height } = this.#canvas;
    if (!width || !height) return;
    this.#post({ type: 'size', width, height, pixelRatio: Math.min(window.devicePixelRatio, 2) });
    this.#camera.aspect = width / height;
    this.render();
  }

  // Sends the camera; the worker draws a frame with it.
  render() {
    const { position, quaternion, aspect } = this.#camera;
    this.#post({ type: 'camera', position: position.toArray(), quaternion: quaternion.toArray(), aspect });
  }

  // Points (flat xyz, in the object's own frame; copied, the caller keeps them); `colors` flat
  // rgb 0..1 (handed over: the caller must not use them again) or one hex colour.
  setCloud(id, positions, colors, size = 2) {
    this.#post({ type: 'cloud', id, positions, colors, size }, typeof colors === 'number' ? [] : [colors.buffer]);
  }

  // The axes of a frame (x red, y green, z blue), `length` m.
  setAxes(id, length = 0.6) {
    this.#post({ type: 'axes', id, length });
  }

  // An axis-aligned box {min, max} as lines.
  setBox(id, { min, max }, color = 0xffcc44) {
    this.#post({ type: 'box', id, min, max, color });
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

  // Looks at a box {min, max} from behind (-x), a little to the right and above.
  lookAt({ min, max }) {
    const centre = new Vector3(...min).add(new Vector3(...max)).multiplyScalar(0.5);
    const size = Math.max(max[0] - min[0], max[1] - min[1], max[2] - min[2], 0.5);
    this.#controls.target.copy(centre);
    this.#camera.position.copy(centre).add(new Vector3(-1.3, -0.5, 0.7).multiplyScalar(size));
    this.#controls.update();
    this.render();
  }
}
