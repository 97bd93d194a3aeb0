//! Shared helpers of abba-io's tests.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use abba_io::{read_all, Batch, IoError, ReadOptions};

/// The test data folder.
pub const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");

/// A fixture's bytes.
pub fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(format!("{DATA}/{name}")).unwrap()
}

/// Options with a zone.
pub fn opts(tz: &str) -> ReadOptions {
    ReadOptions {
        tz: Some(abba_io::time::zone(tz).unwrap()),
        ..ReadOptions::default()
    }
}

/// Reads named in-memory files.
pub fn read(files: &[(&str, Vec<u8>)], o: &ReadOptions) -> Result<Batch, IoError> {
    let inputs: Vec<(String, Vec<u8>)> = files
        .iter()
        .map(|(n, b)| (n.to_string(), b.clone()))
        .collect();
    read_all(&inputs, o)
}
