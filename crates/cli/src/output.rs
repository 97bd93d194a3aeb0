//! Output files: never the same file as an input, and never left half
//! written.

use anyhow::{bail, Context, Result};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Refuses two of `paths` (each with the flag that named it) that are the
/// same file once canonicalised (symbolic links, `./`, `..` resolved) or
/// hard links to one file, so an output never overwrites an input or
/// another output.
pub fn distinct_paths(paths: &[(&str, &Path)]) -> Result<()> {
    let resolved: Vec<PathBuf> = paths.iter().map(|(_, p)| canonical(p)).collect();
    for (i, a) in resolved.iter().enumerate() {
        for (j, b) in resolved.iter().enumerate().skip(i + 1) {
            if a == b || same_inode(a, b) {
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

/// Two existing paths to one file through hard links (Unix).
#[cfg(unix)]
fn same_inode(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => (x.dev(), x.ino()) == (y.dev(), y.ino()),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_inode(_: &Path, _: &Path) -> bool {
    false
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_and_spellings_of_one_file_are_the_same_file() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.csv");
        std::fs::write(&input, "x").unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let same = [
            dir.path().join("sub/../in.csv"),
            dir.path().join("./in.csv"),
        ];
        #[cfg(unix)]
        let linked = {
            let hard = dir.path().join("hard.csv");
            std::fs::hard_link(&input, &hard).unwrap();
            let soft = dir.path().join("soft.csv");
            std::os::unix::fs::symlink(&input, &soft).unwrap();
            vec![hard, soft]
        };
        #[cfg(not(unix))]
        let linked: Vec<PathBuf> = Vec::new();
        for other in same.iter().chain(&linked) {
            let e = distinct_paths(&[("--inputs", &input), ("--out", other)]).unwrap_err();
            assert!(e.to_string().contains("same file"), "{e}");
        }
        let new = dir.path().join("new.csv");
        distinct_paths(&[("--inputs", &input), ("--out", &new)]).unwrap();
    }

    #[test]
    fn a_failed_write_leaves_neither_a_partial_nor_a_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        std::fs::write(&out, "old").unwrap();
        let e = write_atomically(&out, |w| {
            w.write_all(b"half a result")?;
            anyhow::bail!("solver failed")
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "solver failed");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        write_atomically(&out, |w| Ok(w.write_all(b"new")?)).unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
