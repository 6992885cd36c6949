// The renderer half of a Viewer, in its own worker: three.js draws into the page's canvas
// (transferred as an OffscreenCanvas) here, off the main thread. Without a GPU, WebGL runs on
// SwiftShader and the browser reads every frame back for software compositing; on a canvas of the
// page that wait lands on the main thread (60-130 ms a frame for 30k points on 2 busy cores),
// here it lands on this worker. Renders on demand: every message asks for one frame at the next
// animation frame, however many arrive before it.
//
// Messages from viewer.js, {type, ...}: init {canvas, grid}, size {width, height, pixelRatio},
// camera {position, quaternion, aspect}, cloud {id, positions, colors, size}, axes {id, length},
// box {id, min, max, color}, target {id, target, prior}, pose {id, matrix}, stride {id, step},
// visible {id, visible}, remove {id}, clear. After each frame: {type: 'frame', ms} (the time the
// frame took here, readback included).
import * as THREE from 'three';
import { targetObject } from './target.js';

const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15181d);
const camera = new THREE.PerspectiveCamera(50, 1, 0.05, 500);
camera.up.set(0, 0, 1); // vehicle frame: z up
const objects = new Map(); // id -> Object3D
let renderer = null;
let pending = false;
const nextFrame = self.requestAnimationFrame?.bind(self) ?? ((draw) => setTimeout(draw, 16));

function render() {
  if (pending || !renderer) return;
  pending = true;
  nextFrame(() => {
    pending = false;
    const started = performance.now();
    renderer.render(scene, camera);
    // WebGL commits the frame when this task ends; finish() waits for it to be drawn, so `ms`
    // is the whole frame, and the next one is not queued behind it.
    renderer.getContext().finish();
    self.postMessage({ type: 'frame', ms: performance.now() - started });
  });
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

// Points (flat xyz, in the object's own frame); `colors` flat rgb 0..1 or one hex colour.
function cloud({ id, positions, colors, size = 2 }) {
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  const perPoint = typeof colors !== 'number';
  if (perPoint) geometry.setAttribute('color', new THREE.BufferAttribute(colors, 3));
  const material = new THREE.PointsMaterial({ size, sizeAttenuation: false, vertexColors: perPoint, color: perPoint ? 0xffffff : colors });
  put(id, new THREE.Points(geometry, material));
}

// Draws every `step`-th point of a cloud only (1: all); cheap previews while poses animate.
// The preview is a copy (drawArrays): an index buffer costs more than it saves in software GL.
function stride({ id, step }) {
  const geometry = objects.get(id)?.geometry;
  if (!geometry || (geometry.userData.step ?? 1) === step) return;
  const full = (geometry.userData.full ??= Object.fromEntries(['position', 'color'].filter((k) => geometry.getAttribute(k)).map((k) => [k, geometry.getAttribute(k)])));
  for (const [key, attribute] of Object.entries(full)) {
    if (step === 1) {
      geometry.setAttribute(key, attribute);
      continue;
    }
    const n = Math.ceil(attribute.count / step);
    const out = new Float32Array(n * 3);
    for (let i = 0; i < n; i++) out.set(attribute.array.subarray(i * step * 3, i * step * 3 + 3), i * 3);
    geometry.setAttribute(key, new THREE.BufferAttribute(out, 3));
  }
  geometry.userData.step = step;
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
  target: ({ id, target, prior }) => put(id, targetObject(target, prior)),
  // Places an object by a row-major 4x4 (THREE's Matrix4.set takes row-major too).
  pose({ id, matrix }) {
    const object = objects.get(id);
    if (!object) return;
    object.matrixAutoUpdate = false; // placed by its pose from now on
    object.matrix.set(...matrix);
    object.matrixWorldNeedsUpdate = true;
  },
  stride,
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
