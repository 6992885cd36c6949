// Shared by the container targets: open any bytes as a recording (with the container's magic
// forced, so the fuzzer explores past it), then read and decode every message. Nothing may
// panic; every point returned must be finite.

use gmmcalib::io::recording::Recording;

pub fn exercise(data: &[u8], magic: &[u8]) {
    let mut bytes = data.to_vec();
    let n = magic.len().min(bytes.len());
    bytes[..n].copy_from_slice(&magic[..n]);
    let Ok(mut rec) = Recording::open(Box::new(bytes), "fuzz", &mut |_, _| {}) else { return };
    for t in 0..rec.topics().len() {
        let topic = rec.topics()[t].clone();
        for m in 0..topic.count.min(16) {
            match topic.kind {
                k if k.is_point_cloud() => {
                    if let Ok(pc) = rec.point_cloud(t, m) {
                        assert!(pc.cloud.points.iter().all(|p| p.iter().all(|c| c.is_finite())));
                    }
                }
                _ => {
                    let _ = rec.message(t, m);
                }
            }
        }
    }
    let _ = rec.transforms(true);
}
