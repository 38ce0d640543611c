//! Reading a folder store's chunk files ahead: the kernel is asked to bring the files of
//! the chunks a streamer will read next into the page cache (`posix_fadvise` with
//! `POSIX_FADV_WILLNEED`, Linux), so that the disk works on many of them at once while the
//! loaders decode, rather than on the few chunks the loaders read at a time (eight bricks
//! and their aprons share a 64³ chunk, so the loaders' reads overlap on few files).
//!
//! The advice is given on a thread of its own, one per pyramid, started by the first chunks
//! asked for and ended with the pyramid; the caller (a streamer's frame) never opens a file.
//! Nothing is read into this process: a file that is missing, unreadable or already cached
//! costs an `open` and nothing more, and a reader that comes before the disk's answer waits
//! for the same pages it would have read itself.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, OnceLock};

/// Files waiting to be advised at most: what [`ReadAhead::advise`] accepts before it answers
/// "no room" (a few frames of a near view's chunks, 64³ chunks of 0.2–0.5 MB).
pub const READ_AHEAD_FILES: usize = 256;

/// Asks the kernel to read a folder store's chunk files ahead of their reads.
pub(super) struct ReadAhead {
    /// The store's root: a chunk's file is its key below it (zarrs's `FilesystemStore`).
    root: PathBuf,
    /// To the advising thread, started by the first call.
    sender: OnceLock<Option<SyncSender<PathBuf>>>,
    /// Files sent and not yet advised.
    waiting: Arc<AtomicUsize>,
    /// Files opened and advised so far (missing and unreadable ones not counted).
    advised: Arc<AtomicU64>,
}

impl ReadAhead {
    /// Read-ahead for the folder store at `root`, where the system has it (Linux); `None`
    /// elsewhere.
    pub(super) fn for_folder(root: PathBuf) -> Option<Self> {
        cfg!(target_os = "linux").then(|| Self {
            root,
            sender: OnceLock::new(),
            waiting: Arc::default(),
            advised: Arc::default(),
        })
    }

    /// Files opened and advised so far.
    pub(super) fn advised(&self) -> u64 {
        self.advised.load(Ordering::Relaxed)
    }

    /// Whether [`Self::advise`] would take a file now.
    pub(super) fn has_room(&self) -> bool {
        self.waiting.load(Ordering::Relaxed) < READ_AHEAD_FILES
    }

    /// Hands the files of `keys` (store keys below the root), in this order, to the advising
    /// thread, as many as it has room for; returns how many it took from the first.
    pub(super) fn advise<'a>(&self, keys: impl IntoIterator<Item = &'a str>) -> usize {
        let Some(sender) = self.sender.get_or_init(|| self.start()) else {
            return 0;
        };
        let mut taken = 0;
        for key in keys {
            if !self.has_room() {
                break;
            }
            let path = self.root.join(key.trim_start_matches('/'));
            self.waiting.fetch_add(1, Ordering::Relaxed);
            match sender.try_send(path) {
                Ok(()) => taken += 1,
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                    self.waiting.fetch_sub(1, Ordering::Relaxed);
                    break;
                }
            }
        }
        taken
    }

    /// Starts the advising thread; `None` where the system refuses a thread (nothing is read
    /// ahead then).
    fn start(&self) -> Option<SyncSender<PathBuf>> {
        let (sender, receiver) = sync_channel::<PathBuf>(READ_AHEAD_FILES);
        let (waiting, advised) = (Arc::clone(&self.waiting), Arc::clone(&self.advised));
        std::thread::Builder::new()
            .name("voxscope-read-ahead".into())
            .spawn(move || {
                // Ends when the pyramid (the sender) is gone.
                for path in receiver {
                    if advise_file(&path) {
                        advised.fetch_add(1, Ordering::Relaxed);
                    }
                    waiting.fetch_sub(1, Ordering::Relaxed);
                }
            })
            .ok()?;
        Some(sender)
    }
}

/// Asks the kernel to read the whole file at `path` into the page cache, without waiting
/// for the reads; whether it was advised. A file that cannot be opened is passed over (its
/// reader will say why).
#[cfg(target_os = "linux")]
fn advise_file(path: &std::path::Path) -> bool {
    use std::os::fd::AsRawFd;
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    // SAFETY: `file` is an open descriptor for the duration of the call; the advice reads
    // nothing into this process's memory.
    unsafe { libc::posix_fadvise(file.as_raw_fd(), 0, 0, libc::POSIX_FADV_WILLNEED) == 0 }
}

#[cfg(not(target_os = "linux"))]
fn advise_file(_path: &std::path::Path) -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(target_os = "linux")]
    #[test]
    fn advises_at_most_its_room_and_frees_it_as_files_are_advised() {
        let folder = tempfile::tempdir().expect("a temporary folder");
        std::fs::write(folder.path().join("0.0.0"), [1u8; 64]).expect("written");
        let ahead = ReadAhead::for_folder(folder.path().to_path_buf()).expect("Linux");
        let keys: Vec<String> = (0..READ_AHEAD_FILES * 3)
            .map(|i| format!("/1.0.{i}"))
            .collect();
        // It takes its room, and more as the thread advises some meanwhile, never more than
        // asked for.
        let taken = ahead.advise(keys.iter().map(String::as_str));
        assert!((READ_AHEAD_FILES..=keys.len()).contains(&taken), "{taken}");
        // The thread advises them (missing files passed over) and the room comes back.
        let started = std::time::Instant::now();
        while !ahead.has_room() || ahead.waiting.load(Ordering::Relaxed) > 0 {
            assert!(
                started.elapsed().as_secs() < 10,
                "the advising thread is stuck"
            );
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        // Of them only the file that exists was advised.
        assert_eq!(ahead.advised(), 0);
        assert_eq!(ahead.advise(["0.0.0"]), 1);
        while ahead.advised() == 0 {
            assert!(
                started.elapsed().as_secs() < 10,
                "the advising thread is stuck"
            );
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
    }
}
