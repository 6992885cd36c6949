// One-line summaries of the setup, for the folded panels' headers and for why Calibrate is
// disabled.

const plural = (n, word) => `${n} ${word}${n === 1 ? '' : 's'}`;

// "3 scans of 3 sensors": the status line's count after a load or a reassignment.
export const countLine = ({ scans, rig }) => `${plural(scans.length, 'scan')} of ${plural(rig.sensors.length, 'sensor')}`;

// "8 scans of 2 sensors (4 frames each)", or '' before anything is loaded.
export function describeScans({ scans, rig, bad }) {
  if (!scans.length) return bad.length ? `${plural(bad.length, 'file')} with problems` : '';
  const frames = new Set(scans.map((s) => s.frame)).size;
  return `— ${plural(scans.length, 'scan')} of ${plural(rig.sensors.length, 'sensor')}, ${plural(frames, 'frame')}${bad.length ? `, ${bad.length} with problems` : ''}`;
}

// "reference front_left, gmm, cube:0.5, ROI auto".
export function describeRig({ rig, settings }) {
  if (!rig.sensors.length) return '';
  return `— reference ${rig.reference}, ${settings.method}, target ${settings.target}, ROI ${rig.roi ? 'set' : 'auto'}`;
}

// Why a calibration cannot start now, in words, or '' when it can.
export function calibrateBlocker({ scans, rig }) {
  if (!scans.length) return 'Load scans (or the demo) first.';
  if (rig.sensors.length < 2) {
    return `Needs scans of two sensors or more; all ${plural(scans.length, 'scan')} belong to ${rig.sensors[0]}. Assign files to sensors in the table above.`;
  }
  // Scans of different sensors calibrate together only when their frame names match.
  const sensorsOf = new Map();
  for (const v of scans) sensorsOf.set(v.frame, (sensorsOf.get(v.frame) ?? new Set()).add(v.sensor));
  if (![...sensorsOf.values()].some((set) => set.size > 1)) {
    return 'No frame is shared by two sensors: scans taken at the same instant need the same frame name. Set the frames in the table above.';
  }
  return '';
}
