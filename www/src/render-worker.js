// The renderer half of a Viewer, in its own worker: three.js draws into the page's canvas
// (transferred as an OffscreenCanvas) here, off the main thread. Without a GPU, WebGL runs on
// SwiftShader and the browser reads every frame back for software compositing; on a canvas of the
// page that wait lands on the main thread (60-130 ms a frame for 30k points on 2 busy cores),
// here it lands on this worker. Renders on demand: every message asks for one frame at the next
// animation frame, however many arrive before it.
//
// Point budgets: while the user orbits, at most ORBIT_POINTS points are drawn, so the view keeps
// up (1M points take about 0.5 s a frame on SwiftShader here); during a run, RUN_POINTS, so the
// frame of every iteration takes little CPU from the calibration and the page. The full clouds
// are drawn once either stops. Clouds are shuffled once when they arrive, so the first n points
// of each are an even sample and a smaller frame is just a draw range.
//
// Messages from viewer.js, {type, ...}: init {canvas, grid}, size {width, height, pixelRatio},
// camera {position, quaternion, aspect}, cloud {id, positions, colors, size}, axes {id, length},
// box {id, min, max, color}, target {id, target}, pose {id, matrix}, visible {id, visible},
// remove {id}, clear, preview {on}, interacting {on}. After each frame: {type: 'frame', points}
// (the points it drew).
import * as THREE from 'three';
import { targetObject } from './target.js';

const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15181d);
const camera = new THREE.PerspectiveCamera(50, 1, 0.05, 500);
camera.up.set(0, 0, 1); // vehicle frame: z up
const ORBIT_POINTS = 100_000;
const RUN_POINTS = 30_000;
const objects = new Map(); // id -> Object3D
const budget = { preview: false, interacting: false };
let renderer = null;
let pending = false;
const nextFrame = self.requestAnimationFrame?.bind(self) ?? ((draw) => setTimeout(draw, 16));

function render() {
  if (pending || !renderer) return;
  pending = true;
  nextFrame(() => {
    pending = false;
    const started = performance.now();
    const points = drawRanges();
    renderer.render(scene, camera);
    // The browser hands the frame over (and, in software compositing, reads it back) when this
    // callback returns; a task queued now runs after that, so `ms` is the whole frame.
    setTimeout(() => self.postMessage({ type: 'frame', points, ms: performance.now() - started }));
  });
}

// Sets each visible cloud's draw range for the budget; returns the points drawn.
function drawRanges() {
  const clouds = [...objects.values()].filter((o) => o.isPoints && o.visible);
  const total = clouds.reduce((sum, o) => sum + o.geometry.userData.count, 0);
  const limit = Math.min(budget.preview ? RUN_POINTS : Infinity, budget.interacting ? ORBIT_POINTS : Infinity);
  const share = Math.min(1, limit / total);
  let drawn = 0;
  for (const { geometry } of clouds) {
    const n = Math.ceil(geometry.userData.count * share);
    geometry.setDrawRange(0, n);
    drawn += n;
  }
  return drawn;
}

// Fisher-Yates with a fixed seed, the same permutation on positions and colours (xyz, rgb).
function shuffle(positions, colors) {
  let seed = 0x9e3779b9;
  for (let i = positions.length / 3 - 1; i > 0; i--) {
    seed = (Math.imul(seed, 1664525) + 1013904223) >>> 0;
    const j = Math.floor((seed / 2 ** 32) * (i + 1));
    for (const a of colors ? [positions, colors] : [positions]) {
      for (let k = 0; k < 3; k++) {
        const t = a[3 * i + k];
        a[3 * i + k] = a[3 * j + k];
        a[3 * j + k] = t;
      }
    }
  }
}

function put(id, object) {
  remove(id);
  objects.set(id, object);
  scene.add(object);
  return object;
}

function remove(id) {
  const object = objects.get(id);
  if (!object) return;
  scene.remove(object);
  object.traverse((o) => {
    o.geometry?.dispose();
    o.material?.dispose();
  });
  objects.delete(id);
}

// Points (flat xyz, in the object's own frame; ours, reordered here); `colors` flat rgb 0..1 or one
// hex colour.
function cloud({ id, positions, colors, size = 2 }) {
  const perPoint = typeof colors !== 'number';
  shuffle(positions, perPoint ? colors : null);
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  if (perPoint) geometry.setAttribute('color', new THREE.BufferAttribute(colors, 3));
  geometry.userData.count = positions.length / 3;
  const material = new THREE.PointsMaterial({ size, sizeAttenuation: false, vertexColors: perPoint, color: perPoint ? 0xffffff : colors });
  put(id, new THREE.Points(geometry, material));
}

const handlers = {
  init({ canvas, grid }) {
    renderer = new THREE.WebGLRenderer({ canvas, antialias: false });
    if (grid) {
      const g = new THREE.GridHelper(60, 60, 0x3a4048, 0x262a30);
      g.rotation.x = Math.PI / 2; // into the xy plane (the ground)
      scene.add(g);
      scene.add(new THREE.AxesHelper(1));
    }
  },
  size({ width, height, pixelRatio }) {
    renderer.setPixelRatio(pixelRatio);
    renderer.setSize(width, height, false);
  },
  camera({ position, quaternion, aspect }) {
    camera.position.fromArray(position);
    camera.quaternion.fromArray(quaternion);
    camera.aspect = aspect;
    camera.updateProjectionMatrix();
  },
  cloud,
  // The axes of a frame (x red, y green, z blue), `length` m.
  axes: ({ id, length }) => put(id, new THREE.AxesHelper(length)),
  // An axis-aligned box as lines.
  box: ({ id, min, max, color }) => put(id, new THREE.Box3Helper(new THREE.Box3(new THREE.Vector3(...min), new THREE.Vector3(...max)), color)),
  target: ({ id, target }) => put(id, targetObject(target)),
  // Places an object by a row-major 4x4 (THREE's Matrix4.set takes row-major too).
  pose({ id, matrix }) {
    const object = objects.get(id);
    if (!object) return;
    object.matrixAutoUpdate = false; // placed by its pose from now on
    object.matrix.set(...matrix);
    object.matrixWorldNeedsUpdate = true;
  },
  preview: ({ on }) => (budget.preview = on),
  interacting: ({ on }) => (budget.interacting = on),
  visible({ id, visible }) {
    const object = objects.get(id);
    if (object) object.visible = visible;
  },
  remove: ({ id }) => remove(id),
  clear: () => [...objects.keys()].forEach(remove),
};

self.onmessage = ({ data }) => {
  handlers[data.type](data);
  render();
};
