// Picking a point on screen: the point of a cloud nearest to a pixel, within a few pixels,
// nearest the camera among those. Runs in the render worker, over the points drawn.

// `positions` flat xyz (object frame), the first `count` of them drawn; `m` the object's
// model-view-projection (THREE Matrix4 elements, column-major); (x, y) the pixel in NDC (-1..1)
// and `radius` the reach in NDC units per axis ([rx, ry]). Returns {index, depth} or null.
export function nearestOnScreen(positions, count, m, x, y, [rx, ry]) {
  let best = null;
  for (let i = 0; i < count; i++) {
    const [px, py, pz] = [positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]];
    const w = m[3] * px + m[7] * py + m[11] * pz + m[15];
    if (w <= 0) continue;
    const sx = (m[0] * px + m[4] * py + m[8] * pz + m[12]) / w;
    const sy = (m[1] * px + m[5] * py + m[9] * pz + m[13]) / w;
    const dx = (sx - x) / rx, dy = (sy - y) / ry;
    if (dx * dx + dy * dy > 1) continue;
    if (!best || w < best.depth) best = { index: i, depth: w };
  }
  return best;
}
