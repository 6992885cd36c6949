// The rig panel: per sensor the nominal extrinsic (x, y, z in m; roll, pitch, yaw in deg) and
// the reference choice; the vehicle frame's name; the ROI, 'auto' (null: the library's choice,
// with what the last run found) or bounds, also dragged in the view (roi-editor.js). Edits go
// straight into `rig` ({sensors, nominal, roi, reference, parent}); `onChange(what)` tells the
// page to update the view.
import { degrees, radians } from '../transforms.js';
import { DEFAULT_ROI } from '../state/state.js';

function numberInput(value, step, onInput, label) {
  const input = Object.assign(document.createElement('input'), { type: 'number', step, value: +value.toFixed(6) });
  input.setAttribute('aria-label', label);
  input.dataset.value = input.value; // what a bad entry goes back to (showRoi keeps it current)
  input.addEventListener('change', () => {
    const v = Number(input.value);
    if (input.value !== '' && Number.isFinite(v)) {
      input.dataset.value = input.value;
      onInput(v);
    } else input.value = input.dataset.value;
  });
  return input;
}

function unit(text) {
  const th = document.createElement('th');
  th.className = 'unit';
  th.textContent = text;
  return th;
}

function cell(...children) {
  const td = document.createElement('td');
  td.append(...children);
  return td;
}

// `found`: what the last run's auto ROI held ({text, level}), said under the auto box;
// `startRoi()`: the box a user starts editing from when they turn auto off.
export function renderRig(container, rig, onChange, { found = null, startRoi = null } = {}) {
  const table = document.createElement('table');
  table.className = 'rig';
  // Per sensor three rows: the reference radio and the name, then xyz, then rpy: narrow enough
  // for a laptop's side panel with every value in full.
  table.innerHTML = '<tr><th title="The reference sensor keeps its nominal; the others are calibrated to it. Nominal T_vehicle_sensor: where the sensor sits in the vehicle frame (m), and its roll, pitch, yaw about the fixed x, y, z axes (deg)">ref / nominal</th>' +
    '<th>x / roll</th><th>y / pitch</th><th>z / yaw</th></tr>';
  for (const name of rig.sensors) {
    const pose = (rig.nominal[name] ??= { xyz: [0, 0, 0], rpy: [0, 0, 0] });
    const radio = Object.assign(document.createElement('input'), { type: 'radio', name: 'reference', checked: rig.reference === name });
    radio.setAttribute('aria-label', `reference ${name}`);
    radio.title = `Make ${name} the reference`;
    radio.addEventListener('change', () => {
      rig.reference = name;
      onChange('reference');
    });
    const head = document.createElement('tr');
    head.className = 'sensor-row';
    const nameCell = cell(radio, ` ${name}`);
    nameCell.colSpan = 4;
    nameCell.className = 'name';
    head.append(nameCell);
    const xyz = document.createElement('tr');
    xyz.append(unit('xyz (m)'));
    for (let k = 0; k < 3; k++) xyz.append(cell(numberInput(pose.xyz[k], 0.01, (v) => { pose.xyz[k] = v; onChange('nominal'); }, `${name} ${'xyz'[k]}`)));
    const rpy = document.createElement('tr');
    rpy.append(unit('rpy (deg)'));
    for (let k = 0; k < 3; k++) {
      rpy.append(cell(numberInput(degrees(pose.rpy[k]), 0.1, (v) => { pose.rpy[k] = radians(v); onChange('nominal'); }, `${name} ${['roll', 'pitch', 'yaw'][k]}`)));
    }
    table.append(head, xyz, rpy);
  }
  const parent = Object.assign(document.createElement('input'), { type: 'text', value: rig.parent, size: 12 });
  parent.setAttribute('aria-label', 'vehicle frame name');
  parent.addEventListener('change', () => {
    const name = parent.value.trim();
    if (name && /^[A-Za-z_][\w/.-]*$/.test(name)) {
      rig.parent = name;
      onChange('parent');
    } else parent.value = rig.parent;
  });
  const frameLabel = document.createElement('label');
  frameLabel.title = 'The frame the nominals and the ROI are given in, by the name your TF tree gives it: the parent of every transform the results and exports name (a recording\'s base frame)';
  frameLabel.append('vehicle frame ', parent);
  const auto = Object.assign(document.createElement('input'), { type: 'checkbox', checked: !rig.roi });
  auto.setAttribute('data-testid', 'roi-auto');
  auto.addEventListener('change', () => {
    rig.roi = auto.checked ? null : structuredClone(startRoi?.() ?? DEFAULT_ROI);
    renderRig(container, rig, onChange, { found, startRoi });
    onChange('roi');
  });
  const label = document.createElement('label');
  label.append(auto, ' ROI auto: around the targets found where the sensors\' clouds overlap, else that overlap');
  label.title = 'Region of interest: only points inside it (vehicle frame) are registered; auto finds it in each run. Off: drag the box\'s handles in the view, or type its bounds';
  const parts = [table, frameLabel, label];
  if (!rig.roi && found) {
    const note = document.createElement('p');
    note.className = `roi-found ${found.level}`;
    note.setAttribute('data-testid', 'roi-found');
    note.textContent = found.text;
    parts.push(note);
  }
  if (rig.roi) {
    const roi = document.createElement('table');
    roi.className = 'rig';
    roi.innerHTML = '<tr><th>ROI (m)</th><th>x</th><th>y</th><th>z</th></tr>';
    for (const bound of ['min', 'max']) {
      const tr = document.createElement('tr');
      tr.append(cell(bound));
      for (let k = 0; k < 3; k++) {
        const input = numberInput(rig.roi[bound][k], 0.1, (v) => { rig.roi[bound][k] = v; onChange('roi'); }, `ROI ${bound} ${'xyz'[k]}`);
        input.dataset.roi = `${bound}.${k}`;
        tr.append(cell(input));
      }
      roi.append(tr);
    }
    const hint = document.createElement('p');
    hint.className = 'hint';
    hint.textContent = 'Drag the white handles of the box in the view, or type the bounds.';
    parts.push(roi, hint);
  }
  container.replaceChildren(...parts);
}

// The six ROI inputs of a rendered panel set to `roi` (while a handle is dragged).
export function showRoi(container, roi) {
  for (const input of container.querySelectorAll('input[data-roi]')) {
    const [bound, k] = input.dataset.roi.split('.');
    input.value = +roi[bound][Number(k)].toFixed(6);
    input.dataset.value = input.value;
  }
}
