// The main view's tools, around the viewer: the sensors' legend with show/hide, point size,
// the colour scale, preset views and focus, picking a point (its sensor, frame and vehicle
// coordinates), measuring between two picks, and saving the view as PNG.
import { sensorColour } from './display.js';
import { rampCss, rampStops } from './colouring.js';

const CLICK_SLOP_PX = 4; // a press that moves further is an orbit, not a pick
const SCALE_TITLES = {
  height: 'height (vehicle z, m), 2nd–98th percentile',
  intensity: 'intensity, 2nd–98th percentile',
  distance: 'distance to the reference\'s surface (m)',
};

const hex = (c) => `#${c.toString(16).padStart(6, '0')}`;
const fmt = (p) => p.map((v) => v.toFixed(3)).join(', ');

// `el`: the toolbar's elements by id; `focusBounds(key)`: the box to frame for a focus choice;
// `onChange()`: redraw the view after a show/hide; `verdictLine()`: {level, text} of the result
// shown, or null, for the PNG.
export function initViewTools({ viewer, state, el, focusBounds, onChange, onError, verdictLine = () => null }) {
  let measuring = false;
  let picks = []; // [{sensor, frame, point}]

  el.pointSize.addEventListener('input', () => viewer.setPointSize(Number(el.pointSize.value)));
  for (const button of el.looks) button.addEventListener('click', () => viewer.lookFrom(button.dataset.look));
  el.focus.addEventListener('change', () => {
    const bounds = el.focus.value && focusBounds(el.focus.value);
    if (bounds) viewer.lookAt(bounds);
    el.focus.value = '';
  });
  el.legend.addEventListener('change', (e) => {
    const name = e.target.dataset.sensor;
    if (name === undefined) return;
    if (e.target.checked) state.hidden.delete(name);
    else state.hidden.add(name);
    onChange();
  });

  const showPicks = () => {
    viewer.setMarks(picks.map((p) => p.point));
    el.readout.hidden = !picks.length && !measuring;
    const lines = picks.map((p, i) => `${picks.length > 1 ? `${'AB'[i]}: ` : ''}${p.sensor} (frame ${p.frame}): ${fmt(p.point)} m`);
    if (picks.length === 2) {
      const d = Math.hypot(...[0, 1, 2].map((k) => picks[0].point[k] - picks[1].point[k]));
      lines.push(`distance A–B: ${d.toFixed(3)} m`);
    } else if (measuring) lines.push(picks.length ? 'click the second point' : 'Measure: click the first point');
    el.readout.textContent = lines.join('\n');
  };
  const setMeasuring = (on) => {
    measuring = on;
    el.measure.setAttribute('aria-pressed', String(on));
    picks = [];
    showPicks();
  };
  el.measure.addEventListener('click', () => setMeasuring(!measuring));
  document.addEventListener('keydown', (e) => e.key === 'Escape' && (measuring || picks.length) && setMeasuring(false));

  let down = null;
  el.view.addEventListener('pointerdown', (e) => (down = { x: e.clientX, y: e.clientY }));
  el.view.addEventListener('pointerup', async (e) => {
    if (!down || Math.hypot(e.clientX - down.x, e.clientY - down.y) > CLICK_SLOP_PX) return;
    down = null;
    const hit = await viewer.pick(e.clientX, e.clientY);
    if (!hit) return;
    const scan = state.scans.find((s) => s.id === hit.id);
    const pick = { sensor: hit.sensor, frame: scan?.frame ?? '?', point: hit.point };
    picks = measuring && picks.length === 1 ? [picks[0], pick] : [pick];
    showPicks();
  });

  // What the PNG carries besides the points: the verdict line, the sensors' legend (coloured by
  // sensor) or the colour bar (coloured by a value), and what is shown.
  const overlay = () => {
    const byValue = !el.scale.hidden;
    return {
      verdict: verdictLine(),
      legend: byValue ? [] : state.rig.sensors.map((name, i) => ({ name, colour: hex(sensorColour(i)) })).filter((s) => !state.hidden.has(s.name)),
      scale: byValue ? { title: el.scaleTitle.textContent, lo: el.scaleLo.textContent, hi: el.scaleHi.textContent, stops: rampStops() } : null,
      caption: state.results && state.show === 'after' ? 'after calibration' : 'before calibration (nominal extrinsics)',
    };
  };

  el.save.addEventListener('click', async () => {
    try {
      const blob = await viewer.snapshot(overlay());
      const url = URL.createObjectURL(blob);
      const a = Object.assign(document.createElement('a'), { href: url, download: 'gmmcalib-view.png' });
      a.click();
      setTimeout(() => URL.revokeObjectURL(url), 0);
    } catch (error) {
      onError(error);
    }
  });

  return {
    // The sensors, each with its colour and a show/hide box.
    renderLegend() {
      el.legend.replaceChildren(...state.rig.sensors.map((s, i) => {
        const label = document.createElement('label');
        label.title = `Show or hide ${s}'s points`;
        const box = Object.assign(document.createElement('input'), { type: 'checkbox', checked: !state.hidden.has(s) });
        box.dataset.sensor = s;
        box.setAttribute('aria-label', `show ${s}`);
        const dot = Object.assign(document.createElement('span'), { className: 'dot', textContent: '●' });
        dot.style.color = hex(sensorColour(i));
        label.append(box, dot, ` ${s}`);
        return label;
      }));
      el.legend.classList.toggle('muted', state.colour !== 'sensor');
    },
    // The colour scale of the mode the worker coloured by ({mode, range, missing}).
    renderScale({ mode, range, missing, median }) {
      el.legend.classList.toggle('muted', mode !== 'sensor');
      el.scale.hidden = mode === 'sensor';
      if (mode === 'sensor') return;
      el.scaleTitle.textContent = scaleNote(mode, range, missing) + (median != null ? `; median ${(median * 100).toFixed(1)} cm` : '');
      el.scale.dataset.median = median ?? '';
      el.scale.querySelector('.bar').style.background = range ? rampCss() : '#5c636e';
      el.scaleLo.textContent = range ? range[0].toFixed(mode === 'intensity' ? 0 : 2) : '';
      el.scaleHi.textContent = range ? `${range[1].toFixed(mode === 'intensity' ? 0 : 2)}${mode === 'distance' ? ' and beyond' : ''}` : '';
      el.scale.dataset.mode = mode;
    },
    // Focus choices: everything, the ROI (given, or the one the last result cropped to), each
    // sensor, each target the last result fitted.
    renderFocus() {
      const roi = state.rig.roi ?? state.results?.[0]?.roi;
      const fits = state.results?.[0]?.reconstruction.fits ?? [];
      const choices = [['', '…'], ['all', 'everything'], ...(roi ? [['roi', 'the ROI']] : []),
        ...state.rig.sensors.map((s) => [`sensor:${s}`, `sensor ${s}`]),
        ...fits.map((_, i) => [`target:${i}`, fits.length === 1 ? 'the target' : `target ${i + 1}`])];
      el.focus.replaceChildren(...choices.map(([v, t]) => new Option(t, v)));
    },
    clearPicks: () => setMeasuring(false),
  };
}

// The scale's title, saying what is grey and why.
function scaleNote(mode, range, missing) {
  if (mode === 'intensity' && !range) return 'intensity: these scans carry none (grey)';
  if (mode === 'intensity' && missing.length) return `${SCALE_TITLES.intensity}; grey: no intensity (${missing.join(', ')})`;
  if (mode === 'distance') return `${SCALE_TITLES.distance}; grey: the reference, or no surface of it within 25 cm`;
  return SCALE_TITLES[mode];
}
