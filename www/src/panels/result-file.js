// A result saved as a file (the JSON export, `gmmcalib-result.json`, or `gmmcalib calibrate
// --json`'s) opened in the page again: checked to hold what the results panel shows, so a
// malformed or foreign JSON is named as such and changes nothing.
const isMatrix = (m) => Array.isArray(m) && m.length === 16 && m.every(Number.isFinite);
const isBox = (b) => b && [b.min, b.max].every((v) => Array.isArray(v) && v.length === 3 && v.every(Number.isFinite));

function isReport(r) {
  return r && typeof r === 'object' && typeof r.method === 'string' && typeof r.reference === 'string'
    && r.verdict && typeof r.verdict.level === 'string' && Array.isArray(r.verdict.reasons) && r.verdict.sensors && typeof r.verdict.sensors === 'object'
    && Array.isArray(r.sensors) && r.sensors.length > 0
    && r.sensors.every((s) => typeof s.name === 'string' && isMatrix(s.extrinsic) && isMatrix(s.relative) && isMatrix(s.correction) && s.spread && Array.isArray(s.spread.xyz))
    && r.reconstruction && Array.isArray(r.reconstruction.means) && Array.isArray(r.reconstruction.fits)
    && r.history && Array.isArray(r.history.meanSigma) && isBox(r.roi);
}

// {results, failures, json} from the text of `name`, or throws naming what it is not.
export function readResult(text, name) {
  let json;
  try {
    json = JSON.parse(text);
  } catch (error) {
    throw new Error(`${name}: not JSON (${error.message})`);
  }
  const outcomes = Array.isArray(json) ? json : [json];
  const results = outcomes.filter((o) => o && !o.error);
  const failures = outcomes.filter((o) => o?.error).map((o) => ({ method: String(o.method), error: String(o.error) }));
  if (!results.length || !results.every(isReport)) {
    throw new Error(`${name}: not a gmmcalib result (the JSON of Export, or of gmmcalib calibrate --json)`);
  }
  return { results, failures, json };
}

export const isResultFile = (path) => /\.json$/i.test(path);
