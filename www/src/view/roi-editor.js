// The ROI drawn in the view with a handle on each face: dragging a handle moves that face along
// its axis, the six numbers of the rig panel following as it moves. The camera lives on the main
// thread (viewer.js), so a handle is found and dragged here without asking the render worker:
// the handles are projected with the camera, and the pointer's ray is met with the face's axis.
const HANDLE_PX = 12; // how near the pointer a handle is grabbed (CSS px)
const MIN_SIZE = 0.05; // m: a face stops this short of the opposite one
const AXES = ['x', 'y', 'z'];

// The six handles of `roi`: {key: 'min.x', ..., point: [x, y, z] (the face's centre)}.
export function handlesOf(roi) {
  const centre = roi.min.map((v, i) => (v + roi.max[i]) / 2);
  return ['min', 'max'].flatMap((side) => AXES.map((name, axis) => {
    const point = [...centre];
    point[axis] = roi[side][axis];
    return { key: `${side}.${name}`, side, axis, point };
  }));
}

// Where along `axis` through `point` the ray {origin, direction} passes closest: the coordinate
// on that axis, or null when the ray runs (nearly) along it.
export function alongAxis(point, axis, { origin, direction }) {
  const e = [0, 0, 0];
  e[axis] = 1;
  const w = point.map((p, i) => p - origin[i]);
  const b = direction[axis]; // e . d
  const dd = direction.reduce((s, v) => s + v * v, 0);
  const denom = dd - b * b;
  if (denom < 1e-6 * dd) return null;
  const ew = w[axis];
  const dw = direction.reduce((s, v, i) => s + v * w[i], 0);
  return point[axis] + (b * dw - dd * ew) / denom;
}

// `viewer`: the main view; `canvas` its canvas, `wrap` the element around it (its capturing
// pointerdown comes before the orbit controls'); `getRoi()`: the editable ROI or null (auto);
// `onDrag(roi)` as a face moves, `onDrop(roi)` once it is let go. Returns {update()}: call when
// the ROI changes; the canvas's `data-handles` (test hook, like `data-points`) gives each
// handle's canvas pixel.
export function initRoiEditor({ viewer, canvas, wrap, getRoi, onDrag, onDrop }) {
  let drag = null; // {handle, roi}

  const shown = () => {
    const roi = getRoi();
    if (!roi) return [];
    const handles = handlesOf(roi);
    return viewer.project(handles.map((h) => h.point)).map((px, i) => ({ ...handles[i], px }));
  };
  const update = () => {
    const handles = shown().filter((h) => h.px);
    const value = handles.length ? JSON.stringify(Object.fromEntries(handles.map((h) => [h.key, h.px.map((v) => +v.toFixed(1))]))) : '';
    if (canvas.dataset.handles !== value) canvas.dataset.handles = value;
  };
  const at = (e) => {
    const r = canvas.getBoundingClientRect();
    return [e.clientX - r.left, e.clientY - r.top];
  };
  const nearest = (xy) => {
    let best = null;
    for (const h of shown()) {
      if (!h.px) continue;
      const d = Math.hypot(h.px[0] - xy[0], h.px[1] - xy[1]);
      if (d <= HANDLE_PX && (!best || d < best.d)) best = { d, h };
    }
    return best?.h ?? null;
  };

  wrap.addEventListener('pointerdown', (e) => {
    if (e.target !== canvas || e.button !== 0) return;
    const handle = nearest(at(e));
    if (!handle) return;
    // The grab is the handle's, not the orbit's.
    e.stopPropagation();
    e.preventDefault();
    viewer.orbiting = false;
    canvas.setPointerCapture(e.pointerId);
    drag = { handle, roi: structuredClone(getRoi()) };
  }, { capture: true });

  canvas.addEventListener('pointermove', (e) => {
    if (!drag) {
      canvas.style.cursor = nearest(at(e)) ? 'grab' : '';
      return;
    }
    const { axis, side, point } = drag.handle;
    const value = alongAxis(point, axis, viewer.ray(...at(e)));
    if (value === null || !Number.isFinite(value)) return;
    const roi = drag.roi;
    roi[side][axis] = side === 'min' ? Math.min(value, roi.max[axis] - MIN_SIZE) : Math.max(value, roi.min[axis] + MIN_SIZE);
    roi[side][axis] = +roi[side][axis].toFixed(3); // mm: what the numbers show
    onDrag(structuredClone(roi));
    update();
  });

  const end = (e) => {
    if (!drag) return;
    canvas.releasePointerCapture?.(e.pointerId);
    viewer.orbiting = true;
    const { roi } = drag;
    drag = null;
    onDrop(structuredClone(roi));
    update();
  };
  canvas.addEventListener('pointerup', end);
  canvas.addEventListener('pointercancel', end);
  viewer.onCamera(update);
  return { update };
}
