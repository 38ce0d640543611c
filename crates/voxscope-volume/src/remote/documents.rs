//! Metadata documents fetched together while a store is opened: a pyramid's hierarchy names
//! its documents one level at a time (the root's, then every level's), and each asked for
//! alone (its size, then its bytes) would be a round trip after another. What a batch learns
//! about each document (its bytes, that it is missing, that it is too large, or why it could
//! not be read) answers the reader's `size_key` and `get` without asking again.

use zarrs::storage::{StorageError, StoreKey};

use super::cache::Piece;
use super::{RemoteStore, block_on};

/// What a document batch learned about an object, other than its bytes (those go to the
/// fetch cache).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Known {
    /// An object larger than the batch's bound, of this many bytes: never read.
    TooLarge(u64),
    /// The batch could not read it (after its retries): the message `get` and `size_key`
    /// answer with while the store is being opened.
    Failed(String),
}

impl RemoteStore {
    /// Fetches the documents `keys` all at once (up to the request limit), each bounded by
    /// `max_bytes`: what is present goes to the fetch cache; what is missing, larger than
    /// `max_bytes`, or failed is remembered, so that the reader's size checks and reads of
    /// these keys cost no further request. Failures are kept only until [`Self::mark_opened`].
    pub fn prefetch_documents(&self, keys: &[StoreKey], max_bytes: u64) {
        let inner = &self.inner;
        let wanted: Vec<&StoreKey> = {
            let (Ok(cache), Ok(known)) = (inner.cache.lock(), self.inner.known.lock()) else {
                return;
            };
            keys.iter()
                .filter(|key| {
                    cache.get(key.as_str(), Piece::Whole).is_none()
                        && !cache.is_missing(key.as_str())
                        && !known.contains_key(key.as_str())
                })
                .collect()
        };
        if wanted.is_empty() {
            return;
        }
        let reads = wanted.iter().map(|&key| {
            let read = inner
                .clone()
                .read(key.as_str().to_owned(), Piece::Whole, Some(max_bytes));
            async move { (key, read.await) }
        });
        let Ok(answers) = block_on(async { Ok(futures::future::join_all(reads).await) }) else {
            return;
        };
        let Ok(mut known) = inner.known.lock() else {
            return;
        };
        for (key, answer) in answers {
            let learned = match answer {
                // The bytes are in the fetch cache, the missing ones in its missing set.
                Ok(_) => continue,
                Err(failure) => match failure.too_large {
                    Some(size) => Known::TooLarge(size),
                    None => Known::Failed(inner.storage_error(failure).to_string()),
                },
            };
            known.insert(key.as_str().to_owned(), learned);
        }
    }

    /// What a document batch learned about `key`, if it learned anything but its bytes.
    pub(super) fn known(&self, key: &StoreKey) -> Option<Known> {
        self.inner.known.lock().ok()?.get(key.as_str()).cloned()
    }

    /// Forgets the batches' failures: once the store is open, a read asks again.
    pub(super) fn forget_failures(&self) {
        if let Ok(mut known) = self.inner.known.lock() {
            known.retain(|_, learned| !matches!(learned, Known::Failed(_)));
        }
    }

    /// `key`'s size as a batch learned it: `Some(answer)` when it learned one.
    pub(super) fn known_size(&self, key: &StoreKey) -> Option<Result<Option<u64>, StorageError>> {
        if let Ok(cache) = self.inner.cache.lock() {
            if cache.is_missing(key.as_str()) {
                return Some(Ok(None));
            }
            if let Some(bytes) = cache.get(key.as_str(), Piece::Whole) {
                return Some(Ok(Some(bytes.len() as u64)));
            }
        }
        match self.known(key)? {
            Known::TooLarge(size) => Some(Ok(Some(size))),
            Known::Failed(message) => Some(Err(StorageError::Other(message))),
        }
    }
}
