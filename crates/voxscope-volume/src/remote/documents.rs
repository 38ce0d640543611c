//! Metadata documents fetched together while a store is opened: a pyramid's hierarchy names
//! its documents one level at a time (the root's, then every level's), and each asked for
//! alone (its size, then its bytes) would be a round trip after another. What a batch learns
//! about each document (its bytes, that it is missing, that it is too large, or why it could
//! not be read) answers the reader's `size_key` and `get` without asking again.

use std::sync::atomic::Ordering;

use object_store::GetOptions;
use zarrs::storage::{Bytes, StorageError, StoreKey};

use super::cache::Piece;
use super::{RemoteStore, generic, runtime};

/// What a document batch learned about an object, other than its bytes (those go to the
/// fetch cache).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Known {
    /// No such object.
    Missing,
    /// An object larger than the batch's bound, of this many bytes: never read.
    TooLarge(u64),
    /// The batch could not read it (after its retries): the message `get` and `size_key`
    /// answer with while the store is being opened.
    Failed(String),
}

/// One document's answer.
enum Document {
    Bytes(Bytes),
    Missing,
    TooLarge(u64),
}

impl RemoteStore {
    /// Fetches the documents `keys` all at once (up to the request limit), each bounded by
    /// `max_bytes`: what is present goes to the fetch cache; what is missing, larger than
    /// `max_bytes`, or failed is remembered, so that the reader's size checks and reads of
    /// these keys cost no further request. Failures are kept only until [`Self::mark_opened`].
    pub fn prefetch_documents(&self, keys: &[StoreKey], max_bytes: u64) {
        let wanted: Vec<&StoreKey> = {
            let (Ok(cache), Ok(known)) = (self.cache.lock(), self.known.lock()) else {
                return;
            };
            keys.iter()
                .filter(|key| {
                    cache.get(key.as_str(), Piece::Whole).is_none()
                        && !known.contains_key(key.as_str())
                })
                .collect()
        };
        if wanted.is_empty() {
            return;
        }
        let Ok(runtime) = runtime() else { return };
        let deadline = self.deadline();
        let fetches = wanted.iter().map(|&key| async move {
            let answer = tokio::time::timeout(deadline, self.fetch_document(key, max_bytes)).await;
            (key, answer)
        });
        let answers = runtime.block_on(futures::future::join_all(fetches));
        let (Ok(mut cache), Ok(mut known)) = (self.cache.lock(), self.known.lock()) else {
            return;
        };
        for (key, answer) in answers {
            let learned = match answer {
                Ok(Ok(Document::Bytes(bytes))) => {
                    cache.insert(key.as_str(), Piece::Whole, &bytes);
                    continue;
                }
                Ok(Ok(Document::Missing)) => Known::Missing,
                Ok(Ok(Document::TooLarge(size))) => Known::TooLarge(size),
                Ok(Err(error)) => {
                    self.counters.errors.fetch_add(1, Ordering::Relaxed);
                    Known::Failed(format!("{}: {}", self.key_url(key), self.describe(&error)))
                }
                Err(_) => {
                    self.counters.errors.fetch_add(1, Ordering::Relaxed);
                    Known::Failed(format!(
                        "{}: no answer within {} s",
                        self.key_url(key),
                        deadline.as_secs()
                    ))
                }
            };
            known.insert(key.as_str().to_owned(), learned);
        }
    }

    /// What a document batch learned about `key`, if it learned anything but its bytes.
    pub(super) fn known(&self, key: &StoreKey) -> Option<Known> {
        self.known.lock().ok()?.get(key.as_str()).cloned()
    }

    /// Forgets the batches' failures: once the store is open, a read asks again.
    pub(super) fn forget_failures(&self) {
        if let Ok(mut known) = self.known.lock() {
            known.retain(|_, learned| !matches!(learned, Known::Failed(_)));
        }
    }

    /// `key`'s size as a batch learned it: `Some(answer)` when it learned one.
    pub(super) fn known_size(&self, key: &StoreKey) -> Option<Result<Option<u64>, StorageError>> {
        if let Ok(cache) = self.cache.lock() {
            if cache.is_missing(key.as_str()) {
                return Some(Ok(None));
            }
            if let Some(bytes) = cache.get(key.as_str(), Piece::Whole) {
                return Some(Ok(Some(bytes.len() as u64)));
            }
        }
        match self.known(key)? {
            Known::Missing => Some(Ok(None)),
            Known::TooLarge(size) => Some(Ok(Some(size))),
            Known::Failed(message) => Some(Err(StorageError::Other(message))),
        }
    }

    /// One document: its bytes, unless it is missing or larger than `max_bytes` (then only
    /// its size is taken from the answer's length).
    async fn fetch_document(
        &self,
        key: &StoreKey,
        max_bytes: u64,
    ) -> Result<Document, object_store::Error> {
        let location = self.location(key);
        let _permit = self
            .limit
            .acquire()
            .await
            .map_err(|e| generic(e.to_string()))?;
        self.counters.in_flight.fetch_add(1, Ordering::Relaxed);
        let answer = async {
            let result = match self.store.get_opts(&location, GetOptions::default()).await {
                Ok(result) => result,
                Err(object_store::Error::NotFound { .. }) => return Ok(Document::Missing),
                Err(error) => return Err(error),
            };
            let length = result.range.end.saturating_sub(result.range.start);
            if length > max_bytes {
                return Ok(Document::TooLarge(length));
            }
            let bytes = result.bytes().await?;
            if bytes.len() as u64 != length {
                return Err(generic(format!(
                    "{} bytes arrived of the {length} announced",
                    bytes.len()
                )));
            }
            self.counters
                .bytes
                .fetch_add(bytes.len() as u64, Ordering::Relaxed);
            Ok(Document::Bytes(bytes))
        }
        .await;
        self.counters.in_flight.fetch_sub(1, Ordering::Relaxed);
        self.counters.requests.fetch_add(1, Ordering::Relaxed);
        answer
    }
}
