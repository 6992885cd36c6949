import { defineConfig } from 'vite';

// Relative asset paths, so the built site works from any static host and sub-path.
export default defineConfig({
  base: './',
  worker: { format: 'es' },
  build: { target: 'es2022', chunkSizeWarningLimit: 800 }, // three.js is most of it
});
