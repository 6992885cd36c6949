// The rig panel: per sensor the nominal extrinsic (x, y, z in m; roll, pitch, yaw in deg) and
// the reference choice; the ROI, 'auto' (null: the library's choice) or bounds. Edits go
// straight into `rig` ({sensors, nominal, roi, reference}); `onChange(what)` tells the page to
// update the view.
import { degrees, radians } from './transforms.js';
import { DEFAULT_ROI } from './state.js';

function numberInput(value, step, onInput, label) {
  const input = Object.assign(document.createElement('input'), { type: 'number', step, value: +value.toFixed(6) });
  input.setAttribute('aria-label', label);
  input.addEventListener('change', () => {
    const v = Number(input.value);
    if (input.value !== '' && Number.isFinite(v)) onInput(v);
    else input.value = +value.toFixed(6);
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

export function renderRig(container, rig, onChange) {
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
  const auto = Object.assign(document.createElement('input'), { type: 'checkbox', checked: !rig.roi });
  auto.setAttribute('data-testid', 'roi-auto');
  auto.addEventListener('change', () => {
    rig.roi = auto.checked ? null : structuredClone(DEFAULT_ROI);
    renderRig(container, rig, onChange);
    onChange('roi');
  });
  const label = document.createElement('label');
  label.append(auto, ' ROI auto: where the sensors\' clouds overlap');
  label.title = 'Region of interest: only points inside it (vehicle frame) are registered; auto crops to where the sensors\' clouds overlap';
  const parts = [table, label];
  if (rig.roi) {
    const roi = document.createElement('table');
    roi.className = 'rig';
    roi.innerHTML = '<tr><th>ROI (m)</th><th>x</th><th>y</th><th>z</th></tr>';
    for (const bound of ['min', 'max']) {
      const tr = document.createElement('tr');
      tr.append(cell(bound));
      for (let k = 0; k < 3; k++) tr.append(cell(numberInput(rig.roi[bound][k], 0.1, (v) => { rig.roi[bound][k] = v; onChange('roi'); }, `ROI ${bound} ${'xyz'[k]}`)));
      roi.append(tr);
    }
    parts.push(roi);
  }
  container.replaceChildren(...parts);
}
