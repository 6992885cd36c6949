// The settings panel's inputs (method, target, global alignment, components, iterations,
// initial sigma, workers, the E-step's device and exactness; the demo's preset, seed, frames) bound to `state.settings` and the URL
// hash, and the target's CAD model, checked by the library.
import { writeHash } from '../state/url.js';

const SETTING_INPUTS = ['method', 'components', 'iterations', 'initialSigma', 'workers', 'eStepDevice', 'exact', 'global'];

// `$`: the page's elements by id; `client`: the worker client; `changed(what)`: a setting
// changed after a run; `targetLoaded()`: a new CAD model replaces the target (the result goes);
// `setStatus`, `showError`: the page's lines. Returns {sync, loadTargetMesh, setTarget}.
export function initSettings({ $, state, client, changed, targetLoaded, setStatus, showError }) {
  function syncSettingsInputs() {
    for (const key of SETTING_INPUTS) {
      if ($(key).type === 'checkbox') $(key).checked = state.settings[key];
      else $(key).value = state.settings[key];
    }
    // The exact E-step is f64 on the CPU: no device to choose.
    $('eStepDevice').disabled = state.settings.exact;
    const [kind, size = ''] = state.settings.target.split(':');
    $('target-kind').value = kind;
    // A model's size is its own: shown, not edited.
    $('target-size').value = kind === 'mesh' ? (state.targetMesh?.extents.map((e) => e.toFixed(2)).join(',') ?? '') : size;
    $('target-size').disabled = kind === 'none' || kind === 'mesh';
    if (state.settings.demo) $('demo-preset').value = state.settings.demo; // else the last one picked
    $('demo-seed').value = state.settings.seed;
    $('demo-frames').value = state.settings.frames;
  }

  for (const key of SETTING_INPUTS) {
    $(key).addEventListener('change', () => {
      const el = $(key);
      const value = el.type === 'number' ? Number(el.value) : el.type === 'checkbox' ? el.checked : el.value;
      if (el.type === 'number' && !(Number.isFinite(value) && value > 0)) {
        el.value = state.settings[key];
        return;
      }
      state.settings[key] = value;
      syncSettingsInputs();
      writeHash(state.settings, state.rig);
      changed('settings');
    });
  }

  // The target from its two inputs. A cube's or sphere's size becomes a box's three edges and
  // back; a size that is not positive numbers is put back (to the default when the kind changed).
  function targetChanged() {
    const kind = $('target-kind').value;
    if (kind === 'mesh') {
      if (state.targetMesh) state.settings.target = `mesh:${state.targetMesh.name}`;
      else $('mesh-input').click(); // the kind shows once a model is loaded
      syncSettingsInputs();
      writeHash(state.settings, state.rig);
      return;
    }
    const [previousKind] = state.settings.target.split(':');
    let size = $('target-size').value.split(',').filter((v) => v.trim()).map(Number);
    if (kind === 'box' && size.length === 1) size = [size[0], size[0], size[0]];
    if (kind !== 'box' && size.length === 3) size = [Math.max(...size)];
    const valid = size.length === (kind === 'box' ? 3 : 1) && size.every((v) => Number.isFinite(v) && v > 0);
    if (kind === 'none') state.settings.target = 'none';
    else if (valid) state.settings.target = `${kind}:${size.join(',')}`;
    else if (kind !== previousKind) state.settings.target = kind === 'box' ? 'box:0.5,0.5,0.5' : `${kind}:0.5`;
    syncSettingsInputs();
    writeHash(state.settings, state.rig);
    changed('target');
  }
  $('target-kind').addEventListener('change', targetChanged);
  $('mesh-input').addEventListener('change', async (e) => {
    const [file] = e.target.files;
    if (file) await loadTargetMesh({ path: file.name, file });
    e.target.value = '';
  });

  // A CAD-model target: checked and measured by the library (a bad file is named and changes
  // nothing), kept with its bytes for the calibration.
  async function loadTargetMesh({ path, file }) {
    try {
      const bytes = await file.arrayBuffer();
      const mesh = await client.request('mesh', { bytes: bytes.slice(0), name: path });
      state.targetMesh = { name: path, bytes, extents: mesh.extents, size: mesh.size, triangles: mesh.triangles.length / 3 };
      state.settings.target = `mesh:${path}`;
      targetLoaded();
      syncSettingsInputs();
      writeHash(state.settings, state.rig);
      setStatus(`Target: ${path}, ${state.targetMesh.triangles} triangles, ${mesh.extents.map((x) => x.toFixed(2)).join(' × ')} m; where it stands is found from the data.`);
    } catch (error) {
      showError(`${error.message ?? error}`);
      syncSettingsInputs();
    }
  }
  $('target-size').addEventListener('change', targetChanged);

  // The target set from elsewhere (an advice's button): as if picked.
  function setTarget(target) {
    state.settings.target = target;
    syncSettingsInputs();
    writeHash(state.settings, state.rig);
    changed('target');
  }

  return { sync: syncSettingsInputs, loadTargetMesh, setTarget };
}
