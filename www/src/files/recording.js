// A dropped recording (MCAP, ROS 1 .bag, rosbag2 .db3): its point-cloud topics to pick from,
// the reference, the number of instants, and a button that asks the library for the rig
// (`RecordingFile.rig` in the worker). The recording stays open in the worker until another
// one replaces it.

const RECORDING = /\.(mcap|bag|db3)$/i;
export const isRecording = (path) => RECORDING.test(path);

// Renders the picker for `opened` ({handle, topics, problems}) of `name` into `container`;
// `onLoad(options)` runs with {topics, reference, frames} when the user asks for the scans.
export function renderRecording(container, name, opened, onLoad) {
  const clouds = opened.topics.filter((t) => t.kind === 'pointCloud' && t.count > 0);
  const box = document.createElement('div');
  box.className = 'recording';
  box.setAttribute('data-testid', 'recording');
  const title = document.createElement('p');
  title.textContent = `${name}: ${opened.topics.length} topics, ${clouds.length} with point clouds. Pick the sensors, and the reference if you know it (else the sensor with the most points):`;
  const table = document.createElement('table');
  table.innerHTML = '<tr><th>use</th><th>ref</th><th>topic</th><th>scans</th><th>Hz</th></tr>';
  const rows = clouds.map((t) => {
    const use = Object.assign(document.createElement('input'), { type: 'checkbox', checked: true });
    use.setAttribute('aria-label', `use ${t.name}`);
    const ref = Object.assign(document.createElement('input'), { type: 'radio', name: 'recording-reference' });
    ref.setAttribute('aria-label', `recording reference ${t.name}`);
    const tr = document.createElement('tr');
    for (const c of [use, ref, t.name, String(t.count), t.rateHz.toFixed(1)]) {
      const td = document.createElement('td');
      td.append(c);
      tr.append(td);
    }
    table.append(tr);
    return { topic: t.name, use, ref };
  });
  const frames = Object.assign(document.createElement('input'), { type: 'number', min: 1, max: 100, value: 10 });
  frames.setAttribute('aria-label', 'instants');
  const label = document.createElement('label');
  label.append('instants ', frames);
  const load = Object.assign(document.createElement('button'), { type: 'button', textContent: 'Load scans' });
  load.setAttribute('data-testid', 'recording-load');
  load.addEventListener('click', () => {
    const chosen = rows.filter((r) => r.use.checked);
    // No reference picked: the library pairs instants by the first topic, the page takes the
    // sensor with the most points as the reference.
    const reference = chosen.find((r) => r.ref.checked)?.topic;
    onLoad({ topics: chosen.map((r) => r.topic), reference, frames: Math.max(1, Number(frames.value) || 10) });
  });
  box.replaceChildren(title, table, label, load);
  container.replaceChildren(box);
}

// One line on the instants a rig was taken at: how many, and the largest offset between a
// topic's scan and the reference's.
export function describeInstants(rig) {
  const offsets = rig.instants.flatMap(([, o]) => o.map(Math.abs));
  const largest = offsets.length ? Math.max(...offsets) : 0;
  return `${rig.instants.length} instants, offsets up to ${largest.toFixed(1)} ms${rig.moving ? '; the rig moved between instants: each instant\'s scans must see the same scene' : ''}${rig.identityNominals ? '; no /tf_static: identity nominals' : ''}`;
}
