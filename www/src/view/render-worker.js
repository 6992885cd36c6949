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
// Colours are computed here too (colouring.js), from the points and poses this worker holds:
// a change of colouring is one message, not a new upload, and 1M points are coloured off the
// main thread.
//
// Messages from viewer.js, {type, ...}: init {canvas, grid}, size {width, height, pixelRatio},
// camera {position, quaternion, aspect}, cloud {id, positions, intensity, sensor, color},
// colouring {mode, reference}, pointSize {size}, axes {id, length}, box {id, min, max, color},
// target {id, target}, pose {id, matrix}, visible {id, visible}, remove {id}, clear,
// preview {on}, interacting {on}, marks {points}, pick {x, y, radius, id}, snapshot {id, overlay}.
// Replies: after each frame {type: 'frame', points, ms}; {type: 'scale', mode, range, missing}
// once colours are made; {type: 'picked', id, hit} and {type: 'snapshot', id, blob}.
import * as THREE from 'three';
import { targetObject } from './target.js';
import { DISTANCE_RANGE, SurfaceGrid, fillRamp, fillSolid, heightOf, robustRange } from './colouring.js';
import { nearestOnScreen } from './pick.js';
import { drawOverlay } from './snapshot.js';

const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15181d);
const camera = new THREE.PerspectiveCamera(50, 1, 0.05, 500);
camera.up.set(0, 0, 1); // vehicle frame: z up
const ORBIT_POINTS = 100_000;
const HANDLE_SIZE = 10; // px: the ROI's handles
const HANDLE_COLOUR = 0xffffff; // no sensor's colour
const RUN_POINTS = 30_000;
const objects = new Map(); // id -> Object3D
const budget = { preview: false, interacting: false };
const colouring = { mode: 'sensor', reference: '', size: 2 };
const RANGE_SAMPLE = 20_000; // points per cloud for a robust range (each cloud is shuffled)
const RECOLOUR_AFTER_MS = 200; // height and distance follow the poses once they settle
let recolourTimer = null;
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

