// A minimal MCAP writer (https://mcap.dev/spec) for the browser tests' and benches' large
// recordings. The fixtures of record come from PyPI's `mcap` (tests/fixtures/recording/make.py);
// this one exists to write gigabytes cheaply: records go to a file at explicit offsets, and a
// payload of zeros is skipped rather than written, so it stays a hole of a sparse file.
// Messages are CDR (ROS 2): sensor_msgs/msg/PointCloud2 (x y z f32) and tf2_msgs/msg/TFMessage.
import { closeSync, ftruncateSync, openSync, writeSync } from 'node:fs';

const MAGIC = Buffer.from('\x89MCAP0\r\n', 'latin1');

// Little-endian bytes with CDR alignment counted from the end of the 4-byte encapsulation.
class Bytes {
  constructor(cdr = false) {
    this.parts = [];
    this.length = 0;
    if (cdr) this.raw(Buffer.from([0, 1, 0, 0]));
    this.origin = this.length;
    this.cdr = cdr;
  }

  raw(buffer) {
    this.parts.push(buffer);
    this.length += buffer.length;
    return this;
  }

  align(n) {
    if (!this.cdr) return;
    const pad = (n - ((this.length - this.origin) % n)) % n;
    if (pad) this.raw(Buffer.alloc(pad));
  }

  num(kind, size, value) {
    this.align(size);
    const b = Buffer.alloc(size);
    b[`write${kind}`](value);
    return this.raw(b);
  }

  u8(v) { return this.num('UInt8', 1, v); }
  u16(v) { return this.num('UInt16LE', 2, v); }
  u32(v) { return this.num('UInt32LE', 4, v); }
  i32(v) { return this.num('Int32LE', 4, v); }
  u64(v) { return this.num('BigUInt64LE', 8, BigInt(v)); }
  f64(v) { return this.num('DoubleLE', 8, v); }

  // MCAP strings and byte arrays: u32 length, bytes. CDR strings also end in a NUL.
  string(s) {
    const b = Buffer.from(this.cdr ? `${s}\0` : s);
    return this.u32(b.length).raw(b);
  }

  done() {
    return Buffer.concat(this.parts, this.length);
  }
}

function header(b, stampNs, frameId) {
  b.i32(Math.floor(Number(stampNs / 1_000_000_000n))).u32(Number(stampNs % 1_000_000_000n)).string(frameId);
}

// A CDR sensor_msgs/msg/PointCloud2 of `points` (flat x y z) stamped `stampNs` (BigInt).
export function pointCloud2(points, stampNs, frameId) {
  const n = points.length / 3;
  const b = new Bytes(true);
  header(b, stampNs, frameId);
  b.u32(1).u32(n).u32(3);
  ['x', 'y', 'z'].forEach((name, i) => b.string(name).u32(4 * i).u8(7).u32(1));
  b.u8(0).u32(12).u32(12 * n).u32(12 * n);
  b.raw(Buffer.from(new Float32Array(points).buffer));
  return b.u8(1).done();
}

// A CDR tf2_msgs/msg/TFMessage of `transforms`: [{parent, child, xyz, rpy}] (rad, ZYX).
export function tfMessage(transforms, stampNs) {
  const b = new Bytes(true);
  b.u32(transforms.length);
  for (const { parent, child, xyz, rpy } of transforms) {
    header(b, stampNs, parent);
    b.string(child);
    xyz.forEach((v) => b.f64(v));
    const [r, p, y] = rpy.map((a) => a / 2);
    const [cr, sr, cp, sp, cy, sy] = [Math.cos(r), Math.sin(r), Math.cos(p), Math.sin(p), Math.cos(y), Math.sin(y)];
    for (const q of [sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy]) b.f64(q);
  }
  return b.done();
}

// Writes an indexed MCAP at `path`: `channel(topic, type)` declares a topic, `chunk(messages)`
// writes one stored (uncompressed) chunk with its message indexes, `close()` the summary
// (schemas, channels, chunk indexes, statistics) and footer. A message is {channel, timeNs, data} with
// `data` a Buffer, or {channel, timeNs, zeros: n} for n bytes of zeros left unwritten.
export class McapFile {
  constructor(path) {
    this.fd = openSync(path, 'w');
    this.at = 0;
    this.schemas = new Map();
    this.channels = [];
    this.summary = [];
    this.counts = new Map();
    this.times = [];
    this.write(MAGIC);
    this.record(0x01, new Bytes().string('ros2').string('gmmcalib e2e').done());
  }

