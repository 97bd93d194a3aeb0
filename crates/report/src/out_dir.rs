//! The report folder, checked before a run ([`ReportDir::prepare`]) so that
//! a long simulation never ends in "cannot write".
//!
//! What is accepted:
//! - a folder that does not exist yet (it is created, with its parents);
//! - an empty folder;
//! - the folder of an earlier abba report (it holds a `manifest.json`
//!   whose `tool` is `"abba"`).
//!
//! What is refused, with the reason: a path that is a file; a folder that
//! holds other things and no abba manifest (abba does not mix its files
//! into someone else's folder, nor delete from it); a folder abba cannot
//! create or write into (a test file is written and removed).
//!
//! Old files: when the new report is written, the files abba itself wrote
//! before are removed first, so that nothing stale stays beside the new
//! report: every name of [`REPORT_FILES`] and, in `traces/`, every trace
//! file (`*.csv`, `*.decisions.jsonl`; `traces/` itself when that leaves it
//! empty). Other files in the folder are left as they are. Nothing is
//! removed before the run has finished and the whole report was built in
//! memory, so a failed run leaves the old report intact.

use std::path::{Path, PathBuf};

use crate::error::ReportError;
use crate::files::{ReportFile, REPORT_FILES};
use crate::trace::{is_trace_file, TRACE_DIR};

/// The file written and removed to check that the folder is writable.
const PROBE: &str = ".abba-write-check";

/// A report folder that was checked ([`ReportDir::prepare`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReportDir {
    path: PathBuf,
}

impl ReportDir {
    /// Checks `path` as a report folder (see the module docs), creating it
    /// if it does not exist. Call it before the run.
    pub fn prepare(path: &Path) -> Result<ReportDir, ReportError> {
        let refuse = |reason: String| ReportError::OutDir {
            path: path.to_path_buf(),
            reason,
        };
        let failed = |action: &'static str| {
            move |source| ReportError::OutDirIo {
                path: path.to_path_buf(),
                action,
                source,
            }
        };
        match std::fs::metadata(path) {
            Ok(meta) if !meta.is_dir() => {
                return Err(refuse(
                    "exists and is not a folder; give a new folder, an empty one, or an earlier abba report"
                        .to_string(),
                ))
            }
            Ok(_) => {
                let entries = std::fs::read_dir(path).map_err(failed("list the contents of"))?;
                let mut others = Vec::new();
                for entry in entries {
                    let entry = entry.map_err(failed("list the contents of"))?;
                    others.push(entry.file_name().to_string_lossy().into_owned());
                }
                if !others.is_empty() && !is_abba_report(path) {
                    others.sort();
                    let shown: Vec<&str> = others.iter().take(3).map(String::as_str).collect();
                    return Err(refuse(format!(
                        "is not empty ({}{}) and is not an abba report (no manifest.json written by abba); \
                         give a new or empty folder, or an earlier abba report to replace",
                        shown.join(", "),
                        if others.len() > 3 { ", ..." } else { "" }
                    )));
                }
            }
            // Missing (or unreadable: then creating it says why).
            Err(_) => {
                std::fs::create_dir_all(path).map_err(failed("create"))?;
            }
        }
        let probe = path.join(PROBE);
        std::fs::write(&probe, b"")
            .and_then(|()| std::fs::remove_file(&probe))
            .map_err(failed("write into"))?;
        Ok(ReportDir {
            path: path.to_path_buf(),
        })
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Removes the files abba wrote here before (see the module docs), then
    /// writes `files`. Returns the paths written, in order.
    pub fn write_report(&self, files: &[ReportFile]) -> Result<Vec<PathBuf>, ReportError> {
        self.remove_previous()?;
        let mut written = Vec::with_capacity(files.len());
        for f in files {
            let path = self.path.join(f.name);
            std::fs::write(&path, &f.bytes).map_err(ReportError::io("write", &path))?;
            written.push(path);
        }
        Ok(written)
    }

    /// Writes one run's trace (`traces/<stem>.csv`) and decisions
    /// (`traces/<stem>.decisions.jsonl`).
    pub fn write_trace(
        &self,
        stem: &str,
        csv: &str,
        decisions_jsonl: &str,
    ) -> Result<[PathBuf; 2], ReportError> {
        let dir = self.path.join(TRACE_DIR);
        std::fs::create_dir_all(&dir).map_err(ReportError::io("create", &dir))?;
        let csv_path = dir.join(format!("{stem}.csv"));
        std::fs::write(&csv_path, csv).map_err(ReportError::io("write", &csv_path))?;
        let jsonl_path = dir.join(format!("{stem}.decisions.jsonl"));
        std::fs::write(&jsonl_path, decisions_jsonl)
            .map_err(ReportError::io("write", &jsonl_path))?;
        Ok([csv_path, jsonl_path])
    }

    /// Removes the report files and trace files of an earlier run.
    fn remove_previous(&self) -> Result<(), ReportError> {
        for name in REPORT_FILES {
            remove_if_present(&self.path.join(name))?;
        }
        let traces = self.path.join(TRACE_DIR);
        if !traces.is_dir() {
            return Ok(());
        }
        let entries = std::fs::read_dir(&traces).map_err(ReportError::io("list", &traces))?;
        for entry in entries {
            let entry = entry.map_err(ReportError::io("list", &traces))?;
            let is_file = entry.file_type().is_ok_and(|t| t.is_file());
            if is_file && is_trace_file(&entry.file_name().to_string_lossy()) {
                remove_if_present(&entry.path())?;
            }
        }
        let empty = std::fs::read_dir(&traces)
            .map_err(ReportError::io("list", &traces))?
            .next()
            .is_none();
        if empty {
            std::fs::remove_dir(&traces).map_err(ReportError::io("remove", &traces))?;
        }
        Ok(())
    }
}

/// Whether `dir` holds a manifest written by abba.
fn is_abba_report(dir: &Path) -> bool {
    std::fs::read_to_string(dir.join("manifest.json"))
        .ok()
        .and_then(|text| serde_json::from_str::<serde_json::Value>(&text).ok())
        .is_some_and(|m| m["tool"] == "abba")
}

fn remove_if_present(path: &Path) -> Result<(), ReportError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(ReportError::io("remove", path)(e))
        }
        _ => Ok(()),
    }
}
