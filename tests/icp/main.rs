//! Tests of `src/icp`, one module per concern (one test binary: one link).

#[path = "../common/mod.rs"]
mod common;

/// The k-d tree.
mod kdtree;
/// P2p, p2l and GICP.
mod metrics;
