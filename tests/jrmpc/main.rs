//! Tests of `src/jrmpc`, one module per concern (one test binary: one link).

#[path = "../common/mod.rs"]
mod common;

/// The fidelity rule.
mod fidelity;
/// Joint registration.
mod registration;
