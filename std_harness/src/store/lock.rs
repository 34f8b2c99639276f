//! An advisory, exclusive lock on an output directory, held while a writer reads, merges
//! and rewrites its result files, so two processes writing runs into one directory (two
//! shards, two terminals, array tasks on a shared file system) never drop each other's runs.

use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

use anyhow::Context;

/// The lock file's name inside the directory (it stays there; only the lock comes and goes).
pub const LOCK_FILE: &str = ".awfqi-harness.lock";

/// Held until dropped. The operating system releases it if the process dies, so a killed
/// writer never leaves the directory locked.
#[derive(Debug)]
pub struct DirLock {
    file: File,
    path: PathBuf,
}

impl DirLock {
    /// Blocks until this process holds the lock of `dir` (which must exist).
    pub fn acquire(dir: &Path) -> anyhow::Result<Self> {
        let path = dir.join(LOCK_FILE);
        let file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .with_context(|| format!("opening the lock file {}", path.display()))?;
        // `flock(2)` on Unix: advisory, released on close or death; on NFS the Linux
        // client maps it onto the server's byte-range locks.
        file.lock()
            .with_context(|| format!("locking {}", path.display()))?;
        Ok(Self { file, path })
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        // Closing the file releases the lock as well; unlocking first makes it explicit.
        if let Err(e) = self.file.unlock() {
            eprintln!("warning: unlocking {}: {e}", self.path.display());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::{Arc, Barrier};
    use std::time::Duration;

    #[test]
    fn a_second_holder_waits_until_the_first_drops_it() {
        let dir = std::env::temp_dir().join(format!("awfqi-lock-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let first = DirLock::acquire(&dir).unwrap();
        let released = Arc::new(AtomicBool::new(false));
        let started = Arc::new(Barrier::new(2));
        let waiter = {
            let (dir, released, started) = (dir.clone(), released.clone(), started.clone());
            std::thread::spawn(move || {
                started.wait();
                // A separate open file description: flock excludes it like another process.
                let _second = DirLock::acquire(&dir).unwrap();
                released.load(Ordering::SeqCst)
            })
        };
        started.wait();
        std::thread::sleep(Duration::from_millis(100));
        released.store(true, Ordering::SeqCst);
        drop(first);
        assert!(
            waiter.join().unwrap(),
            "the second lock was granted while the first was held"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
