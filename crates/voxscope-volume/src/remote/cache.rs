//! Fetched bytes kept in RAM by object and piece ([`super::FETCH_CACHE_BYTES`]).

use std::collections::{HashMap, HashSet, VecDeque};

use object_store::GetRange;
use zarrs::storage::Bytes;

use super::FETCH_CACHE_BYTES;

/// Which bytes of an object a cached piece is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Piece {
    Whole,
    Range(u64, u64),
    From(u64),
    Suffix(u64),
}

impl Piece {
    pub(super) fn of(range: Option<&GetRange>) -> Self {
        match range {
            // zarrs reads a whole chunk as the range from its start: the same bytes as a
            // whole object's, which a prefetch asked for.
            None | Some(GetRange::Offset(0)) => Self::Whole,
            Some(GetRange::Bounded(r)) => Self::Range(r.start, r.end),
            Some(GetRange::Offset(o)) => Self::From(*o),
            Some(GetRange::Suffix(n)) => Self::Suffix(*n),
        }
    }
}

/// Objects found missing that a [`FetchCache`] remembers, at most (a sparse store's skipped
/// chunks: a brick's reads and a prefetch's would each ask again).
const MAX_MISSING: usize = 1 << 20;

/// Fetched bytes by object and piece, the oldest dropped first beyond [`FETCH_CACHE_BYTES`];
/// and objects found missing.
#[derive(Default)]
pub(super) struct FetchCache {
    pieces: HashMap<(String, Piece), Bytes>,
    order: VecDeque<(String, Piece)>,
    bytes: u64,
    missing: HashSet<String>,
}

impl FetchCache {
    pub(super) fn get(&self, key: &str, piece: Piece) -> Option<Bytes> {
        self.pieces.get(&(key.to_owned(), piece)).cloned()
    }

    /// Whether the object `key` was found missing.
    pub(super) fn is_missing(&self, key: &str) -> bool {
        self.missing.contains(key)
    }

    /// Remembers that there is no object `key` (up to [`MAX_MISSING`] of them).
    pub(super) fn insert_missing(&mut self, key: &str) {
        if self.missing.len() < MAX_MISSING {
            self.missing.insert(key.to_owned());
        }
    }

    pub(super) fn insert(&mut self, key: &str, piece: Piece, bytes: &Bytes) {
        let size = bytes.len() as u64;
        if size > FETCH_CACHE_BYTES / 4 {
            return;
        }
        let entry = (key.to_owned(), piece);
        if self.pieces.insert(entry.clone(), bytes.clone()).is_some() {
            return;
        }
        self.order.push_back(entry);
        self.bytes += size;
        while self.bytes > FETCH_CACHE_BYTES {
            let Some(oldest) = self.order.pop_front() else {
                break;
            };
            if let Some(dropped) = self.pieces.remove(&oldest) {
                self.bytes -= dropped.len() as u64;
            }
        }
    }
}
