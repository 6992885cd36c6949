// Loading what a user drops or picks: point clouds with their rig files (GMMCalib's config,
// OpenCalib's lists), a recording (its topics offered, then the scans chosen), a target's CAD
// model, a result saved as a file. Each becomes the page's state; main.js renders it.
import { groupNameless, isMesh, placeAll, readEntries, splitNameless } from './files.js';
import { renderLooseQuestion } from './loose.js';
import { describeInstants, isRecording, renderRecording } from './recording.js';
import { isResultFile, readResult } from '../panels/result-file.js';
import { sortScans } from '../state/state.js';
import { countLine } from '../panels/summary.js';
import { writeHash } from '../state/url.js';

// `page`: what main.js lends: {$, state, client, settings, nextId(), setStatus, showError,
// clearAll, showLoaded(config), showResults, forgetResults, setStale, rigFrom, renderPanels,
// changed, redraw}. Returns {loadFiles(entries)}.
export function initLoading(page) {
  const { $, state, client, settings, setStatus, showError, clearAll, showLoaded, showResults, forgetResults, setStale, rigFrom, renderPanels, changed, redraw } = page;

  async function loadFiles(entries) {
    showError(null);
    const recording = entries.find((e) => isRecording(e.path));
    if (recording) await openRecording(recording);
    // An .obj or .stl among the files is the target's CAD model (a .ply is a scan: pick a PLY
    // model with the target's "CAD model…").
    const model = entries.find((e) => isMesh(e.path));
    if (model) await settings.loadTargetMesh(model);
    // A result saved as a file opens once the scans beside it are in.
    const resultFile = entries.findLast((e) => isResultFile(e.path));
    entries = entries.filter((e) => !isRecording(e.path) && !isMesh(e.path) && !isResultFile(e.path));
    if (entries.length) await loadScans(entries);
    if (resultFile) await openResult(resultFile);
  }

  // A result file ({path, file}): the results panel shows it as it was, the view places the
  // loaded scans by it. A file that is no result is named, and nothing changes.
  async function openResult({ path, file }) {
    let opened;
    try {
      opened = readResult(await file.text(), path);
    } catch (error) {
      showError(error);
      return;
    }
    // What the run had is not in the file: no advice on its target.
    state.resultContext = null;
    setStale(null);
    try {
      await showResults(opened.results, opened.failures, opened.json);
    } catch (error) {
      forgetResults();
      showError(`${path}: ${error.message}`);
      return;
    }
    const sensors = opened.results[0].sensors.map((s) => s.name);
    const missing = sensors.filter((name) => !state.rig.sensors.includes(name));
    setStatus(`Opened ${path}: ${opened.results[0].method}'s result for ${sensors.join(', ')}${missing.length ? `; load the scans of ${missing.join(', ')} to see them placed` : ''}.`);
  }

  async function loadScans(entries) {
    if (state.truth) clearAll(); // user files replace a demo
    const read = {
      cloud: (bytes, name) => client.request('parse', { bytes, name }, { transfer: [bytes] }),
      config: (text, name) => client.request('config', { text, name }),
      opencalib: (paths, pathsName, guess, guessName) => client.request('opencalib', { paths, pathsName, guess, guessName }),
    };
    const { scans, bad, config } = await readEntries(entries, read, (path, i, n) => setStatus(`Reading ${path} (${i}/${n})…`));
    const paths = new Set(scans.map((s) => s.path));
    const fresh = scans.map((s) => ({ id: page.nextId(), ...s }));
    state.scans = [...state.scans.filter((v) => !paths.has(v.path)), ...fresh];
    // Every scan placed again with the new ones, as the CLI places a folder: a folder loaded
    // after another pairs its frames with the first sensor's.
    const placed = await placeAll(state.scans, (list) => client.request('layout', { paths: list }));
    const dropped = new Set(placed.duplicates.map((d) => d.second));
    for (const d of placed.duplicates) bad.push({ path: d.second, error: `ignored: ${d.first} is frame ${d.frame} of the same sensor` });
    state.scans = state.scans.filter((s) => !dropped.has(s.path));
    const nameless = new Set(placed.nameless);
    const loose = groupNameless(fresh.filter((s) => nameless.has(s.path)), state.scans.filter((s) => !nameless.has(s.path)).map((s) => s.sensor));
    const lastSensors = placed.sensorsLast ? [...new Set(fresh.filter((s) => s.frame === placed.sensorsLast).map((s) => s.sensor))] : [];
    const paired = placed.pairings.join('; ');
    state.bad.push(...bad);
    sortScans(state);
    state.settings.demo = '';
    writeHash(state.settings, state.rig);
    showLoaded(config);
    const assumed = loose ? `; ${loose.scans.length} files without a sensor in their names taken as frames of ${loose.sensor}` : '';
    const suffixed = lastSensors.length ? `; the names end in a sensor, not a frame number: sensors ${lastSensors.join(', ')}, frame ${placed.sensorsLast}` : '';
    setStatus(`${countLine(state)} loaded${paired ? ` (${paired})` : ''}${assumed}${suffixed}${state.bad.length ? `, ${state.bad.length} file(s) with problems` : ''}.`);
    renderLooseQuestion($('loose'), loose, () => {
      splitNameless(loose.scans);
      sortScans(state);
      rigFrom();
      renderPanels();
      changed('sensors');
      redraw();
      setStatus(`Each of the ${loose.scans.length} files is a sensor of its own: ${state.rig.sensors.length} sensors.`);
    });
    if (state.bad.length) showError(state.bad.map((b) => `${b.path}: ${b.error}`).join('\n'));
  }

  // A recording is opened in the worker (read where it lies) and its topics offered; its scans
  // load when the user asks (loadRecording).
  async function openRecording({ path, file }) {
    setStatus(`Opening ${path}…`);
    try {
      if (state.recording) client.request('closeRecording', { handle: state.recording.handle }).catch(() => {});
      const onProgress = ({ done, total }) => setStatus(`Scanning ${path} (${Math.round((100 * done) / Math.max(total, 1))} %)…`);
      const opened = await client.request('openRecording', { file }, { onProgress });
      state.recording = { handle: opened.handle, path };
      renderRecording($('recording'), path, opened, (options) => loadRecording(path, opened.handle, options));
      const clouds = opened.topics.filter((t) => t.kind === 'pointCloud' && t.count > 0).length;
      setStatus(clouds ? `${path}: pick the topics, then Load scans.` : `${path}: no point-cloud messages.`);
      // Damage that leaves the rest readable (a truncated tail, a corrupt chunk) is named.
      if (opened.problems.length) showError(opened.problems.join('\n'));
    } catch (error) {
      setStatus('Failed.');
      showError(error);
    }
  }

  async function loadRecording(path, handle, options) {
    showError(null);
    setStatus(`Reading ${options.topics.length} topics at ${options.frames} instants from ${path}…`);
    try {
      const rig = await client.request('recordingRig', { handle, options });
      if (state.truth) clearAll(); // a recording replaces a demo
      // Loading again (other topics, other instants) replaces this recording's scans.
      state.scans = state.scans.filter((s) => s.recording !== path);
      const format = path.split('.').at(-1);
      // Sensors are named by their frame ids; the file table names the topic each came from.
      const topicOf = Object.fromEntries(Object.entries(rig.sensors).map(([topic, sensor]) => [sensor, topic]));
      state.scans.push(...rig.scans.map((v) => ({ id: page.nextId(), path: `${path} ${topicOf[v.sensor] ?? v.sensor} #${v.frame}`, recording: path, sensor: v.sensor, frame: v.frame, points: v.points, count: v.points.length / 3, dropped: 0, format })));
      sortScans(state);
      // The reference the user picked, else (none picked) the sensor with the most points; the
      // vehicle frame is the tree's base frame, by its name, everywhere.
      showLoaded({ nominal: rig.nominal, reference: options.reference ? rig.reference : null, parent: rig.baseFrame });
      setStatus(`${rig.scans.length} scans of ${options.topics.length} sensors loaded from ${path} (${describeInstants(rig)}).`);
      if (rig.problems.length) showError(rig.problems.join('\n'));
    } catch (error) {
      setStatus('Failed.');
      showError(error);
    }
  }

  return { loadFiles };
}