  write(buffer) {
    writeSync(this.fd, buffer, 0, buffer.length, this.at);
    this.at += buffer.length;
  }

  record(op, body) {
    this.write(new Bytes().u8(op).u64(body.length).done());
    this.write(body);
  }

  channel(topic, type) {
    if (!this.schemas.has(type)) {
      const schema = new Bytes().u16(this.schemas.size + 1).string(type).string('ros2msg').u32(0).done();
      this.schemas.set(type, schema);
      this.record(0x03, schema);
    }
    const id = this.channels.length + 1;
    const schemaId = [...this.schemas.keys()].indexOf(type) + 1;
    const channel = new Bytes().u16(id).u16(schemaId).string(topic).string('cdr').u32(0).done();
    this.channels.push(channel);
    this.record(0x04, channel);
    return id;
  }

  chunk(messages) {
    // Each message record: opcode, length, channel u16, sequence u32, log and publish time.
    const heads = messages.map((m) => {
      const size = m.data ? m.data.length : m.zeros;
      return new Bytes().u8(0x05).u64(2 + 4 + 8 + 8 + size).u16(m.channel).u32(0).u64(m.timeNs).u64(m.timeNs).done();
    });
    const sizes = messages.map((m, i) => heads[i].length + (m.data ? m.data.length : m.zeros));
    const recordsLen = sizes.reduce((a, b) => a + b, 0);
    const times = messages.map((m) => m.timeNs);
    const [first, last] = [times.reduce((a, b) => (b < a ? b : a)), times.reduce((a, b) => (b > a ? b : a))];
    for (const m of messages) this.counts.set(m.channel, (this.counts.get(m.channel) ?? 0) + 1);
    this.times = [...this.times, first, last].sort((a, b) => (a < b ? -1 : a > b ? 1 : 0)).filter((_, i, a) => i === 0 || i === a.length - 1);
    const start = this.at;
    const head = new Bytes().u64(first).u64(last).u64(recordsLen).u32(0).string('').u64(recordsLen).done();
    this.write(new Bytes().u8(0x06).u64(head.length + recordsLen).done());
    this.write(head);
    const offsets = new Map();
    let offset = 0;
    messages.forEach((m, i) => {
      if (!offsets.has(m.channel)) offsets.set(m.channel, []);
      offsets.get(m.channel).push([m.timeNs, offset]);
      this.write(heads[i]);
      if (m.data) this.write(m.data);
      else this.at += m.zeros; // a hole
      offset += sizes[i];
    });
    const chunkLength = this.at - start;
    const indexStart = this.at;
    const indexOffsets = new Bytes();
    for (const [channel, entries] of offsets) {
      indexOffsets.u16(channel).u64(this.at);
      const pairs = new Bytes();
      for (const [t, o] of entries) pairs.u64(t).u64(o);
      const body = pairs.done();
      this.record(0x07, new Bytes().u16(channel).u32(body.length).raw(body).done());
    }
    const map = indexOffsets.done();
    this.summary.push(new Bytes().u64(first).u64(last).u64(start).u64(chunkLength)
      .u32(map.length).raw(map).u64(this.at - indexStart).string('').u64(recordsLen).u64(recordsLen).done());
  }

  close() {
    this.record(0x0F, Buffer.alloc(4));
    const summaryStart = this.at;
    for (const schema of this.schemas.values()) this.record(0x03, schema);
    for (const channel of this.channels) this.record(0x04, channel);
    for (const index of this.summary) this.record(0x08, index);
    // Statistics: message, schema, channel, attachment, metadata and chunk counts, the first and
    // last log time, messages per channel.
    const perChannel = new Bytes();
    for (const [channel, n] of this.counts) perChannel.u16(channel).u64(n);
    const map = perChannel.done();
    const total = [...this.counts.values()].reduce((a, b) => a + b, 0);
    this.record(0x0B, new Bytes().u64(total).u16(this.schemas.size).u32(this.channels.length).u32(0).u32(0)
      .u32(this.summary.length).u64(this.times[0] ?? 0).u64(this.times.at(-1) ?? 0).u32(map.length).raw(map).done());
    this.record(0x02, new Bytes().u64(summaryStart).u64(0).u32(0).done());
    this.write(MAGIC);
    ftruncateSync(this.fd, this.at);
    closeSync(this.fd);
    return this.at;
  }
}
