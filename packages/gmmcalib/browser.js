// The package for bundlers and browsers: wasm-bindgen's `--target web` output fetches
// `gmmcalib_bg.wasm` beside it (bundlers rewrite `new URL(..., import.meta.url)`). Top-level
// await, so that `import { calibrate } from 'gmmcalib'` is ready on import, as under Node.
import init from './wasm/gmmcalib.js';

await init();

export * from './wasm/gmmcalib.js';
