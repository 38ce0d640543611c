//! Metadata documents fetched together while a store is opened: a pyramid's hierarchy names
//! its documents one level at a time (the root's, then every level's), and each asked for
//! alone (its size, then its bytes) would be a round trip after another. What a batch learns
//! about each document (its bytes, that it is missing, that it is too large, or why it could
//! not be read) answers the reader's `size_key` and `get` without asking again.

use zarrs::storage::{StorageError, StoreKey};

use std::sync::atomic::Ordering;

use super::cache::Piece;
use super::fault::Persistence;
use super::{Answer, Fetched, RemoteStore, block_on};

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
    /// these keys cost no further request. Failures are kept only until [`Self::mark_opened`]
    /// (after it, a batch's failures are remembered as a read's are).
    /// A denied one (403) is taken for missing where another document of its node is there:
    /// a server that lets nobody list the store (an S3 bucket without `s3:ListBucket`)
    /// answers so for what does not exist, here the other Zarr version's documents.
    pub fn prefetch_documents(&self, keys: &[StoreKey], max_bytes: u64) {
        self.prefetch_guessing(keys, &[], max_bytes);
    }

    /// [`Self::prefetch_documents`] of `keys`, and in the same round trip the documents
    /// `guesses` that may not exist (the levels' of a store not yet read: `ome_zarr`'s
    /// `first_documents`): each asked for once, its bytes or its absence kept, but its
    /// failure forgotten (a server may deny what it does not have): a read asks again.
    pub fn prefetch_guessing(&self, keys: &[StoreKey], guesses: &[StoreKey], max_bytes: u64) {
        let inner = &self.inner;
        let unknown = |keys: &'_ [StoreKey]| -> Vec<StoreKey> {
            let (Ok(cache), Ok(known)) = (inner.cache.lock(), self.inner.known.lock()) else {
                return Vec::new();
            };
            keys.iter()
                .filter(|key| {
                    cache.get(key.as_str(), Piece::Whole).is_none()
                        && !cache.is_missing(key.as_str())
                        && !known.contains_key(key.as_str())
                        && inner.remembered.get(key.as_str()).is_none()
                })
                .cloned()
                .collect()
        };
        let wanted = unknown(keys);
        let guessed: Vec<StoreKey> = unknown(guesses)
            .into_iter()
            .filter(|key| !wanted.contains(key))
            .collect();
        if wanted.is_empty() && guessed.is_empty() {
            return;
        }
        let fetch = |key: &StoreKey, fetched: Fetched| {
            inner.flight(key.as_str(), Piece::Whole, Some(max_bytes), fetched)
        };
        let documents = wanted.iter().map(|key| fetch(key, Fetched::Document));
        let guesses = guessed.iter().map(|key| fetch(key, Fetched::Guess));
        let Ok((documents, guesses)) = block_on(async {
            Ok(futures::future::join(
                futures::future::join_all(documents),
                futures::future::join_all(guesses),
            )
            .await)
        }) else {
            return;
        };
        // A server that lets nobody list the store (an S3 bucket without `s3:ListBucket`)
        // answers 403 for what does not exist: a denied document is taken for missing where
        // another document of its node is there (found now, or fetched before: the other
        // Zarr version's names, a guessed level's); one whose node shows nothing stays denied
        // (a well or a level behind a deny policy says so).
        let found: Vec<&str> = wanted
            .iter()
            .zip(&documents)
            .chain(guessed.iter().zip(&guesses))
            .filter(|(_, answer)| matches!(answer, Ok(Answer::Body { .. })))
            .map(|(key, _)| key.as_str())
            .collect();
        let node_shows = |key: &str| {
            let node = node_of(key);
            found.iter().any(|other| node_of(other) == node)
                || inner.cache.lock().is_ok_and(|cache| {
                    NODE_DOCUMENTS.iter().any(|name| {
                        let other = format!("{node}{name}");
                        other != key && cache.get(&other, Piece::Whole).is_some()
                    })
                })
        };
        let mut missing = Vec::new();
        let mut failed = Vec::new();
        let answers = wanted.iter().zip(documents).map(|(key, a)| (key, a, true));
        let guessed = guessed.iter().zip(guesses).map(|(key, a)| (key, a, false));
        for (key, answer, asked) in answers.chain(guessed) {
            // The bytes are in the fetch cache, the missing ones in its missing set.
            let Err(failure) = answer else {
                continue;
            };
            if failure.is_denied() && node_shows(key.as_str()) {
                missing.push(key);
            } else if asked {
                failed.push((key, failure));
            }
            // A guess that failed otherwise: its read asks again.
        }
        if let Ok(mut cache) = inner.cache.lock() {
            for key in missing {
                inner.remembered.forget(key.as_str());
                cache.insert_missing(key.as_str());
            }
        }
        let Ok(mut known) = inner.known.lock() else {
            return;
        };
        // Once the store is open (a batch of its labels' documents), a failure is answered as
        // a read's is, for as long as it is remembered, not for the store's life.
        let opened = inner.opened.load(Ordering::Relaxed);
        for (key, failure) in failed {
            // As a read's failure: counted, remembered, and answered while the store opens.
            inner.record_failure(key.as_str(), &failure);
            if failure.persistence != Persistence::Silent {
                inner.health.operation_ended(true);
            }
            let learned = match failure.too_large {
                Some(size) => Known::TooLarge(size),
                None if opened => continue,
                None => Known::Failed(inner.storage_error(failure).to_string()),
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

/// The names of the documents that tell what sits at a node of a Zarr hierarchy (v3's, then
/// v2's group, attributes and array documents).
pub(crate) const NODE_DOCUMENTS: [&str; 4] = ["zarr.json", ".zgroup", ".zattrs", ".zarray"];

/// The node a document `key` belongs to, with its trailing `/` (`""` for the root's).
fn node_of(key: &str) -> &str {
    key.rfind('/').map_or("", |slash| &key[..=slash])
}
