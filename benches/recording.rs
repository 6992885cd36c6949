//! Recording benchmark (prints, asserts nothing): `cargo run --release --bin bench-recording`.
//! Writes a synthetic MCAP in memory (our own minimal writer, for this benchmark only: the
//! tests' fixtures come from independent writers) holding 100 PointCloud2 scans of 131,072
//! points (x y z intensity f32, CDR), one uncompressed chunk each with its message index and a
//! summary; then times opening it (listing topics from the summary and message indexes) and
//! decoding all 100 scans, from memory and from a file.

// Native only: it writes a file and times reading it back; the wasm build (cargo test for
// wasm32 builds every bin) is empty.
#[cfg(target_arch = "wasm32")]
fn main() {}

#[cfg(not(target_arch = "wasm32"))]
fn main() {
    native::main();
}

#[cfg(not(target_arch = "wasm32"))]
mod native {
    use std::time::Instant;

    use gmmcalib::io::recording::Recording;

    const SCANS: usize = 100;
    const POINTS: usize = 131_072;

    fn record(out: &mut Vec<u8>, op: u8, body: &[u8]) {
        out.push(op);
        out.extend((body.len() as u64).to_le_bytes());
        out.extend(body);
    }

    fn string(out: &mut Vec<u8>, s: &str) {
        out.extend((s.len() as u32).to_le_bytes());
        out.extend(s.as_bytes());
    }

    /// A CDR PointCloud2 of `POINTS` points on a slowly turning spiral.
    fn cloud(k: usize) -> Vec<u8> {
        let mut m = vec![0, 1, 0, 0];
        m.extend((k as i32).to_le_bytes());
        m.extend(0u32.to_le_bytes());
        let frame = b"lidar\0";
        m.extend((frame.len() as u32).to_le_bytes());
        m.extend(frame);
        while (m.len() - 4) % 4 != 0 {
            m.push(0);
        }
        m.extend(1u32.to_le_bytes());
        m.extend((POINTS as u32).to_le_bytes());
        m.extend(4u32.to_le_bytes());
        for (i, name) in ["x", "y", "z", "intensity"].iter().enumerate() {
            m.extend((name.len() as u32 + 1).to_le_bytes());
            m.extend(name.as_bytes());
            m.push(0);
            while (m.len() - 4) % 4 != 0 {
                m.push(0);
            }
            m.extend((4 * i as u32).to_le_bytes());
            m.push(7);
            while (m.len() - 4) % 4 != 0 {
                m.push(0);
            }
            m.extend(1u32.to_le_bytes());
        }
        m.push(0); // is_bigendian
        while (m.len() - 4) % 4 != 0 {
            m.push(0);
        }
        m.extend(16u32.to_le_bytes());
        m.extend((16 * POINTS as u32).to_le_bytes());
        m.extend((16 * POINTS as u32).to_le_bytes());
        for i in 0..POINTS {
            let a = i as f32 * 0.001 + k as f32 * 0.01;
            let r = 2.0 + (i % 1000) as f32 * 0.03;
            for v in [r * a.cos(), r * a.sin(), (i % 64) as f32 * 0.05 - 1.0, (i % 256) as f32] {
                m.extend(v.to_le_bytes());
            }
        }
        m.push(1); // is_dense
        m
    }

