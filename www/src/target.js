// The reconstructed target for its own small view: one sphere per mixture component (radius =
// sigma, only components holding data) and the fitted prior as a wireframe. The mixture floats
// (its frame is not the vehicle's), so it is shown apart from the clouds.
import * as THREE from 'three';

// Cube yaw about z that best fits the means (the report gives centre and edge, not the pose):
// least prior-weighted distance to the cube surface over 1-degree steps.
function cubeYaw(means, priors, centre, edge) {
  const h = edge / 2;
  let best = { yaw: 0, cost: Infinity };
  for (let step = 0; step < 90; step++) {
    const yaw = (step * Math.PI) / 180;
    const [c, s] = [Math.cos(yaw), Math.sin(yaw)];
    let cost = 0;
    for (let k = 0; k < priors.length; k++) {
      if (!(priors[k] > 0)) continue;
      const dx = means[3 * k] - centre[0], dy = means[3 * k + 1] - centre[1], dz = means[3 * k + 2] - centre[2];
      const q = [Math.abs(c * dx + s * dy) - h, Math.abs(-s * dx + c * dy) - h, Math.abs(dz) - h];
      const outside = Math.hypot(...q.map((v) => Math.max(v, 0)));
      cost += priors[k] * (outside + Math.min(Math.max(...q), 0)) ** 2;
    }
    if (cost < best.cost) best = { yaw, cost };
  }
  return best.yaw;
}

export function targetObject({ means, sigmas, priors, edge, centre }, prior) {
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
  if (edge && centre) {
    const geometry = prior.kind === 'sphere' ? new THREE.SphereGeometry(edge / 2, 16, 12) : new THREE.BoxGeometry(edge, edge, edge);
    const wire = new THREE.LineSegments(new THREE.EdgesGeometry(geometry), new THREE.LineBasicMaterial({ color: 0xffcc44 }));
    wire.position.set(...centre);
    if (prior.kind !== 'sphere') wire.rotation.z = cubeYaw(means, priors, centre, edge);
    geometry.dispose();
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
