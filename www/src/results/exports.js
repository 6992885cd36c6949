// Exports of one calibration result (the report shape): text generators, and the panel that
// offers each with copy and download. Every extrinsic is T_parent_child: `vehicle` (the frame
// the nominal extrinsics and ROI are given in) is the parent, each sensor the child.

const num = (x) => String(+x.toPrecision(10));

// The result as JSON, typed arrays as plain arrays.
export const resultJson = (result) =>
  JSON.stringify(result, (_, v) => (ArrayBuffer.isView(v) ? Array.from(v) : v), 2);

// The reconstructed target as ASCII PLY: components holding data, with sigma and prior.
export function targetPly({ means, sigmas, priors }) {
  const used = [];
  for (let k = 0; k < sigmas.length; k++) if (priors[k] > 0) used.push(k);
  const header = ['ply', 'format ascii 1.0', 'comment gmmcalib reconstructed target (vehicle frame, m)',
    `element vertex ${used.length}`, 'property float x', 'property float y', 'property float z',
    'property float sigma', 'property float prior', 'end_header'];
  const body = used.map((k) => [means[3 * k], means[3 * k + 1], means[3 * k + 2], sigmas[k], priors[k]].map(num).join(' '));
  return `${[...header, ...body].join('\n')}\n`;
}

// Every export of `result`. The ROS forms and GMMCalib's YAML come from the library's writers
// (`ros`: the worker's `exports` request, given [{parent, child, pose}] and the ROI), as the
// CLI's --export and `gmmcalib simulate` write them.
// `parent`: the vehicle frame's name (a recording's base frame, or the name the user gave it);
// each sensor is the child of its own name (a recording's frame id), in every export alike.
export async function exportsOf(result, { roi, parent = 'vehicle' }, ros) {
  const texts = await ros(result.sensors.map((s) => ({ parent, child: s.name, pose: Array.from(s.extrinsic) })), roi);
  const direction = `T_${parent}_sensor: maps each sensor's points into ${parent} (parent ${parent}, child the sensor)`;
  const out = [
    { key: 'json', title: 'JSON (everything)', direction: `as the CLI's --json; matrices row-major T_${parent}_sensor / C_ref_s / T_ref_s`, file: 'gmmcalib-result.json', text: resultJson(result) },
    { key: 'yaml', title: 'GMMCalib YAML', direction: `transform_<sensor>: sensor -> ${parent}`, file: 'config-calibrated.yaml', text: texts.gmmcalibYaml },
    { key: 'urdf', title: 'URDF origins', direction, file: 'extrinsics.urdf.xml', text: texts.urdf },
    { key: 'ros2', title: 'ROS 2 static_transform_publisher', direction: `--frame-id ${parent} (parent), --child-frame-id the sensor`, file: 'static_transforms.sh', text: texts.ros2 },
    { key: 'ros1', title: 'ROS 1 static_transform_publisher', direction: `positional x y z yaw pitch roll (yaw first), then ${parent} (parent) and the sensor`, file: 'static_transforms_ros1.sh', text: texts.ros1 },
    { key: 'tfYaml', title: '/tf_static YAML', direction: `header.frame_id ${parent}, child_frame_id the sensor`, file: 'tf_static.yaml', text: texts.tfYaml },
    { key: 'autoware', title: 'Autoware sensor_kit_calibration.yaml', direction, file: 'sensor_kit_calibration.yaml', text: texts.autoware },
    { key: 'kitti', title: 'KITTI Tr (3x4)', direction, file: 'calib_tr.txt', text: texts.kitti },
  ];
  if (result.reconstruction.priors.length) {
    out.push({ key: 'ply', title: 'Reconstructed target (PLY)', direction: `points in ${parent} (where the reference sees the target)`, file: 'target.ply', text: targetPly(result.reconstruction) });
  }
  return out;
}

// The export panel: one block per export with copy and download.
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

function button(label, onClick) {
  const b = document.createElement('button');
  b.type = 'button';
  b.textContent = label;
  b.addEventListener('click', onClick);
  return b;
}
