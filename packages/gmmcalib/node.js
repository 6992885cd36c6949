// The package under Node: the same wasm-bindgen output as the page (`--target web`), with its
// bytes read from beside this file and instantiated synchronously, so that
// `import { calibrate } from 'gmmcalib'` is ready on import. One wasm binary serves Node,
// bundlers and browsers; see README.md.
import { readFileSync } from 'node:fs';
import { initSync } from './wasm/gmmcalib.js';

initSync({ module: readFileSync(new URL('./wasm/gmmcalib_bg.wasm', import.meta.url)) });

export * from './wasm/gmmcalib.js';
