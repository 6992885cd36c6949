// @ts-check
// Exports of one calibration result. The library writes every text (the result's `exports`,
// made by `calibrate` for the vehicle frame named at the run); this module titles them and
// offers each with copy and download. Every extrinsic is T_parent_child: `parent` (the frame
// the nominal extrinsics and ROI are given in) is the parent, each sensor the child of its name.

/** @typedef {import('../result').PageResult} PageResult */
/** @typedef {import('../result').Exports} Exports */
/** @typedef {{ key: string, title: string, direction: string, file: string, text: string }} ExportItem */

// The JSON view's text: the outcomes as the page holds them, typed arrays as plain arrays, each
// result's exports left to the export panel.
export const resultJson = (/** @type {unknown} */ value) =>
  JSON.stringify(value, (key, v) => (key === 'exports' ? undefined : ArrayBuffer.isView(v) ? Array.from(/** @type {Float32Array} */ (v)) : v), 2);

// The texts of `result` for `parent`: its own, or, for a frame renamed since the run, the
// library's again (`remake`: the worker's `exports`); the JSON names no frame and stays.
/**
 * @param {PageResult} result
 * @param {string} parent
 * @param {(input: object) => Promise<Exports>} remake
 * @returns {Promise<Exports>}
 */
export async function exportTexts(result, parent, remake) {
  const made = result.exports;
  if (made?.parent === parent) return made;
  const { sensors, roi, reconstruction } = result;
  const again = await remake({ parent, sensors, roi, reconstruction });
  // A result opened from a file, or kept from before results carried their JSON: the page's copy.
  return { ...again, json: made?.json ?? resultJson(result) };
}

// The export panel's items: each text with its title, its direction and its file name.
/**
 * @param {Exports} texts
 * @returns {ExportItem[]}
 */
export function exportItems(texts) {
  const parent = texts.parent;
  const direction = `T_${parent}_sensor: maps each sensor's points into ${parent} (parent ${parent}, child the sensor)`;
  const out = [
    { key: 'json', title: 'JSON (everything)', direction: `the CLI's --json, byte for byte; matrices row-major T_${parent}_sensor / C_ref_s / T_ref_s`, file: 'gmmcalib-result.json', text: texts.json },
    { key: 'yaml', title: 'GMMCalib YAML', direction: `transform_<sensor>: sensor -> ${parent}`, file: 'config-calibrated.yaml', text: texts.gmmcalibYaml },
    { key: 'urdf', title: 'URDF origins', direction, file: 'extrinsics.urdf.xml', text: texts.urdf },
    { key: 'ros2', title: 'ROS 2 static_transform_publisher', direction: `--frame-id ${parent} (parent), --child-frame-id the sensor`, file: 'static_transforms.sh', text: texts.ros2 },
    { key: 'ros1', title: 'ROS 1 static_transform_publisher', direction: `positional x y z yaw pitch roll (yaw first), then ${parent} (parent) and the sensor`, file: 'static_transforms_ros1.sh', text: texts.ros1 },
    { key: 'tfYaml', title: '/tf_static YAML', direction: `header.frame_id ${parent}, child_frame_id the sensor`, file: 'tf_static.yaml', text: texts.tfYaml },
    { key: 'autoware', title: 'Autoware sensor_kit_calibration.yaml', direction, file: 'sensor_kit_calibration.yaml', text: texts.autoware },
    { key: 'kitti', title: 'KITTI Tr (3x4)', direction, file: 'calib_tr.txt', text: texts.kitti },
  ];
  if (texts.targetPly) {
    out.push({ key: 'ply', title: 'Reconstructed target (PLY)', direction: `points in ${parent} (where the reference sees the target)`, file: 'target.ply', text: texts.targetPly });
  }
  return out;
}

// The export panel: one block per export with copy and download.
/**
 * @param {HTMLElement} container
 * @param {ExportItem[]} items
 */
export function renderExports(container, items) {
  container.replaceChildren();
  for (const item of items) {
    const block = document.createElement('details');
    block.className = 'export';
    block.dataset.export = item.key;
    const summary = document.createElement('summary');
    summary.textContent = item.title;
    const note = document.createElement('p');
    note.className = 'direction';
    note.textContent = item.direction;
    const copy = button('Copy', async () => {
      await navigator.clipboard.writeText(item.text);
      copy.textContent = 'Copied';
      setTimeout(() => (copy.textContent = 'Copy'), 1500);
    });
    const download = button('Download', () => {
      const url = URL.createObjectURL(new Blob([item.text], { type: 'text/plain' }));
      const a = Object.assign(document.createElement('a'), { href: url, download: item.file });
      a.click();
      setTimeout(() => URL.revokeObjectURL(url), 0);
    });
    const pre = document.createElement('pre');
    pre.textContent = item.text.length > 20000 ? `${item.text.slice(0, 20000)}\n… (${item.text.length} characters; download for all)` : item.text;
    block.append(summary, note, copy, download, pre);
    container.append(block);
  }
}

/**
 * @param {string} label
 * @param {() => unknown} onClick
 */
function button(label, onClick) {
  const b = document.createElement('button');
  b.type = 'button';
  b.textContent = label;
  b.addEventListener('click', onClick);
  return b;
}
