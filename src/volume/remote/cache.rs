//! Fetched bytes kept in RAM by object and piece ([`super::FETCH_CACHE_BYTES`]).

use std::collections::{HashMap, VecDeque};

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
            None => Self::Whole,
            Some(GetRange::Bounded(r)) => Self::Range(r.start, r.end),
            Some(GetRange::Offset(o)) => Self::From(*o),
            Some(GetRange::Suffix(n)) => Self::Suffix(*n),
        }
    }
}

/// Fetched bytes by object and piece, the oldest dropped first beyond [`FETCH_CACHE_BYTES`].
#[derive(Default)]
pub(super) struct FetchCache {
    pieces: HashMap<(String, Piece), Bytes>,
    order: VecDeque<(String, Piece)>,
    bytes: u64,
}

impl FetchCache {
    pub(super) fn get(&self, key: &str, piece: Piece) -> Option<Bytes> {
        self.pieces.get(&(key.to_owned(), piece)).cloned()
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
