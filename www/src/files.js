// Which files were given and what they are: paths from a drop (folders walked), the picker or
// a folder picker; point-cloud files assigned to (sensor, frame) and parsed by `parse` (the
// worker), the GMMCalib config read; every bad file kept with its error.
import { parseConfig } from './config.js';

const CLOUD = /\.(pcd|ply|bin)$/i;
const CONFIG = /(^|\/)[^/]*\.ya?ml$/i;

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

// Sensor and frame from a path: the GMMCalib layout `.../sensor_N/<frame>.<ext>`, else the name
// `<sensor>_<frame>.<ext>` split at the last underscore. A name without one is frame 1 of a
// sensor of its own name, to be reassigned by hand.
export function assign(path) {
  const parts = path.split('/');
  const stem = parts.at(-1).replace(/\.[^.]*$/, '');
  const folder = parts.at(-2);
  if (folder && /^sensor_\d+$/i.test(folder)) return { sensor: folder, frame: stem };
  const cut = stem.lastIndexOf('_');
  if (cut > 0 && cut < stem.length - 1) return { sensor: stem.slice(0, cut), frame: stem.slice(cut + 1) };
  return { sensor: stem, frame: '1' };
}

// Natural order: sensor_2 before sensor_10.
export const natural = (a, b) => a.localeCompare(b, undefined, { numeric: true });

// Reads `entries` ([{path, file}]): {scans: [{path, sensor, frame, ...parsed}], bad: [{path,
// error}], config}. `parse(bytes, path)` parses one cloud; `onFile(path, i, n)` reports progress.
export async function readEntries(entries, parse, onFile) {
  const bad = [];
  let config = {};
  for (const e of entries.filter((e) => isConfig(e.path))) {
    try {
      config = { ...config, ...parseConfig(await e.file.text(), e.path) };
    } catch (error) {
      bad.push({ path: e.path, error: error.message });
    }
  }
  for (const e of entries) if (!isCloud(e.path) && !isConfig(e.path)) bad.push({ path: e.path, error: 'ignored: not a .pcd, .ply, .bin or .yaml file' });
  const clouds = entries.filter((e) => isCloud(e.path)).sort((a, b) => natural(a.path, b.path));
  const scans = [];
  for (const [i, { path, file }] of clouds.entries()) {
    onFile(path, i + 1, clouds.length);
    try {
      scans.push({ path, ...assign(path), ...(await parse(await file.arrayBuffer(), path)) });
    } catch (error) {
      bad.push({ path, error: error.message });
    }
  }
  return { scans, bad, config };
}
