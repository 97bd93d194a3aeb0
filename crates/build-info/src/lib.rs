//! For build scripts (`[build-dependencies]`): records the git revision a
//! package was built from, so that reports can name it. One helper for every
//! crate that needs it (the CLI, the Python package).

use std::path::Path;
use std::process::Command;

/// The short git revision of the checkout (`-dirty` when tracked files have
/// uncommitted changes), or `"unknown"` outside a git checkout.
pub fn git_revision() -> String {
    git_revision_in(Path::new("."))
}

/// [`git_revision`] of the checkout that holds `dir`. Reads the checkout
/// without writing to it.
pub fn git_revision_in(dir: &Path) -> String {
    let rev = Command::new("git")
        .current_dir(dir)
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|| "unknown".to_string());
    // Mark a build from a work tree with uncommitted changes. Without the
    // optional locks, `git status` does not write the refreshed index back:
    // a fresh clone's first status would, and the newer .git/index would
    // then rerun this script (and rebuild its crate) on the next build.
    let dirty = Command::new("git")
        .current_dir(dir)
        .args([
            "--no-optional-locks",
            "status",
            "--porcelain",
            "--untracked-files=no",
        ])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .is_some_and(|o| !o.stdout.is_empty());
    if dirty && rev != "unknown" {
        format!("{rev}-dirty")
    } else {
        rev
    }
}

/// Called from a build script of a crate two folders below the workspace
/// root (`crates/<name>`): sets the compile-time variable `ABBA_GIT_REV`
/// (read with `env!("ABBA_GIT_REV")`) and asks Cargo to run the script again
/// when the checkout's HEAD, refs or index change.
pub fn emit_git_revision() {
    println!("cargo:rustc-env=ABBA_GIT_REV={}", git_revision());
    println!("cargo:rerun-if-changed=../../.git/HEAD");
    println!("cargo:rerun-if-changed=../../.git/refs");
    println!("cargo:rerun-if-changed=../../.git/index");
}

#[cfg(test)]
mod tests {
    use super::git_revision_in;
    use std::path::Path;
    use std::process::Command;

    fn git(dir: &Path, args: &[&str]) {
        let out = Command::new("git")
            .current_dir(dir)
            .args(args)
            .output()
            .expect("git runs");
        assert!(out.status.success(), "git {args:?}: {out:?}");
    }

    /// A file touched after the commit (same content, newer mtime) is what
    /// a fresh clone's files look like to git: a plain `git status` would
    /// refresh the index and write it back. Reading the revision must not,
    /// or Cargo would rerun the build script (`rerun-if-changed` on the
    /// index) and rebuild its crate on the next build.
    #[test]
    fn reading_the_revision_leaves_the_index_untouched_and_a_clean_tree_clean() {
        let dir = std::env::temp_dir().join(format!("abba-build-info-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        git(&dir, &["init", "-q"]);
        std::fs::write(dir.join("a.txt"), "a\n").expect("write");
        git(&dir, &["add", "a.txt"]);
        git(
            &dir,
            &[
                "-c",
                "user.name=t",
                "-c",
                "user.email=t@t",
                "commit",
                "-qm",
                "one",
            ],
        );
        std::thread::sleep(std::time::Duration::from_millis(1100));
        std::fs::write(dir.join("a.txt"), "a\n").expect("touch");
        let index = dir.join(".git/index");
        let before = std::fs::metadata(&index)
            .and_then(|m| m.modified())
            .expect("index");
        let rev = git_revision_in(&dir);
        let after = std::fs::metadata(&index)
            .and_then(|m| m.modified())
            .expect("index");
        assert_eq!(before, after, "the index was rewritten");
        assert_eq!(rev.len(), 12, "{rev}");
        assert!(!rev.ends_with("-dirty"), "{rev}");
        // A real change is still seen.
        std::fs::write(dir.join("a.txt"), "b\n").expect("change");
        assert!(git_revision_in(&dir).ends_with("-dirty"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
