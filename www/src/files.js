// Which files were given and what they are: paths from a drop (folders walked), the picker or
// a folder picker; point-cloud files assigned to (sensor, frame) and parsed by `parse` (the
// worker), the GMMCalib config and OpenCalib's rig files read; every bad file kept with its
// error.

const CLOUD = /\.(pcd|ply|bin)$/i;
const CONFIG = /(^|\/)[^/]*\.ya?ml$/i;
// OpenCalib's lidar2lidar layout: which file is which device, and its guess per device.
const OPENCALIB_PATHS = /(^|\/)lidar_cloud_path\.txt$/i;
const OPENCALIB_GUESS = /(^|\/)initial_extrinsic\.txt$/i;

// A target's CAD model: OBJ or STL (a PLY is taken for a scan).
export const isMesh = (path) => /\.(obj|stl)$/i.test(path);

// [{path, file}] from a file input: webkitRelativePath for folder picks, else the name.
export function fromInput(fileList) {
  return Array.from(fileList, (file) => ({ path: file.webkitRelativePath || file.name, file }));
}

// [{path, file}] from a drop, walking dropped folders.
export async function fromDrop(dataTransfer) {
  const entries = Array.from(dataTransfer.items ?? [])
    .map((item) => item.webkitGetAsEntry?.())
    .filter(Boolean);
  if (!entries.length) return fromInput(dataTransfer.files);
  const out = [];
  const walk = async (entry, prefix) => {
    if (entry.isFile) {
      const file = await new Promise((resolve, reject) => entry.file(resolve, reject));
      out.push({ path: prefix + entry.name, file });
    } else if (entry.isDirectory) {
      const reader = entry.createReader();
      // readEntries returns the folder in batches until an empty one.
      for (;;) {
        const batch = await new Promise((resolve, reject) => reader.readEntries(resolve, reject));
        if (!batch.length) break;
        for (const child of batch) await walk(child, `${prefix}${entry.name}/`);
      }
    }
  };
  for (const entry of entries) await walk(entry, '');
  return out;
}

export const isCloud = (path) => CLOUD.test(path);
export const isConfig = (path) => CONFIG.test(path);
const isRigFile = (path) => isConfig(path) || OPENCALIB_PATHS.test(path) || OPENCALIB_GUESS.test(path);
const folderOf = (path) => path.split('/').slice(0, -1).join('/');

// A file's name without its folders and extension.
const stemOf = (path) => path.split('/').at(-1).replace(/\.[^.]*$/, '');

// Sensor and frame from a path: the GMMCalib layout `.../sensor_N/<frame>.<ext>`, else the name
// `<sensor>_<frame>.<ext>` split at the last underscore. A name without one is frame 1 of a
// sensor of its own name, to be reassigned by hand.
export function assign(path) {
  const stem = stemOf(path);
  const folder = path.split('/').at(-2);
  if (folder && /^sensor_\d+$/i.test(folder)) return { sensor: folder, frame: stem };
  const cut = stem.lastIndexOf('_');
  if (cut > 0 && cut < stem.length - 1) return { sensor: stem.slice(0, cut), frame: stem.slice(cut + 1) };
  return { sensor: stem, frame: '1' };
}

