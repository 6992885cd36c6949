// The README and docs/ link to files of the tree: each relative link must name a file that is
// there, so a move or a rename that leaves a link behind fails here.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, readdirSync, readFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const root = join(dirname(fileURLToPath(import.meta.url)), '../..');

const markdown = (dir) =>
  readdirSync(join(root, dir), { withFileTypes: true }).flatMap((e) =>
    e.isDirectory() ? markdown(join(dir, e.name)) : e.name.endsWith('.md') ? [join(dir, e.name)] : []);

test('every relative link in the README and docs/ names a file of the tree', () => {
  const files = ['README.md', ...markdown('docs')];
  const broken = [];
  for (const file of files) {
    const text = readFileSync(join(root, file), 'utf8');
    for (const [, target] of text.matchAll(/\]\(([^)\s]+)\)/g)) {
      if (/^[a-z]+:/.test(target) || target.startsWith('#')) continue;
      const path = decodeURIComponent(target.split('#')[0]);
      if (!existsSync(join(root, dirname(file), path))) broken.push(`${file}: ${target}`);
    }
  }
  assert.ok(files.length > 5, files.join(', '));
  assert.deepEqual(broken, []);
});
