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

/// Reads files of which some rows or items cannot be read: they are left
/// out and reported in their file's note, the rest is read. Returns the
/// batch and the first row's error (naming file, line or path, and field).
pub fn read_in_part(files: &[(&str, Vec<u8>)], o: &ReadOptions) -> (Batch, String) {
    let b = read(files, o).unwrap_or_else(|e| panic!("the whole file was refused: {e}"));
    assert!(b.unread.count > 0, "nothing was left out: {:?}", b.notes);
    let first = b.unread.first[0].clone();
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("could not be read") && n.contains(&first)),
        "no note reports {first}: {:?}",
        b.notes
    );
    (b, first)
}
