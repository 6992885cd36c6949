//! The edge where results meet people and programs: the JSON shape (`gmmcalib calibrate
//! --json`, the wasm `calibrate`, the page), the CLI's text, and every sentence made from the
//! calibration's typed notes. Compute code returns typed data; prose is made here. The files
//! a result is written as are `export`'s.

mod drift;
mod json;
mod sentences;
mod text;

pub use drift::{DriftReport, LimitReport, SensorDriftReport, drift_findings, drift_table};
pub use json::{
    CandidateReport, GlobalReport, GroundReport, HistoryReport, HypothesisReport, LevellingReport,
    NoteReport, OverlayReport, PlacementReport, ReasonReport, ReconstructionReport, Report,
    RoiReport, SelectionReport, SensorReport, SensorVerdictReport, Value, VerdictReport,
};
pub use text::{comparison, summary, verdict};
