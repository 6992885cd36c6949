import { defineConfig } from 'vite';

// Relative asset paths, so the built site works from any static host and sub-path. Two pages:
// the app and its static "How it works".
export default defineConfig({
  base: './',
  worker: { format: 'es' },
  build: {
    target: 'es2022',
    chunkSizeWarningLimit: 800, // three.js is most of it
    rollupOptions: { input: { main: 'index.html', how: 'how.html' } },
  },
});
