//! Any bytes opened as this container must give an error or a recording whose messages read
//! and decode (or fail) without panicking.
#![no_main]

#[path = "recording_common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| common::exercise(data, b"SQLite format 3\0"));
