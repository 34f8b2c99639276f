//! Keeping result files safe in an output directory that several invocations share: an
//! advisory lock around every read-merge-write ([`DirLock`]), writes that either complete
//! or leave the previous file untouched ([`write_atomic`]), timestamped backups for
//! `--replace` ([`backup`]), the fields by which two configurations differ
//! ([`differences`]), and run indices that must not repeat ([`unique_runs`]). Nothing here knows what a result file holds.

mod atomic;
mod conflict;
mod diff;
mod lock;
mod unique;

pub use atomic::{backup, copy_backup, write_atomic, write_csv};
pub use conflict::{Conflict, conflict_error, refusal, writer_remedy};
pub use diff::{Difference, describe, differences};
pub use lock::DirLock;
pub use unique::unique_runs;
