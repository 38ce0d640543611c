//! Paths of the checkout, for the integration tests of every package of the workspace: the
//! root package's (tests/) and each crate's (crates/*/tests, which run in the crate's folder).

use std::path::{Path, PathBuf};

/// `path` in the checkout's root (the workspace's, which holds Cargo.lock, tests/data and
/// target/), whichever package's tests ask.
pub fn repo(path: impl AsRef<Path>) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .find(|dir| dir.join("Cargo.lock").is_file())
        .expect("the workspace's root holds Cargo.lock");
    root.join(path)
}

/// A file of the shared real data set (`../shared/data`, beside the checkout).
pub fn shared_data(name: &str) -> PathBuf {
    let path = repo("../shared/data").join(name);
    assert!(path.exists(), "test data {} is missing", path.display());
    path
}

/// Where tests may write images worth looking at (target/test-images).
pub fn image_dir() -> PathBuf {
    let dir = repo("target/test-images");
    std::fs::create_dir_all(&dir).expect("create target/test-images");
    dir
}