// Recorded scans as a bag export leaves them: one folder per sensor, whatever its name, and
// files named by timestamp, so no two sensors share a stem. `pair(scans, fresh)` takes a
// folder of `fresh` (the scans just read, each {path, sensor, frame} from `assign`) as the
// sensor of its scans when their names carry no sensor (each would be a sensor of its own);
// then every sensor of `scans` (all loaded) that shares no frame name with the first sensor
// has its scans paired with the first sensor's: by the nearest timestamp (one to one, within
// half the first sensor's median interval) when both are named by numbers, else in order.
// Paired scans take the first sensor's frame name; a scan left over keeps its own, so the
// calibration skips it. Returns what it did, or null.
export function pair(scans, fresh = scans) {
  const notes = [];
  const byFolder = groupBy(fresh, (s) => s.path.split('/').slice(0, -1).join('/'));
  let moved = false;
  for (const [folder, list] of byFolder) {
    if (list.some((s) => s.named)) continue; // a rig file named them
    const nameless = new Set(list.map((s) => s.sensor)).size === list.length && (list.length > 1 || (byFolder.size > 1 && list[0].frame === '1'));
    if (!folder || /(^|\/)sensor_\d+$/i.test(folder) || !nameless) continue;
    for (const s of list) [s.sensor, s.frame] = [folder.split('/').at(-1), stemOf(s.path)];
    moved = true;
  }
  if (moved) notes.push('one sensor per folder');
  const bySensor = groupBy([...scans].sort((a, b) => natural(a.path, b.path)), (s) => s.sensor);
  const [firstName, ...others] = [...bySensor.keys()].sort(natural);
  const first = bySensor.get(firstName) ?? [];
  const firstFrames = new Set(first.map((s) => s.frame));
  const numeric = (list) => list.every((scan) => /^\d+(\.\d+)?$/.test(stemOf(scan.path)));
  const time = (scan) => Number(stemOf(scan.path));
  const how = new Set();
  for (const name of others) {
    const list = bySensor.get(name);
    if (list.some((s) => firstFrames.has(s.frame))) continue;
    if (numeric(first) && numeric(list)) {
      const reference = first.map(time);
      const sorted = [...reference].sort((a, b) => a - b);
      const gaps = sorted.slice(1).map((t, i) => t - sorted[i]).sort((a, b) => a - b);
      const reach = gaps.length ? gaps[gaps.length >> 1] / 2 : Infinity;
      // One to one, closest pairs first.
      const candidates = [];
      list.forEach((scan, k) => reference.forEach((t, j) => {
        const gap = Math.abs(time(scan) - t);
        if (gap <= reach) candidates.push([gap, k, j]);
      }));
      candidates.sort((a, b) => a[0] - b[0]);
      const [taken, given] = [new Set(), new Set()];
      for (const [, k, j] of candidates) {
        if (taken.has(k) || given.has(j)) continue;
        list[k].frame = first[j].frame;
        taken.add(k);
        given.add(j);
      }
      how.add(`frames paired by the nearest timestamp to ${firstName}'s`);
    } else {
      list.forEach((s, k) => { if (k < first.length) s.frame = first[k].frame; });
      how.add(`frames paired in order with ${firstName}'s`);
    }
  }
  notes.push(...how);
  return notes.length ? notes.join('; ') : null;
}

// Loose files whose names carry no sensor (`1.pcd 2.pcd 3.pcd` from the picker, no folder):
// rather than one sensor per file, they are taken as the frames of one new sensor, named
// `sensor_N` with the first N no sensor of `sensors` has. Changes those scans of `fresh` and
// returns {sensor, scans} so the page can say so and ask, or null when there are fewer than two.
export function groupNameless(fresh, sensors = []) {
  const carriesSensor = (stem) => stem.lastIndexOf('_') > 0 && stem.lastIndexOf('_') < stem.length - 1; // as assign splits
  const nameless = fresh.filter((s) => !s.named && !s.path.includes('/') && !carriesSensor(stemOf(s.path)));
  if (nameless.length < 2) return null;
  let n = 1;
  while (sensors.includes(`sensor_${n}`)) n++;
  const sensor = `sensor_${n}`;
  for (const s of nameless) Object.assign(s, { sensor, frame: stemOf(s.path) });
  return { sensor, scans: nameless };
}

// Loose files named `<frame>_<sensor>` (the Livox Mid-100's units: scene1_pose10_L0.pcd,
// scene1_pose10_L1.pcd, ...) split at the last underscore would all be frames of one sensor,
// none a frame number. When every such file of `fresh` shares what comes before its last
// underscore and no part after it is a number, the parts after it are the sensors and the part
// before the frame. Changes those scans; returns {frame, sensors} for the page to say so, or null.
export function sensorsBySuffix(fresh) {
  const loose = fresh.filter((s) => !s.named && !s.path.includes('/'));
  const splits = (stem) => stem.lastIndexOf('_') > 0 && stem.lastIndexOf('_') < stem.length - 1;
  if (loose.length < 2 || !loose.every((s) => splits(stemOf(s.path)))) return null;
  const cut = loose.map((s) => stemOf(s.path)).map((stem) => [stem.slice(0, stem.lastIndexOf('_')), stem.slice(stem.lastIndexOf('_') + 1)]);
  const prefixes = new Set(cut.map(([p]) => p));
  const suffixes = new Set(cut.map(([, x]) => x));
  if (prefixes.size !== 1 || [...prefixes][0] === '' || suffixes.size !== loose.length || cut.some(([p, x]) => p.length === 0 || x.length === 0 || /^\d+(\.\d+)?$/.test(x))) return null;
  loose.forEach((s, i) => Object.assign(s, { sensor: cut[i][1], frame: cut[i][0] }));
  return { frame: cut[0][0], sensors: cut.map(([, x]) => x) };
}

