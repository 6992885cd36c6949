// What the browser keeps for the next visit (store.js, session.js), kept a moment after each
// change and not during a run (its cores are the calculation's), with the link following the
// settings and the rig; and on opening, the kept work restored, unless the link asks for
// another demo than the one kept (a link's settings win over the kept ones).
import * as store from './store.js';
import { keptScans, restoreSession, sessionOf } from './session.js';
import { DEFAULTS, explicitSettings, readRig, writeHash } from './url.js';
import { countLine } from '../panels/summary.js';

const PERSIST_MS = 300;
const DEMO_KEYS = ['demo', 'seed', 'frames', 'maxAngleDeg', 'maxTranslation'];

// `page`: what main.js lends: {$, state, settings, setNextId(n), setStatus, renderPanels,
// showResults, setStale, redraw, viewerLookAt, clearAll}. Returns {persist(), forget(),
// start(loadMethods, loadDemo)}.
export function initKeeping(page) {
  const { $, state, settings, setStatus } = page;
  let timer = null;

  function persist() {
    clearTimeout(timer);
    writeHash(state.settings, state.rig);
    timer = setTimeout(() => (state.running ? persist() : store.save(keptScans(state), sessionOf(state))), PERSIST_MS);
  }

  async function forget() {
    clearTimeout(timer);
    await store.clear();
    writeHash(state.settings, state.rig);
  }

  // On opening: the work kept in this browser comes back, unless the link asks for another demo
  // than the one kept; a link's settings win over the kept ones.
  async function start(loadMethods, loadDemo) {
    await loadMethods();
    const link = explicitSettings();
    const kept = await store.load();
    const sameDemo = (k) => DEMO_KEYS.every((key) => (link[key] ?? DEFAULTS[key]) === (k.session.settings[key] ?? DEFAULTS[key]));
    if (kept && (kept.scans.length || kept.session.results) && (!link.demo || sameDemo(kept))) await restore(kept, link);
    else if (state.settings.demo) await loadDemo();
  }

  async function restore(kept, link) {
    try {
      page.setNextId(restoreSession(state, kept, link));
      const rigLink = readRig();
      if (rigLink.roi) state.rig.roi = rigLink.roi;
      if (rigLink.parent) state.rig.parent = rigLink.parent;
      if (rigLink.reference && state.rig.sensors.includes(rigLink.reference)) state.rig.reference = rigLink.reference;
      settings.sync();
      $('colour').value = state.colour;
      $('all-frames').checked = state.allFrames;
      page.renderPanels();
      const stale = kept.session.stale;
      if (state.results) {
        const show = state.show;
        await page.showResults(state.results, state.failures, state.resultJson);
        if (show === 'before') document.querySelector('input[name=show][value=before]').click();
        if (stale) page.setStale(stale);
      }
      page.redraw();
      page.viewerLookAt();
      const what = [state.scans.length && `${countLine(state)}`, 'the rig and the settings', state.results && `the last result${stale ? ' (out of date)' : ''}`].filter(Boolean);
      setStatus(`Restored from this browser: ${what.join(', ')}. Clear forgets them.`);
    } catch (error) {
      // A record this page cannot read (an older version's) is no reason to fail: start afresh.
      page.clearAll();
      await store.clear();
      setStatus('Load scans or run the demo.');
    }
  }

  return { persist, forget, start };
}
