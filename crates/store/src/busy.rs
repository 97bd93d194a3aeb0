//! Who holds a store: the processes with a lock on the file or its WAL
//! index (Linux's `/proc/locks`), for the message "the store is busy (held
//! by ...)". Elsewhere nothing is known and the list is empty.

use std::path::Path;

/// `pid N (command line)` of every other process holding a lock on `db`,
/// its `-wal` or its `-shm` (SQLite's readers and writers both do).
pub fn lock_holders(db: &Path) -> Vec<String> {
    #[cfg(target_os = "linux")]
    {
        linux(db)
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = db;
        Vec::new()
    }
}

#[cfg(target_os = "linux")]
fn linux(db: &Path) -> Vec<String> {
    use std::os::unix::fs::MetadataExt;
    let mut inodes = Vec::new();
    for suffix in ["", "-wal", "-shm"] {
        let mut p = db.as_os_str().to_owned();
        p.push(suffix);
        if let Ok(m) = std::fs::metadata(&p) {
            inodes.push(m.ino());
        }
    }
    let Ok(locks) = std::fs::read_to_string("/proc/locks") else {
        return Vec::new();
    };
    let me = std::process::id();
    let mut pids: Vec<u32> = Vec::new();
    for line in locks.lines() {
        // "1: POSIX  ADVISORY  WRITE 1234 08:01:5678 128 128"
        let fields: Vec<&str> = line.split_whitespace().collect();
        let (Some(pid), Some(dev_ino)) = (fields.get(4), fields.get(5)) else {
            continue;
        };
        let (Ok(pid), Some(ino)) = (
            pid.parse::<u32>(),
            dev_ino
                .rsplit(':')
                .next()
                .and_then(|i| i.parse::<u64>().ok()),
        ) else {
            continue;
        };
        if pid != me && inodes.contains(&ino) && !pids.contains(&pid) {
            pids.push(pid);
        }
    }
    pids.sort_unstable();
    pids.into_iter()
        .map(|pid| {
            let cmd = std::fs::read(format!("/proc/{pid}/cmdline"))
                .map(|b| {
                    String::from_utf8_lossy(&b)
                        .split('\0')
                        .filter(|s| !s.is_empty())
                        .collect::<Vec<_>>()
                        .join(" ")
                })
                .unwrap_or_default();
            if cmd.is_empty() {
                format!("pid {pid}")
            } else {
                format!("pid {pid} ({cmd})")
            }
        })
        .collect()
}
