// The loaded files: per file its sensor (editable: reassign by hand), frame, format, point
// count and dropped invalid points; per bad file its error.

export function renderFiles(container, { scans, bad, sensors }, onReassign) {
  const table = document.createElement('table');
  table.className = 'files';
  table.innerHTML = '<tr><th title="The file, with its folder">file</th>' +
    '<th title="The sensor the file belongs to (from its folder or name); type another name to reassign it">sensor</th>' +
    '<th title="The instant it was taken: scans of different sensors with the same frame name were taken at the same time">frame</th>' +
    '<th title="The file\'s format as read">format</th><th title="Valid points read">points</th>' +
    '<th title="Invalid points left out: NaN or infinite coordinates, and exact-zero returns (beams that hit nothing)">dropped</th></tr>';
  const list = document.createElement('datalist');
  list.id = 'sensor-names';
  list.append(...sensors.map((s) => Object.assign(document.createElement('option'), { value: s })));
  // Inputs as wide as the longest name they hold (within limits), so no name is cut off and
  // the table fits the side panel at 1280 px.
  const width = (values, lo, hi) => `${Math.min(hi, Math.max(lo, ...values.map((v) => v.length)) + 1.5)}ch`;
  const sensorWidth = width(scans.map((v) => v.sensor), 4, 18);
  const frameWidth = width(scans.map((v) => v.frame), 2, 16);
  for (const view of scans) {
    const tr = document.createElement('tr');
    const sensor = Object.assign(document.createElement('input'), { value: view.sensor });
    sensor.style.width = sensorWidth;
    sensor.setAttribute('list', 'sensor-names');
    sensor.setAttribute('aria-label', `sensor of ${view.path}`);
    sensor.addEventListener('change', () => sensor.value.trim() && onReassign(view, sensor.value.trim()));
    const frame = Object.assign(document.createElement('input'), { value: view.frame });
    frame.style.width = frameWidth;
    frame.setAttribute('aria-label', `frame of ${view.path}`);
    frame.addEventListener('change', () => frame.value.trim() && onReassign(view, view.sensor, frame.value.trim()));
    const cells = [breakable(view.path), sensor, frame, breakable(view.format), view.count.toLocaleString('en'), view.dropped.toLocaleString('en')];
    for (const c of cells) {
      const td = document.createElement('td');
      td.append(...[c].flat());
      tr.append(td);
    }
    tr.firstChild.title = view.path;
    table.append(tr);
  }
  for (const b of bad) {
    const tr = document.createElement('tr');
    tr.className = 'bad';
    tr.innerHTML = '<td></td><td colspan="5"></td>';
    tr.children[0].textContent = b.path;
    tr.children[1].textContent = b.error;
    table.append(tr);
  }
  container.replaceChildren(list, table);
}

// Text that may wrap after a '/', '_' or '-' (a path, 'PCD binary_compressed') rather than
// anywhere, as nodes for append.
function breakable(text) {
  return String(text).split(/(?<=[/_-])/).flatMap((part, i) => (i ? [document.createElement('wbr'), part] : [part]));
}
