// The page's modules that read a result (marked `// @ts-check`) type-check against the npm
// package's declarations, which tests/report.rs generates from the Rust types: a result
// field renamed in Rust and not in the page fails here.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

const www = new URL('..', import.meta.url).pathname;
const tsc = (project) => spawnSync(path.join(www, 'node_modules/.bin/tsc'), ['-p', project], { encoding: 'utf8' });

test('the page reads the result by the names the Rust types give', () => {
  const checked = fs.readdirSync(path.join(www, 'src'), { recursive: true })
    .filter((f) => f.endsWith('.js') && fs.readFileSync(path.join(www, 'src', f), 'utf8').startsWith('// @ts-check'));
  for (const f of ['results/answer.js', 'results/results.js', 'results/drift.js', 'panels/advice.js', 'calibrate/progress.js']) {
    assert.ok(checked.includes(f), `${f} is type-checked`);
  }
  const run = tsc(www);
  assert.equal(run.status, 0, run.stdout + run.stderr);
});

test('a misspelt result field fails the check', () => {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'gmmcalib-types-'));
  try {
    fs.writeFileSync(path.join(dir, 'tsconfig.json'), JSON.stringify({ extends: path.join(www, 'tsconfig.json'), include: ['reads.js'] }));
    fs.writeFileSync(path.join(dir, 'reads.js'), `// @ts-check\n/** @param {import('${path.join(www, 'src/result')}').PageResult} r */\nexport const level = (r) => r.verdict.levle;\n`);
    const run = tsc(dir);
    assert.notEqual(run.status, 0);
    assert.match(run.stdout, /Property 'levle' does not exist/);
  } finally {
    fs.rmSync(dir, { recursive: true, force: true });
  }
});
