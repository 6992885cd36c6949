// Renders, nothing else: clouds (one object per view, placed by a pose), sensor axes, the ROI
// box, a grid. Renders on demand (a change asks for one frame), never in a busy loop: software
// WebGL draws a million points slowly.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

export class Viewer {
  #renderer;
  #scene = new THREE.Scene();
  #camera;
  #controls;
  #objects = new Map(); // id -> Object3D
  #pending = false;

  constructor(canvas, { grid = true } = {}) {
    this.#renderer = new THREE.WebGLRenderer({ canvas, antialias: false });
    this.#renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.#scene.background = new THREE.Color(0x15181d);
    this.#camera = new THREE.PerspectiveCamera(50, 1, 0.05, 500);
    this.#camera.up.set(0, 0, 1); // vehicle frame: z up
    this.#camera.position.set(-8, -6, 8);
    this.#controls = new OrbitControls(this.#camera, canvas);
    this.#controls.addEventListener('change', () => this.render());
    if (grid) {
      const g = new THREE.GridHelper(60, 60, 0x3a4048, 0x262a30);
      g.rotation.x = Math.PI / 2; // into the xy plane (the ground)
      this.#scene.add(g);
      this.#scene.add(new THREE.AxesHelper(1));
    }
    new ResizeObserver(() => this.#resize()).observe(canvas);
    this.#resize();
  }

  #resize() {
    const canvas = this.#renderer.domElement;
    const { clientWidth: w, clientHeight: h } = canvas;
    if (!w || !h) return;
    this.#renderer.setSize(w, h, false);
    this.#camera.aspect = w / h;
    this.#camera.updateProjectionMatrix();
    this.render();
  }

  // One frame at the next animation frame, however many changes ask for it.
  render() {
    if (this.#pending) return;
    this.#pending = true;
    requestAnimationFrame(() => {
      this.#pending = false;
      this.#renderer.render(this.#scene, this.#camera);
    });
  }

  #put(id, object) {
    this.remove(id);
    this.#objects.set(id, object);
    this.#scene.add(object);
    this.render();
    return object;
  }

  // Points (flat xyz, in the object's own frame); `colors` flat rgb 0..1 or one hex colour.
  setCloud(id, positions, colors, size = 2) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    const perPoint = typeof colors !== 'number';
    if (perPoint) geometry.setAttribute('color', new THREE.BufferAttribute(colors, 3));
    const material = new THREE.PointsMaterial({ size, sizeAttenuation: false, vertexColors: perPoint, color: perPoint ? 0xffffff : colors });
    return this.#put(id, new THREE.Points(geometry, material));
  }

  // The axes of a frame (x red, y green, z blue), `length` m.
  setAxes(id, length = 0.6) {
    return this.#put(id, new THREE.AxesHelper(length));
  }

  // An axis-aligned box {min, max} as lines.
  setBox(id, { min, max }, color = 0xffcc44) {
    const box = new THREE.Box3(new THREE.Vector3(...min), new THREE.Vector3(...max));
    return this.#put(id, new THREE.Box3Helper(box, color));
  }

  setObject(id, object) {
    return this.#put(id, object);
  }

  // Places an object by a row-major 4x4 (THREE's Matrix4.set takes row-major too).
  setPose(id, m) {
    const object = this.#objects.get(id);
    if (!object) return;
    object.matrixAutoUpdate = false; // placed by its pose from now on
    object.matrix.set(...m);
    object.matrixWorldNeedsUpdate = true;
    this.render();
  }

  // Draws every `step`-th point of a cloud only (1: all); cheap previews while poses animate.
  // The preview is a copy (drawArrays): an index buffer costs more than it saves in software GL.
  setStride(id, step) {
    const geometry = this.#objects.get(id)?.geometry;
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
    this.render();
  }

  setVisible(id, visible) {
    const object = this.#objects.get(id);
    if (object && object.visible !== visible) {
      object.visible = visible;
      this.render();
    }
  }

  remove(id) {
    const object = this.#objects.get(id);
    if (!object) return;
    this.#scene.remove(object);
    object.traverse((o) => {
      o.geometry?.dispose();
      o.material?.dispose();
    });
    this.#objects.delete(id);
    this.render();
  }

  clear() {
    for (const id of [...this.#objects.keys()]) this.remove(id);
  }

  // Looks at a box {min, max} from behind (-x), a little to the right and above.
  lookAt({ min, max }) {
    const centre = new THREE.Vector3(...min).add(new THREE.Vector3(...max)).multiplyScalar(0.5);
    const size = Math.max(max[0] - min[0], max[1] - min[1], max[2] - min[2], 0.5);
    this.#controls.target.copy(centre);
    this.#camera.position.copy(centre).add(new THREE.Vector3(-1.3, -0.5, 0.7).multiplyScalar(size));
    this.#controls.update();
    this.render();
  }
}
