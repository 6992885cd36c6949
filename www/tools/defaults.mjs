// Writes the library's settings defaults (`defaults()`) to pkg/defaults.json beside the wasm, for
// url.js: the page's controls start from the library's own numbers and copy none.
import { readFileSync, writeFileSync } from 'node:fs';
import { defaults, initSync } from '../pkg/gmmcalib.js';

initSync({ module: readFileSync(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });
writeFileSync(new URL('../pkg/defaults.json', import.meta.url), `${JSON.stringify(defaults(), null, 2)}\n`);