// Fisher-Yates with a fixed seed, the same permutation on positions (xyz) and intensity.
function shuffle(positions, intensity) {
  let seed = 0x9e3779b9;
  for (let i = positions.length / 3 - 1; i > 0; i--) {
    seed = (Math.imul(seed, 1664525) + 1013904223) >>> 0;
    const j = Math.floor((seed / 2 ** 32) * (i + 1));
    for (let k = 0; k < 3; k++) {
      const t = positions[3 * i + k];
      positions[3 * i + k] = positions[3 * j + k];
      positions[3 * j + k] = t;
    }
    if (intensity) [intensity[i], intensity[j]] = [intensity[j], intensity[i]];
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

// Points (flat xyz, in the object's own frame; ours, reordered here), their intensity (or
// null), their sensor and its colour (hex).
function cloud({ id, positions, intensity, sensor, color }) {
  shuffle(positions, intensity);
  const count = positions.length / 3;
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  geometry.userData = { count, intensity, sensor, color };
  // By sensor: one colour, no colour attribute (half the data a frame draws); per point
  // colours are made when another mode asks (recolour).
  const material = new THREE.PointsMaterial({ size: colouring.size, sizeAttenuation: false, color });
  put(id, new THREE.Points(geometry, material));
  scheduleRecolour(0);
}

const clouds = () => [...objects.values()].filter((o) => o.isPoints && o.geometry.userData.sensor !== undefined);

// Colours every cloud by the current mode and reports the scale: {mode, range, missing} where
// `missing` lists the sensors without intensity and `median` is the median distance to the
// reference's surface (distance mode).
function recolour() {
  recolourTimer = null;
  const all = clouds();
  scene.updateMatrixWorld();
  const { mode } = colouring;
  const missing = [...new Set(all.filter((o) => !o.geometry.userData.intensity).map((o) => o.geometry.userData.sensor))];
  let range = null;
  let median = null;
  let value = null; // object -> (i -> number), or null for the sensor's colour
  if (mode === 'height') {
    value = (o) => heightOf(o.geometry.attributes.position.array, o.matrixWorld.elements);
    range = robustRange(all.filter((o) => o.visible).flatMap((o) => sample(o, value(o))));
  } else if (mode === 'intensity') {
    value = (o) => o.geometry.userData.intensity && ((i) => o.geometry.userData.intensity[i]);
    range = robustRange(all.filter((o) => o.visible && o.geometry.userData.intensity).flatMap((o) => sample(o, value(o))));
  } else if (mode === 'distance') {
    const grid = new SurfaceGrid();
    const v = new THREE.Vector3();
    for (const o of all.filter((o) => o.visible && o.geometry.userData.sensor === colouring.reference)) {
      const p = o.geometry.attributes.position.array;
      for (let i = 0; i < o.geometry.userData.count; i++) {
        v.fromArray(p, 3 * i).applyMatrix4(o.matrixWorld);
        grid.add(v.x, v.y, v.z);
      }
    }
    value = (o) => o.geometry.userData.sensor !== colouring.reference && ((i) => grid.distance(...v.fromArray(o.geometry.attributes.position.array, 3 * i).applyMatrix4(o.matrixWorld).toArray()));
    range = DISTANCE_RANGE;
    // The median distance of the points measured (a sample of each cloud shown): one number to
    // compare before and after.
    const measured = all.filter((o) => o.visible && value(o)).flatMap((o) => sample(o, value(o))).filter((d) => !Number.isNaN(d)).sort((a, b) => a - b);
    median = measured.length ? measured[measured.length >> 1] : null;
  }
  for (const o of all) {
    const { count, color } = o.geometry.userData;
    const perPoint = mode !== 'sensor';
    if (o.material.vertexColors !== perPoint) {
      o.material.vertexColors = perPoint;
      o.material.color.setHex(perPoint ? 0xffffff : color);
      o.material.needsUpdate = true;
    }
    if (!perPoint) {
      o.geometry.deleteAttribute('color');
      continue;
    }
    if (!o.geometry.attributes.color) o.geometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(3 * count), 3));
    const out = o.geometry.attributes.color.array;
    const f = value?.(o);
    if (f && range) fillRamp(out, count, f, range);
    else fillSolid(out, count, 0x5c636e); // grey: nothing to colour by
    o.geometry.attributes.color.needsUpdate = true;
  }
  self.postMessage({ type: 'scale', mode, range, missing, median });
  render();
}

function sample(o, f) {
  const n = Math.min(o.geometry.userData.count, RANGE_SAMPLE);
  return Array.from({ length: n }, (_, i) => f(i));
}

function scheduleRecolour(ms) {
  clearTimeout(recolourTimer);
  recolourTimer = setTimeout(recolour, ms);
}

// The point nearest the pixel (NDC x, y; `radius` NDC per axis) among the points drawn:
// {id, sensor, point (vehicle frame)} or null.
function pick({ x, y, radius }) {
  scene.updateMatrixWorld();
  const viewProjection = new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse);
  let best = null;
  for (const [id, o] of objects) {
    if (!o.isPoints || !o.visible || o.geometry.userData.sensor === undefined) continue;
    const m = new THREE.Matrix4().multiplyMatrices(viewProjection, o.matrixWorld);
    const positions = o.geometry.attributes.position.array;
    // Every point of the cloud: the user saw the full frame, while the click itself may have
    // cut the draw range to the orbit's sample.
    const hit = nearestOnScreen(positions, o.geometry.userData.count, m.elements, x, y, radius);
    if (hit && (!best || hit.depth < best.depth)) {
      const point = new THREE.Vector3().fromArray(positions, 3 * hit.index).applyMatrix4(o.matrixWorld);
      best = { depth: hit.depth, id, sensor: o.geometry.userData.sensor, point: point.toArray() };
    }
  }
  return best && { id: best.id, sensor: best.sensor, point: best.point };
}

