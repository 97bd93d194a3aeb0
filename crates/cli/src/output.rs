//! Output files: never the same file as an input, and never left half
//! written.

use anyhow::{bail, Context, Result};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Refuses two of `paths` (each with the flag that named it) that are the
/// same file once canonicalised (symbolic links, `./`, `..` resolved), so an
/// output never overwrites an input or another output.
pub fn distinct_paths(paths: &[(&str, &Path)]) -> Result<()> {
    let resolved: Vec<PathBuf> = paths.iter().map(|(_, p)| canonical(p)).collect();
    for (i, a) in resolved.iter().enumerate() {
        for (j, b) in resolved.iter().enumerate().skip(i + 1) {
            if a == b {
                bail!(
                    "{} {} and {} {} are the same file ({}); refusing to overwrite it",
                    paths[i].0,
                    paths[i].1.display(),
                    paths[j].0,
                    paths[j].1.display(),
                    a.display()
                );
            }
        }
    }
    Ok(())
}

/// The canonical form of `path`; for a file that does not exist yet, its
/// folder's canonical form joined with its name.
fn canonical(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    match (parent.canonicalize(), path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// Writes `path` through `write`: into a temporary file in the same folder,
/// renamed over `path` only when `write` succeeded, so a failure (a solver
/// error half-way, a full disk) leaves no partial file and an old `path`
/// untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<&mut tempfile::NamedTempFile>) -> Result<()>,
) -> Result<()> {
    let shown = path.display();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".abba-").suffix(".partial");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // The mode of a file created the ordinary way (before the umask).
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .with_context(|| format!("cannot create output file {shown}"))?;
    {
        let mut w = BufWriter::new(&mut tmp);
        write(&mut w)?;
        w.flush().with_context(|| format!("cannot write {shown}"))?;
    }
    tmp.persist(path)
        .with_context(|| format!("cannot write {shown}"))?;
    Ok(())
}
