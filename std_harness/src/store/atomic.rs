//! Writes that never leave a half-written result file, and the backups `--replace` keeps.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::Context;

/// Distinguishes the temporary files of one process's concurrent writes.
static TEMPORARIES: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` through a temporary file in the same directory, flushed to
/// disk and then renamed over `path`: a write that fails (no space, no permission, a file
/// size limit) or a process killed mid-way leaves the previous `path` exactly as it was.
///
/// Errors: the temporary file cannot be created, written, synced or renamed; the message
/// names `path` and the cause, and the temporary file is removed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let temporary = temporary_path(path);
    let written = (|| -> std::io::Result<()> {
        let mut file = std::fs::File::create(&temporary)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        std::fs::rename(&temporary, path)
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&temporary);
        return Err(e).with_context(|| {
            format!(
                "writing {} failed; the previous file, if any, is unchanged",
                path.display()
            )
        });
    }
    Ok(())
}

/// Writes `rows` as CSV with a header, atomically ([`write_atomic`]).
pub fn write_csv<T: serde::Serialize>(path: &Path, rows: &[T]) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)
            .with_context(|| format!("formatting {}", path.display()))?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| anyhow::anyhow!("formatting {}: {e}", path.display()))?;
    write_atomic(path, &bytes)
}

/// `.<name>.<pid>.<n>.partial` next to `path`: hidden, and unique among writers.
fn temporary_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "file".into(), |n| n.to_string_lossy().into_owned());
    let n = TEMPORARIES.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{name}.{}.{n}.partial", std::process::id()))
}

/// Moves `path` aside as `<name>.<UTC timestamp>.bak` (e.g.
/// `fqi.json.20260514T101502Z.bak`; `-1`, `-2`… is appended to the timestamp when that
/// name is taken) and returns the backup's path.
pub fn backup(path: &Path) -> anyhow::Result<PathBuf> {
    let target = backup_path(path);
    std::fs::rename(path, &target)
        .with_context(|| format!("moving {} to {}", path.display(), target.display()))?;
    Ok(target)
}

/// Copies `path` to its backup name (as [`backup`]) and leaves `path` in place.
pub fn copy_backup(path: &Path) -> anyhow::Result<PathBuf> {
    let target = backup_path(path);
    std::fs::copy(path, &target)
        .with_context(|| format!("copying {} to {}", path.display(), target.display()))?;
    Ok(target)
}

fn backup_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "file".into(), |n| n.to_string_lossy().into_owned());
    let stamp = utc_timestamp(SystemTime::now());
    let mut target = path.with_file_name(format!("{name}.{stamp}.bak"));
    let mut n = 1;
    while target.exists() {
        target = path.with_file_name(format!("{name}.{stamp}-{n}.bak"));
        n += 1;
    }
    target
}

/// `YYYYMMDDTHHMMSSZ` in UTC.
fn utc_timestamp(t: SystemTime) -> String {
    let secs = t.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rest) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!(
        "{y:04}{m:02}{d:02}T{:02}{:02}{:02}Z",
        rest / 3600,
        rest / 60 % 60,
        rest % 60
    )
}

/// The proleptic Gregorian date of a day count since 1970-01-01 (Howard Hinnant's
/// `civil_from_days`).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn timestamps_are_utc_calendar_dates() {
        let at = |s: u64| utc_timestamp(UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "19700101T000000Z");
        // 2000-02-29 (a leap day of a century leap year) 12:34:56.
        assert_eq!(at(951_827_696), "20000229T123456Z");
        // 2024-12-31 23:59:59, then the next second.
        assert_eq!(at(1_735_689_599), "20241231T235959Z");
        assert_eq!(at(1_735_689_600), "20250101T000000Z");
    }

    #[test]
    fn a_write_replaces_the_file_and_leaves_no_temporary_and_backups_never_collide() {
        let dir = std::env::temp_dir().join(format!("awfqi-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("fqi.json");
        write_atomic(&path, b"old").unwrap();
        write_atomic(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        let a = copy_backup(&path).unwrap();
        let b = backup(&path).unwrap();
        assert_ne!(a, b);
        assert!(!path.exists());
        for p in [&a, &b] {
            assert_eq!(std::fs::read(p).unwrap(), b"new");
            let name = p.file_name().unwrap().to_str().unwrap();
            assert!(
                name.starts_with("fqi.json.") && name.ends_with(".bak"),
                "{name}"
            );
        }
        let names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        // A write into a directory that does not exist fails and names the file.
        let missing = dir.join("missing").join("fqi.json");
        let err = format!("{:#}", write_atomic(&missing, b"x").unwrap_err());
        assert!(err.contains("missing/fqi.json"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
