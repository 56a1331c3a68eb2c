//! Scratch files of the command-line tests.

use std::path::PathBuf;
use std::sync::OnceLock;

/// A path for the scratch file `name` of this test binary: in a directory of its own under
/// cargo's `CARGO_TARGET_TMPDIR` (inside the target directory, not the system's temporary
/// directory), emptied the first time the binary asks for it, so a run leaves nothing outside
/// the target directory and never reads a file an earlier run wrote.
pub fn scratch(name: &str) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(env!("CARGO_CRATE_NAME"));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch directory");
        dir
    })
    .join(name)
}
