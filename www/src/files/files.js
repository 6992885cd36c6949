// Which files were given and what they are: paths from a drop (folders walked), the picker or
// a folder picker; point-cloud files placed as (sensor, frame) by the library and parsed by `parse` (the
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

// Which file is which sensor and frame is the library's (`placeScans`, through the worker:
// GMMCalib's sensor_N folders, a folder per sensor under any name, loose <sensor>_<frame> or
// <frame>_<sensor> files, frames paired by the nearest timestamp), the same code the CLI
// reads a folder with. `placeAll(scans, request)` places every scan no rig file named, no
// recording gave and no hand placed; `request(paths)` asks the library. Changes those scans;
// returns the library's findings ({pairings, nameless, sensorsLast, duplicates}).
export async function placeAll(scans, request) {
  const open = scans.filter((s) => !s.named && !s.manual && !s.recording);
  if (!open.length) return { pairings: [], nameless: [], sensorsLast: null, duplicates: [] };
  const placed = await request(open.map((s) => s.path));
  const at = new Map(placed.scans.map((p) => [p.path, p]));
  for (const s of open) {
    const p = at.get(s.path);
    if (p) Object.assign(s, { sensor: p.sensor, frame: p.frame });
  }
  return placed;
}

// Loose files whose names carry no sensor (`1.pcd 2.pcd 3.pcd` from the picker, no folder;
// the library's `nameless`): rather than one sensor per file, they are taken as the frames of
// one new sensor, named `sensor_N` with the first N no sensor of `sensors` has, and kept so
// (placed by hand). Changes `nameless` and returns {sensor, scans} so the page can say so and
// ask, or null when there are fewer than two.
export function groupNameless(nameless, sensors = []) {
  if (nameless.length < 2) return null;
  let n = 1;
  while (sensors.includes(`sensor_${n}`)) n++;
  const sensor = `sensor_${n}`;
  for (const s of nameless) Object.assign(s, { sensor, frame: stemOf(s.path), manual: true });
  return { sensor, scans: nameless };
}

// Undoes groupNameless: each of `scans` a sensor of its own name, frame 1.
export function splitNameless(scans) {
  for (const s of scans) Object.assign(s, { sensor: stemOf(s.path), frame: '1', manual: true });
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

// Reads `entries` ([{path, file}]): {scans: [{path, ...parsed}], bad: [{path, error}], config};
// a scan an OpenCalib list names has its sensor and frame (`named`), the rest are placed by
// placeAll. `read.cloud(bytes, path)` parses one cloud, `read.config(text, path)` one
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
      scans.push({ path, ...openCalib.names.get(path), ...(await read.cloud(await file.arrayBuffer(), path)) });
    } catch (error) {
      bad.push({ path, error: error.message });
    }
  }
  return { scans, bad, config };
}