    fn synthetic_mcap() -> Vec<u8> {
        let mut f = b"\x89MCAP0\r\n".to_vec();
        let mut body = Vec::new();
        string(&mut body, "ros2");
        string(&mut body, "bench");
        record(&mut f, 0x01, &body);
        let mut schema = 1u16.to_le_bytes().to_vec();
        string(&mut schema, "sensor_msgs/msg/PointCloud2");
        string(&mut schema, "ros2msg");
        schema.extend(0u32.to_le_bytes());
        let mut channel = 1u16.to_le_bytes().to_vec();
        channel.extend(1u16.to_le_bytes());
        string(&mut channel, "/lidar/points");
        string(&mut channel, "cdr");
        channel.extend(0u32.to_le_bytes());
        record(&mut f, 0x03, &schema);
        record(&mut f, 0x04, &channel);
        let mut chunk_indexes = Vec::new();
        for k in 0..SCANS {
            let t = 1_000_000_000 + k as u64 * 100_000_000;
            let mut message = 1u16.to_le_bytes().to_vec();
            message.extend((k as u32).to_le_bytes());
            message.extend(t.to_le_bytes());
            message.extend(t.to_le_bytes());
            message.extend(cloud(k));
            let mut records = Vec::new();
            record(&mut records, 0x05, &message);
            let start = f.len() as u64;
            let mut chunk = Vec::new();
            chunk.extend(t.to_le_bytes());
            chunk.extend(t.to_le_bytes());
            chunk.extend((records.len() as u64).to_le_bytes());
            chunk.extend(0u32.to_le_bytes()); // no CRC
            string(&mut chunk, "");
            chunk.extend((records.len() as u64).to_le_bytes());
            chunk.extend(&records);
            record(&mut f, 0x06, &chunk);
            let chunk_len = f.len() as u64 - start;
            let index_start = f.len() as u64;
            let mut index = 1u16.to_le_bytes().to_vec();
            index.extend(16u32.to_le_bytes());
            index.extend(t.to_le_bytes());
            index.extend(0u64.to_le_bytes());
            record(&mut f, 0x07, &index);
            let mut ci = Vec::new();
            ci.extend(t.to_le_bytes());
            ci.extend(t.to_le_bytes());
            ci.extend(start.to_le_bytes());
            ci.extend(chunk_len.to_le_bytes());
            ci.extend(10u32.to_le_bytes());
            ci.extend(1u16.to_le_bytes());
            ci.extend(index_start.to_le_bytes());
            ci.extend((f.len() as u64 - index_start).to_le_bytes());
            string(&mut ci, "");
            ci.extend((records.len() as u64).to_le_bytes());
            ci.extend((records.len() as u64).to_le_bytes());
            chunk_indexes.push(ci);
        }
        record(&mut f, 0x0F, &0u32.to_le_bytes());
        let summary = f.len() as u64;
        record(&mut f, 0x03, &schema);
        record(&mut f, 0x04, &channel);
        for ci in &chunk_indexes {
            record(&mut f, 0x08, ci);
        }
        let mut footer = summary.to_le_bytes().to_vec();
        footer.extend(0u64.to_le_bytes());
        footer.extend(0u32.to_le_bytes());
        record(&mut f, 0x02, &footer);
        f.extend(b"\x89MCAP0\r\n");
        f
    }

    fn decode_all(rec: &mut Recording) -> usize {
        (0..SCANS).map(|m| rec.point_cloud(0, m).map(|pc| pc.cloud.points.len()).unwrap_or(0)).sum()
    }

    pub fn main() {
        let t = Instant::now();
        let data = synthetic_mcap();
        let mb = data.len() as f64 / 1e6;
        println!(
            "synthetic MCAP: {SCANS} scans x {POINTS} points, {mb:.0} MB, written in {:.2} s",
            t.elapsed().as_secs_f64()
        );
        let path = std::env::temp_dir().join("gmmcalib-bench.mcap");
        std::fs::write(&path, &data).expect("temporary file");

        let t = Instant::now();
        let mut rec = Recording::open(Box::new(data), "bench.mcap", &mut |_, _| {}).expect("open");
        let open_s = t.elapsed().as_secs_f64();
        println!(
            "memory: open + list topics {:.3} ms ({} messages)",
            open_s * 1e3,
            rec.topics()[0].count
        );
        let t = Instant::now();
        let points = decode_all(&mut rec);
        let s = t.elapsed().as_secs_f64();
        println!(
            "memory: decode {SCANS} scans {s:.3} s ({:.1} ms/scan, {:.0} MB/s, {points} points)",
            s * 1e3 / SCANS as f64,
            mb / s
        );

        let t = Instant::now();
        let mut rec = Recording::open_path(&path, &mut |_, _| {}).expect("open file");
        println!("file: open + list topics {:.3} ms", t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let points = decode_all(&mut rec);
        let s = t.elapsed().as_secs_f64();
        println!(
            "file: decode {SCANS} scans {s:.3} s ({:.1} ms/scan, {points} points)",
            s * 1e3 / SCANS as f64
        );
        let _ = std::fs::remove_file(&path);
    }
}