// Undoes groupNameless: each of `scans` a sensor of its own name, frame 1.
export function splitNameless(scans) {
  for (const s of scans) Object.assign(s, { sensor: stemOf(s.path), frame: '1' });
}

// Map from key(item) to the items with that key, in order.
function groupBy(items, key) {
  const groups = new Map();
  for (const item of items) {
    const k = key(item);
    if (!groups.has(k)) groups.set(k, []);
    groups.get(k).push(item);
  }
  return groups;
}

// Natural order: sensor_2 before sensor_10.
export const natural = (a, b) => a.localeCompare(b, undefined, { numeric: true });

// `into` with the values `from` sets (a key a file leaves unset is null or an empty map).
const merge = (into, from) => ({
  ...into,
  ...Object.fromEntries(Object.entries(from).filter(([, v]) => v != null && !(typeof v === 'object' && !Object.keys(v).length))),
});

// OpenCalib's folders among `entries`: each `lidar_cloud_path.txt` read with the
// `initial_extrinsic.txt` beside it (`read.opencalib`, the library's reader). Returns {config,
// names: Map(path -> {sensor, frame}), folders}: a device's file is its sensor's scan, of a
// frame named by the folder (two scenes of one rig dropped together are two frames); `folders`
// are those with a list, whose other clouds (OpenCalib's own `stitching.pcd`) are no device.
async function openCalibFolders(entries, read, bad) {
  const names = new Map();
  const folders = new Set();
  let config = {};
  const guesses = new Map(entries.filter((e) => OPENCALIB_GUESS.test(e.path)).map((e) => [folderOf(e.path), e]));
  for (const e of entries.filter((e) => OPENCALIB_PATHS.test(e.path))) {
    const folder = folderOf(e.path);
    const guess = guesses.get(folder);
    guesses.delete(folder);
    try {
      const found = await read.opencalib(await e.file.text(), e.path, guess && (await guess.file.text()), guess?.path);
      folders.add(folder);
      const frame = folder.split('/').at(-1) || '1';
      for (const d of found.devices) names.set(folder ? `${folder}/${d.file}` : d.file, { sensor: d.name, frame, named: true });
      config = merge(config, { reference: found.reference, nominal: found.nominal });
    } catch (error) {
      bad.push({ path: e.path, error: error.message });
    }
  }
  for (const [, e] of guesses) bad.push({ path: e.path, error: 'ignored: OpenCalib\'s guess needs its lidar_cloud_path.txt beside it (which file is which device)' });
  return { config, names, folders };
}

// Reads `entries` ([{path, file}]): {scans: [{path, sensor, frame, ...parsed}], bad: [{path,
// error}], config}. `read.cloud(bytes, path)` parses one cloud, `read.config(text, path)` one
// GMMCalib config and `read.opencalib(paths, pathsName, guess, guessName)` OpenCalib's rig
// files (the library's readers, in the worker); `onFile(path, i, n)` reports progress.
export async function readEntries(entries, read, onFile) {
  const bad = [];
  let config = {};
  for (const e of entries.filter((e) => isConfig(e.path))) {
    try {
      config = merge(config, await read.config(await e.file.text(), e.path));
    } catch (error) {
      bad.push({ path: e.path, error: error.message });
    }
  }
  const openCalib = await openCalibFolders(entries, read, bad);
  config = merge(openCalib.config, config);
  for (const e of entries) if (!isCloud(e.path) && !isRigFile(e.path)) bad.push({ path: e.path, error: 'ignored: not a .pcd, .ply, .bin, .yaml or OpenCalib .txt file' });
  const listed = (path) => openCalib.names.has(path) || !openCalib.folders.has(folderOf(path));
  for (const e of entries.filter((e) => isCloud(e.path) && !listed(e.path))) {
    bad.push({ path: e.path, error: 'ignored: not a device in its folder\'s lidar_cloud_path.txt' });
  }
  const clouds = entries.filter((e) => isCloud(e.path) && listed(e.path)).sort((a, b) => natural(a.path, b.path));
  const scans = [];
  for (const [i, { path, file }] of clouds.entries()) {
    onFile(path, i + 1, clouds.length);
    try {
      scans.push({ path, ...(openCalib.names.get(path) ?? assign(path)), ...(await read.cloud(await file.arrayBuffer(), path)) });
    } catch (error) {
      bad.push({ path, error: error.message });
    }
  }
  return { scans, bad, config };
}
