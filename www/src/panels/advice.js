// @ts-check
// What the page advises when a run cannot give a good answer for a reason a user can fix: a
// reference that cannot be registered (choose this sensor instead), a target shape that is not
// in the data (set the target to none, or draw the ROI), a ROI auto that found only the clouds'
// overlap. Each advice carries the one action that follows it, for a button.
import { esc } from '../results/answer.js';

// What to do about a run that failed, where the page can say: {text, action: {label, what,
// value}} with `what` 'reference' (make `value` the reference) or 'target' (set the target to
// `value`) or 'roi' (draw the ROI), or null. A reference that cannot be registered against
// gets the sensor to choose instead: the one with the most points after it.
export function adviceForError(message, { scans, rig, settings }) {
  const failed = /no frame of sensor '(.+?)' could be registered/.exec(message);
  if (failed) {
    const points = new Map();
    for (const v of scans) points.set(v.sensor, (points.get(v.sensor) ?? 0) + v.points.length / 3);
    const others = rig.sensors.filter((s) => s !== rig.reference).sort((a, b) => points.get(b) - points.get(a));
    const instead = others[0];
    if (!instead) return null;
    const sensor = failed[1];
    return {
      text: `${sensor} could not be registered onto ${rig.reference}, the reference. Choose another reference: ${instead} has the most points after ${rig.reference}${instead === sensor ? '' : ` (or try ${sensor})`}.`,
      action: { label: `Make ${instead} the reference`, what: 'reference', value: instead },
    };
  }
  const empty = /sensor '(.+?)' has no usable points in the ROI/.exec(message);
  if (empty) {
    return {
      text: `Draw the ROI where ${empty[1]} sees what ${rig.reference} sees${settings.global === 'off' ? ', or turn the global alignment on: the nominal may be far off' : ''}.`,
      action: { label: 'Draw the ROI', what: 'roi' },
    };
  }
  if (/was found standing nowhere|overlap nowhere/.test(message)) {
    const none = settings.target !== 'none' && !/overlap nowhere/.test(message);
    return {
      text: none ? 'Draw the ROI around the targets in the view (ROI auto off, then drag its handles), or calibrate on the scene itself: target none.' : 'Draw the ROI around what the sensors see in common: turn ROI auto off and drag its handles in the view.',
      action: none ? { label: 'Target: none', what: 'target', value: 'none' } : { label: 'Draw the ROI', what: 'roi' },
    };
  }
  return null;
}

// The library's finding that no target stands out of the reconstruction (a reason of the run).
const noTarget = (/** @type {import('../result').PageResult} */ r) => r.verdict.reasons.find((x) => x.kind === 'noTarget');

// Advice for a result: a target shape given (`context.target`, as the run had it) and none
// found. [{html, action}], empty when there is nothing to advise.
/** @param {import('../result').PageResult} r @param {{target: string, roiAuto: boolean}} [context] */
export function adviceForResult(r, context) {
  const missing = noTarget(r);
  if (!missing || !context || context.target === 'none' || context.target.startsWith('mesh:')) return [];
  const where = context.roiAuto ? ` The ROI was auto: ${r.roi.source === 'targets' ? `around ${objects(r.roi.found)} of its size standing in the reference's scans, none of which stood out as it.` : 'with no target found it is where the clouds overlap.'}` : '';
  return [{
    html: `No ${esc(context.target)} found: ${esc(missing.text)}.${where} Set the target to none to calibrate on the scene itself, or draw the ROI around the targets.`,
    actions: [{ label: 'Target: none', what: 'target', value: 'none' }, { label: 'Draw the ROI', what: 'roi' }],
  }];
}

const size = (/** @type {import('../result').RoiReport} */ roi) => roi.max.map((v, i) => (v - roi.min[i]).toFixed(1)).join(' × ');

const objects = (n) => `${n} object${n === 1 ? '' : 's'}`;

// What the last run's auto ROI held, for the rig panel: {text, level}, or null (a ROI given,
// no run). The library says where the region came from (`roi.source`): around objects of the
// target's shape found standing in the reference's scans (`found`), which the reconstruction
// then fits or not, or the clouds' overlap.
/** @param {import('../result').PageResult | null} r @param {{target: string, roiAuto: boolean}} [context] */
export function autoRoiFound(r, context) {
  if (!r || !context?.roiAuto) return null;
  const fits = r.reconstruction.fits.length;
  const draw = 'Draw the ROI around the targets (untick auto, drag the handles) or set the target to none.';
  if (r.roi.source === 'targets' && !noTarget(r)) {
    return { level: 'good', text: `Last run: ${fits === 1 ? 'a target' : `${fits} targets`} found; the ROI around them, ${size(r.roi)} m, is drawn grey in the view.` };
  }
  if (r.roi.source === 'targets') {
    return { level: 'failed', text: `Last run: the ROI was put around ${objects(r.roi.found)} of the target's size standing in the reference's scans, ${size(r.roi)} m (grey in the view), but no ${context.target} stood out of the reconstruction. ${draw}` };
  }
  if (context.target !== 'none' && noTarget(r)) {
    return { level: 'failed', text: `Last run: no ${context.target} found, so the ROI was the clouds' whole overlap, ${size(r.roi)} m (grey in the view). ${draw}` };
  }
  return { level: 'good', text: `Last run: the sensors' clouds overlap in ${size(r.roi)} m, the ROI drawn grey in the view.` };
}
