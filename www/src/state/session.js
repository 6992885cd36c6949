// What of the page's state is kept in the browser (store.js) and how it comes back on reload:
// the scans (each with its sensor and frame as last assigned), the files with problems, the rig,
// the settings, a demo's truth, the CAD model, the view's choices, and the last result with what
// the run had (target, ROI auto) and whether it is out of date.

const SCAN_FIELDS = ['id', 'path', 'recording', 'points', 'intensity', 'count', 'dropped', 'format'];

// The scans as the store keeps them: without their sensor and frame, which change by hand and
// live in the session record.
export const keptScans = (state) => state.scans.map((s) => Object.fromEntries(SCAN_FIELDS.filter((k) => s[k] !== undefined).map((k) => [k, s[k]])));

// The session record of `state`.
export function sessionOf(state) {
  return {
    version: 1,
    assigned: state.scans.map((s) => [s.id, s.sensor, s.frame]),
    bad: state.bad,
    rig: state.rig,
    settings: state.settings,
    truth: state.truth,
    targetMesh: state.targetMesh ?? null,
    view: { show: state.show, colour: state.colour, allFrames: state.allFrames, hidden: [...state.hidden] },
    results: state.results,
    failures: state.failures ?? [],
    resultJson: state.resultJson ?? null,
    resultContext: state.resultContext ?? null,
    stale: state.stale,
  };
}

// Puts a kept session ({session, scans} from store.load) back into `state`; `explicit`: the
// settings a link gave, which win over the kept ones. Returns the next free scan number.
export function restoreSession(state, { session, scans }, explicit = {}) {
  const byId = new Map(scans.map((s) => [s.id, s]));
  state.scans = session.assigned.filter(([id]) => byId.has(id)).map(([id, sensor, frame]) => ({ ...byId.get(id), sensor, frame }));
  Object.assign(state, {
    bad: session.bad ?? [],
    rig: session.rig,
    settings: { ...state.settings, ...session.settings, ...explicit },
    truth: session.truth,
    targetMesh: session.targetMesh ?? undefined,
    show: session.view.show,
    colour: session.view.colour,
    allFrames: session.view.allFrames,
    hidden: new Set(session.view.hidden),
    results: session.results,
    failures: session.failures,
    resultJson: session.resultJson,
    resultContext: session.resultContext,
  });
  return 1 + Math.max(0, ...state.scans.map((s) => Number(String(s.id).split(':')[1]) || 0));
}
