//! `gmmcalib drift STORED NEW` (`compare`, its first name, still works): the drift check over two files, its table on stdout, the
//! sensors that moved on stderr, and the exit status CI acts on.

use super::args::DriftArgs;
use super::calibrate::write_json;
use super::{Host, read_text};
use crate::drift;
use crate::report;

/// The exit status when a sensor moved beyond its limit or went missing.
pub const DRIFT: u8 = 3;

pub fn drift(a: &DriftArgs, host: &mut dyn Host) -> Result<u8, String> {
    let stored = drift::read(&read_text(host, &a.stored)?, &a.stored).map_err(|e| e.to_string())?;
    let new = drift::read(&read_text(host, &a.new)?, &a.new).map_err(|e| e.to_string())?;
    let result = drift::compare(&stored, &new, &a.tolerance)
        .map_err(|e| format!("{} against {}: {e}", a.new, a.stored))?;
    host.out(&report::drift_table(&result, &a.stored));
    write_json(host, a.json.as_deref(), &report::DriftReport::from(&result))?;
    if result.passed() {
        return Ok(0);
    }
    for line in report::drift_findings(&result) {
        host.err(&format!("gmmcalib: drift: {line}\n"));
    }
    Ok(DRIFT)
}