// Picked points (vehicle frame) as large dots, joined by a line when there are two.
function marks({ points }) {
  remove('marks');
  if (!points.length) return;
  const group = new THREE.Group();
  const geometry = new THREE.BufferGeometry().setAttribute('position', new THREE.Float32BufferAttribute(points.flat(), 3));
  group.add(new THREE.Points(geometry, new THREE.PointsMaterial({ size: 9, sizeAttenuation: false, color: 0xffffff, depthTest: false })));
  if (points.length === 2) group.add(new THREE.Line(geometry.clone(), new THREE.LineBasicMaterial({ color: 0xffffff, depthTest: false })));
  group.renderOrder = 1;
  put('marks', group);
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
  colouring({ mode, reference }) {
    Object.assign(colouring, { mode, reference });
    scheduleRecolour(0);
  },
  pointSize({ size }) {
    colouring.size = size;
    for (const o of clouds()) o.material.size = size;
  },
  marks,
  pick: ({ id, ...at }) => self.postMessage({ type: 'picked', id, hit: pick(at) }),
  // The view as PNG: drawn now, in full, copied onto a 2D canvas before the frame is handed
  // over, with `overlay` (view/snapshot.js: verdict line, legend or colour bar, caption) on it.
  async snapshot({ id, overlay }) {
    const [preview, interacting] = [budget.preview, budget.interacting];
    Object.assign(budget, { preview: false, interacting: false });
    drawRanges();
    renderer.render(scene, camera);
    Object.assign(budget, { preview, interacting });
    const { width, height } = renderer.domElement;
    const out = new OffscreenCanvas(width, height);
    const ctx = out.getContext('2d');
    ctx.drawImage(renderer.domElement, 0, 0);
    if (overlay) drawOverlay(ctx, width, height, overlay, renderer.getPixelRatio());
    const blob = await out.convertToBlob({ type: 'image/png' });
    self.postMessage({ type: 'snapshot', id, blob });
  },
  // The axes of a frame (x red, y green, z blue), `length` m.
  axes: ({ id, length }) => put(id, new THREE.AxesHelper(length)),
  // An axis-aligned box as lines; with `handles`, a square on each face's centre (roi-editor.js
  // drags them), drawn over everything so a face behind the data can still be grabbed.
  box({ id, min, max, color, handles }) {
    const group = new THREE.Group();
    group.add(new THREE.Box3Helper(new THREE.Box3(new THREE.Vector3(...min), new THREE.Vector3(...max)), color));
    if (handles) {
      const centre = min.map((v, i) => (v + max[i]) / 2);
      const faces = [min, max].flatMap((side) => [0, 1, 2].map((a) => centre.map((c, i) => (i === a ? side[a] : c))));
      const geometry = new THREE.BufferGeometry().setAttribute('position', new THREE.Float32BufferAttribute(faces.flat(), 3));
      const squares = new THREE.Points(geometry, new THREE.PointsMaterial({ size: HANDLE_SIZE, sizeAttenuation: false, color: HANDLE_COLOUR, depthTest: false }));
      squares.renderOrder = 2;
      group.add(squares);
    }
    put(id, group);
  },
  target: ({ id, target }) => put(id, targetObject(target)),
  // Places an object by a row-major 4x4 (THREE's Matrix4.set takes row-major too).
  pose({ id, matrix }) {
    const object = objects.get(id);
    if (!object) return;
    object.matrixAutoUpdate = false; // placed by its pose from now on
    object.matrix.set(...matrix);
    object.matrixWorldNeedsUpdate = true;
    if (object.isPoints && (colouring.mode === 'height' || colouring.mode === 'distance')) scheduleRecolour(RECOLOUR_AFTER_MS);
  },
  preview: ({ on }) => (budget.preview = on),
  interacting: ({ on }) => (budget.interacting = on),
  visible({ id, visible }) {
    const object = objects.get(id);
    if (!object || object.visible === visible) return;
    object.visible = visible;
    if (object.isPoints && colouring.mode !== 'sensor') scheduleRecolour(RECOLOUR_AFTER_MS);
  },
  remove: ({ id }) => remove(id),
  clear: () => [...objects.keys()].forEach(remove),
};

self.onmessage = ({ data }) => {
  handlers[data.type](data);
  render();
};
