//! Reads export files and prints the record counts: used to measure time
//! and peak memory with `/usr/bin/time -v` (BENCHMARKS.md).
#![allow(missing_docs)]

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let tz = match args.iter().position(|a| a == "--tz") {
        Some(i) => {
            let z = args.remove(i + 1);
            args.remove(i);
            Some(abba_io::time::zone(&z)?)
        }
        None => None,
    };
    let paths: Vec<std::path::PathBuf> = args.iter().map(Into::into).collect();
    let batch = abba_io::read_files(
        &paths,
        &abba_io::ReadOptions {
            tz,
            ..Default::default()
        },
    )?;
    println!(
        "{} records ({} cgm)",
        batch.records.len(),
        batch.count("cgm")
    );
    Ok(())
}
