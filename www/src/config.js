// GMMCalib's config.yaml (what src/bin/gmmcalib/config.rs reads) to rig settings.
// `transform_<sensor>: - [roll, pitch, yaw, x, y, z]` (sensor -> vehicle, rad, m), ROI
// `min_bound`/`max_bound` (vehicle frame), and our optional keys.
import { load } from 'js-yaml';

// A list of n numbers, also accepted nested once ([[...]]), as GMMCalib writes them.
function numbers(value, n, what, file, key) {
  const list = Array.isArray(value) && value.length === 1 && Array.isArray(value[0]) ? value[0] : value;
  if (!Array.isArray(list) || list.length !== n || !list.every((v) => typeof v === 'number' && Number.isFinite(v))) {
    throw new Error(`${file}: ${key}: expected ${n} numbers ${what}`);
  }
  return list;
}

// {nominal: {sensor: {xyz, rpy}}, roi?, reference?, method?, components?, iterations?,
//  edge?, initialSigma?}; throws an Error naming the file and key.
export function parseConfig(text, file) {
  let doc;
  try {
    doc = load(text);
  } catch (error) {
    throw new Error(`${file}: bad YAML: ${error.message.split('\n')[0]}`);
  }
  if (!doc || typeof doc !== 'object' || Array.isArray(doc)) throw new Error(`${file}: expected a mapping of keys to values`);
  const config = { nominal: {} };
  for (const [key, value] of Object.entries(doc)) {
    if (!key.startsWith('transform_')) continue;
    const v = numbers(value, 6, '[roll, pitch, yaw, x, y, z]', file, key);
    config.nominal[key.slice('transform_'.length)] = { xyz: v.slice(3), rpy: v.slice(0, 3) };
  }
  if ('min_bound' in doc || 'max_bound' in doc) {
    config.roi = {
      min: numbers(doc.min_bound, 3, '[x, y, z]', file, 'min_bound'),
      max: numbers(doc.max_bound, 3, '[x, y, z]', file, 'max_bound'),
    };
  }
  const optional = { reference: 'reference', method: 'method', components: 'components', iterations: 'iterations', target_edge: 'edge', initial_sigma: 'initialSigma' };
  for (const [key, name] of Object.entries(optional)) if (doc[key] != null) config[name] = doc[key];
  return config;
}
