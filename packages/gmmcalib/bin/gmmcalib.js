#!/usr/bin/env node
// `npx gmmcalib calibrate ...` / `drift ...`: the native CLI's shared commands, run by the
// library in wasm (`runCommand`) over Node's file system. Errors are the CLI's: one line, no
// stack trace.
import fs from 'node:fs';
import { runCommand } from '../node.js';

// A file error as Rust's std::io::Error prints it, so both commands name it alike.
const REASONS = {
  ENOENT: 'No such file or directory',
  EACCES: 'Permission denied',
  EISDIR: 'Is a directory',
  ENOTDIR: 'Not a directory',
  ENOSPC: 'No space left on device',
  EROFS: 'Read-only file system',
  EPERM: 'Operation not permitted',
};

function reason(e) {
  const text = REASONS[e?.code];
  return text && Number.isInteger(e.errno) ? `${text} (os error ${Math.abs(e.errno)})` : String(e?.message ?? e);
}

/** `f` with a thrown file error replaced by its reason alone. */
const plain = (f) => (...args) => {
  try {
    return f(...args);
  } catch (e) {
    throw new Error(reason(e));
  }
};

const host = {
  read: plain((path) => fs.readFileSync(path)),
  list: plain((dir) => fs.readdirSync(dir)),
  kind(path) {
    try {
      const s = fs.statSync(path);
      return s.isFile() ? 'file' : s.isDirectory() ? 'dir' : 'other';
    } catch {
      return 'other';
    }
  },
  write: plain((path, bytes) => fs.writeFileSync(path, bytes)),
  open: plain((path) => {
    const fd = fs.openSync(path, 'r');
    return {
      size: fs.fstatSync(fd).size,
      readAt: plain((offset, length) => {
        const buf = new Uint8Array(length);
        let done = 0;
        while (done < length) {
          const n = fs.readSync(fd, buf, done, length - done, offset + done);
          if (n === 0) break;
          done += n;
        }
        return buf.subarray(0, done);
      }),
    };
  }),
  out: (text) => process.stdout.write(text),
  err: (text) => process.stderr.write(text),
  progress: (line) => {
    if (process.stderr.isTTY) process.stderr.write(`\r\x1b[K${line}`);
  },
};

try {
  process.exitCode = runCommand(process.argv.slice(2), host);
} catch (e) {
  // Only a bug gets here (a user's error is a status and a line): no stack, still.
  process.stderr.write(`gmmcalib: internal error: ${e?.message ?? e}\n`);
  process.exitCode = 1;
}
