//! `new RecordingFile(size, readAt, fileName)`: a ROS recording (MCAP, ROS 1 bag, rosbag2
//! `.db3`) read through `readAt(offset, length) -> Uint8Array` (in the page: `File.slice` and
//! `FileReaderSync` in a worker), so only its summary, index and the chosen messages' chunks
//! are ever read. `topics()` lists it; `rig(options)` gives the scans, nominals and reference
//! in the shape `calibrate` takes.

use std::collections::BTreeMap;

use js_sys::{Float32Array, Function, Uint8Array};
use serde::{Deserialize, Serialize};
use wasm_bindgen::prelude::*;

use super::{XyzRpy, to_js};
use crate::io::recording::instants::InstantSettings;
use crate::io::recording::{Kind, ReadAt, Recording, RigRequest};

/// The page's reader: a JS function returning the bytes at an offset.
struct JsSource {
    size: u64,
    read: Function,
}

impl ReadAt for JsSource {
    fn size(&self) -> u64 {
        self.size
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        let bytes = self
            .read
            .call2(&JsValue::NULL, &(offset as f64).into(), &(buf.len() as f64).into())
            .map_err(|e| std::io::Error::other(format!("{e:?}")))?;
        let bytes = Uint8Array::new(&bytes);
        if bytes.length() as usize != buf.len() {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        bytes.copy_to(buf);
        Ok(())
    }
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct TopicOutput {
    name: String,
    type_name: String,
    /// `pointCloud`, `tf` or `other`.
    kind: &'static str,
    count: usize,
    rate_hz: f64,
}

#[derive(Deserialize, Default)]
#[serde(rename_all = "camelCase", default)]
struct RigOptions {
    topics: Option<Vec<String>>,
    reference: Option<String>,
    base_frame: Option<String>,
    frames: Option<usize>,
    /// Largest offset between a topic's scan and the reference's (ms).
    tolerance_ms: Option<f64>,
}

#[derive(Serialize)]
struct RecordingScan {
    sensor: String,
    frame: String,
    #[serde(with = "serde_wasm_bindgen::preserve")]
    points: Float32Array,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct RigOutput {
    scans: Vec<RecordingScan>,
    nominal: BTreeMap<String, XyzRpy>,
    reference: String,
    base_frame: String,
    /// Topic -> its frame id.
    frame_ids: BTreeMap<String, String>,
    /// Topic -> its sensor's name (the frame id, unless empty or shared; the child of each
    /// export).
    sensors: BTreeMap<String, String>,
    /// Per instant: the reference's time (s) and each other topic's offset (ms).
    instants: Vec<(f64, Vec<f64>)>,
    moving: bool,
    identity_nominals: bool,
    problems: Vec<String>,
    /// Topics left out (not named, and not in the tree): "topic: why".
    left_out: Vec<String>,
}

#[wasm_bindgen]
pub struct RecordingFile {
    recording: Recording,
}

#[wasm_bindgen]
impl RecordingFile {
    /// Opens the recording; throws an `Error` naming the file and what is wrong.
    /// `onProgress(done, total)` (bytes) runs while a file without an index is scanned.
    #[wasm_bindgen(constructor)]
    pub fn new(
        size: f64,
        read_at: Function,
        file_name: &str,
        on_progress: Option<Function>,
    ) -> Result<RecordingFile, JsError> {
        let source = JsSource { size: size as u64, read: read_at };
        let mut progress = |done: u64, total: u64| {
            if let Some(f) = &on_progress {
                // Progress is advisory: an exception in it must not stop the scan.
                let _ = f.call2(&JsValue::NULL, &(done as f64).into(), &(total as f64).into());
            }
        };
        let recording = Recording::open(Box::new(source), file_name, &mut progress)
            .map_err(|e| JsError::new(&e.to_string()))?;
        Ok(Self { recording })
    }

    /// The topics: `[{name, typeName, kind, count, rateHz}]`.
    pub fn topics(&self) -> Result<JsValue, JsError> {
        let topics: Vec<TopicOutput> = self
            .recording
            .topics()
            .iter()
            .map(|t| TopicOutput {
                name: t.name.clone(),
                type_name: t.type_name.clone(),
                kind: match t.kind {
                    Kind::PointCloud2 | Kind::LivoxCustom => "pointCloud",
                    Kind::TfMessage => "tf",
                    Kind::Other => "other",
                },
                count: t.count,
                rate_hz: t.rate_hz(),
            })
            .collect();
        to_js(&topics)
    }

    /// Damage found while opening that leaves the rest readable, as sentences.
    pub fn problems(&self) -> Vec<String> {
        self.recording.problems().iter().map(ToString::to_string).collect()
    }

    /// The rig `options` ({topics, reference, baseFrame, frames, toleranceMs}) ask for.
    pub fn rig(&mut self, options: JsValue) -> Result<JsValue, JsError> {
        let o: RigOptions = super::options_or_default(options, "rig")?;
        let mut instants = InstantSettings::default();
        instants.frames = o.frames.unwrap_or(instants.frames);
        if let Some(ms) = o.tolerance_ms.filter(|ms| ms.is_finite() && *ms >= 0.0) {
            instants.tolerance_ns = (ms * 1e6) as u64;
        }
        let request = RigRequest {
            topics: o.topics,
            reference: o.reference,
            base_frame: o.base_frame.unwrap_or_else(|| "base_link".into()),
            instants,
            urdf: None,
        };
        let label = self.recording.file().to_string();
        let rig =
            self.recording.rig(&request).map_err(|e| JsError::new(&format!("{label}: {e}")))?;
        to_js(&RigOutput {
            scans: rig
                .scans
                .iter()
                .map(|s| RecordingScan {
                    sensor: s.sensor.clone(),
                    frame: s.frame.clone(),
                    points: Float32Array::from(s.points.as_flattened()),
                })
                .collect(),
            nominal: rig.nominal.iter().map(|(n, p)| (n.clone(), XyzRpy::from(p))).collect(),
            reference: rig.reference,
            base_frame: rig.base,
            frame_ids: rig.frames.into_iter().collect(),
            sensors: rig.sensors.into_iter().collect(),
            instants: rig
                .picks
                .iter()
                .map(|p| {
                    let offsets = p.others.iter().map(|(_, d)| *d as f64 * 1e-6).collect();
                    (p.reference_ns as f64 * 1e-9, offsets)
                })
                .collect(),
            moving: rig.motion.moving,
            identity_nominals: rig.identity_nominals,
            problems: rig.problems.iter().map(ToString::to_string).collect(),
            left_out: rig.left_out.iter().map(|(t, why)| format!("{t}: {why}")).collect(),
        })
    }
}
