// The boxes the view frames: on opening (the ROI, else the data's robust extent, placed by the
// nominals) and for each focus choice (everything, the ROI, a sensor, a target).
import { boxAround, robustBounds } from './framing.js';
import { nominalPoses, shownPoses } from '../state/state.js';

const TARGET_MARGIN = 0.3; // m around a fitted target

// What the view frames when scans are loaded: the ROI when one is given, else the data.
export function openingBox(state) {
  return state.rig.roi ?? robustBounds(state.scans, nominalPoses(state), { hidden: state.hidden });
}

// The box for a focus choice: 'all' (every point shown, as placed now), 'roi' (given, or the one
// the last result cropped to), 'sensor:NAME', 'target:i'; null when there is none.
export function focusBox(state, key) {
  const poses = shownPoses(state);
  if (key === 'all') return robustBounds(state.scans, poses, { hidden: state.hidden });
  if (key === 'roi') return state.rig.roi ?? state.results?.[0]?.roi ?? null;
  if (key.startsWith('sensor:')) return robustBounds(state.scans, poses, { sensor: key.slice(7) });
  const fit = state.results?.[0]?.reconstruction.fits[Number(key.split(':')[1])];
  return fit ? boxAround(fit.centre, Math.max(...fit.extents) / 2 + TARGET_MARGIN) : null;
}
