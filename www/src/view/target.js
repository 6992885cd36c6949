// The reconstructed target for its own small view: one sphere per mixture component (radius =
// sigma, only components holding data) and the shape fitted to each target as a wireframe, all
// in the vehicle frame.
import * as THREE from 'three';

export function targetObject({ means, sigmas, priors, fits }) {
  const group = new THREE.Group();
  const used = [];
  for (let k = 0; k < sigmas.length; k++) if (priors[k] > 0) used.push(k);
  const mesh = new THREE.InstancedMesh(new THREE.SphereGeometry(1, 8, 6), new THREE.MeshBasicMaterial({ color: 0x7fd1ff, transparent: true, opacity: 0.55 }), used.length);
  const m = new THREE.Matrix4();
  used.forEach((k, i) => {
    const r = Math.max(sigmas[k], 1e-3);
    m.makeScale(r, r, r).setPosition(means[3 * k], means[3 * k + 1], means[3 * k + 2]);
    mesh.setMatrixAt(i, m);
  });
  group.add(mesh);
  const material = new THREE.LineBasicMaterial({ color: 0xffcc44 });
  for (const fit of fits) {
    const geometry = fit.shape === 'sphere' ? new THREE.SphereGeometry(fit.size / 2, 16, 12) : new THREE.BoxGeometry(...fit.extents);
    const wire = new THREE.LineSegments(new THREE.EdgesGeometry(geometry), material);
    geometry.dispose();
    wire.position.set(...fit.centre);
    // The fit's orientation arrives as a rotation vector (axis times angle).
    const axis = new THREE.Vector3(...fit.rotation);
    const angle = axis.length();
    if (angle > 0) wire.quaternion.setFromAxisAngle(axis.normalize(), angle);
    group.add(wire);
  }
  return group;
}

// The box around the used means, for framing the view.
export function targetBounds({ means, priors }) {
  const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
  for (let k = 0; k < priors.length; k++) {
    if (!(priors[k] > 0)) continue;
    for (let a = 0; a < 3; a++) {
      min[a] = Math.min(min[a], means[3 * k + a]);
      max[a] = Math.max(max[a], means[3 * k + a]);
    }
  }
  return Number.isFinite(min[0]) ? { min, max } : null;
}
