//! A store that remembers what was written through it: each object's key, size and CRC-32C,
//! which a part of a conversion lists in its marker (what it owns, and a check that the bytes
//! on disk are the ones it wrote).

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, PoisonError};

use zarrs::filesystem::FilesystemStore;
use zarrs::storage::byte_range::ByteRangeIterator;
use zarrs::storage::{
    Bytes, MaybeBytesIterator, OffsetBytesIterator, ReadableStorageTraits, StorageError, StoreKey,
    StorePrefix, WritableStorageTraits,
};

/// An object written: its key in the store, its size and its CRC-32C.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Written {
    pub bytes: u64,
    pub crc32c: u32,
}

/// What was written, by key; `None` for an object written in parts (its checksum is taken
/// from the file once writing is over).
type Log = BTreeMap<String, Option<Written>>;

/// A [`FilesystemStore`] that records every object set through it.
#[derive(Debug)]
pub(super) struct Recorded {
    inner: Arc<FilesystemStore>,
    log: Mutex<Log>,
}

impl Recorded {
    pub(super) fn new(inner: Arc<FilesystemStore>) -> Self {
        Self {
            inner,
            log: Mutex::new(Log::new()),
        }
    }

    fn log(&self) -> std::sync::MutexGuard<'_, Log> {
        self.log.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The objects written so far (an object written in parts read back for its checksum).
    pub(super) fn written(&self) -> Result<BTreeMap<String, Written>, StorageError> {
        let log = self.log().clone();
        let mut out = BTreeMap::new();
        for (key, written) in log {
            let written = match written {
                Some(written) => written,
                None => {
                    let Some(bytes) = self.inner.get(&StoreKey::new(key.clone())?)? else {
                        continue;
                    };
                    Written {
                        bytes: bytes.len() as u64,
                        crc32c: crc32c::crc32c(&bytes),
                    }
                }
            };
            out.insert(key, written);
        }
        Ok(out)
    }
}

impl ReadableStorageTraits for Recorded {
    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        self.inner.get_partial_many(key, byte_ranges)
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        self.inner.size_key(key)
    }

    fn supports_get_partial(&self) -> bool {
        self.inner.supports_get_partial()
    }
}

impl WritableStorageTraits for Recorded {
    fn set(&self, key: &StoreKey, value: Bytes) -> Result<(), StorageError> {
        let written = Written {
            bytes: value.len() as u64,
            crc32c: crc32c::crc32c(&value),
        };
        self.inner.set(key, value)?;
        self.log().insert(key.as_str().to_owned(), Some(written));
        Ok(())
    }

    fn set_partial_many(
        &self,
        key: &StoreKey,
        offset_values: OffsetBytesIterator,
    ) -> Result<(), StorageError> {
        self.inner.set_partial_many(key, offset_values)?;
        self.log().insert(key.as_str().to_owned(), None);
        Ok(())
    }

    fn erase(&self, key: &StoreKey) -> Result<(), StorageError> {
        self.inner.erase(key)?;
        self.log().remove(key.as_str());
        Ok(())
    }

    fn erase_prefix(&self, prefix: &StorePrefix) -> Result<(), StorageError> {
        self.inner.erase_prefix(prefix)?;
        self.log()
            .retain(|key, _| !key.starts_with(prefix.as_str()));
        Ok(())
    }

    fn supports_set_partial(&self) -> bool {
        self.inner.supports_set_partial()
    }
}
