//! Bytes a batch fetch got for the reads that follow it ([`super::RemoteStore::prefetch`]),
//! held for them while its [`HeldFetches`] lives, whatever the fetch cache keeps: a cache
//! smaller than the batch (a small `--ram-cache`), or an object over the quarter of the cache
//! it admits, would otherwise drop bytes before their read, which then fetched them again.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use zarrs::storage::Bytes;

use super::cache::Piece;
use super::fault::Failure;

/// An object's piece, as the fetch cache names it too.
type PieceOf = (String, Piece);

/// The pieces held now, each with how many [`HeldFetches`] hold it.
#[derive(Default)]
pub(super) struct HeldPieces {
    pieces: HashMap<PieceOf, (Bytes, usize)>,
}

impl HeldPieces {
    /// `piece` of `key`: held as such, or cut from the whole object where that is held.
    pub(super) fn piece(&self, key: &str, piece: Piece) -> Option<Result<Bytes, Failure>> {
        let held = |piece: Piece| {
            self.pieces
                .get(&(key.to_owned(), piece))
                .map(|(bytes, _)| bytes)
        };
        if let Some(bytes) = held(piece) {
            return Some(Ok(bytes.clone()));
        }
        held(Piece::Whole).map(|whole| piece.cut(whole))
    }

    /// Bytes held now, but for the pieces `kept` says are kept elsewhere (the fetch cache
    /// shares their bytes).
    pub(super) fn bytes_besides(&self, kept: impl Fn(&str, Piece) -> bool) -> u64 {
        self.pieces
            .iter()
            .filter(|((key, piece), _)| !kept(key, *piece))
            .map(|(_, (bytes, _))| bytes.len() as u64)
            .sum()
    }

    fn hold(&mut self, key: &str, piece: Piece, bytes: &Bytes) {
        self.pieces
            .entry((key.to_owned(), piece))
            .or_insert_with(|| (bytes.clone(), 0))
            .1 += 1;
    }

    fn release(&mut self, entry: &PieceOf) {
        if let Some((_, holders)) = self.pieces.get_mut(entry) {
            *holders -= 1;
            if *holders == 0 {
                self.pieces.remove(entry);
            }
        }
    }
}

/// What one batch fetch holds for the reads after it; dropped, it lets go of it (the bytes
/// stay where the fetch cache kept them too).
#[must_use = "the fetched bytes are held only while this lives"]
#[derive(Default)]
pub struct HeldFetches {
    entries: Vec<(Arc<Mutex<HeldPieces>>, PieceOf)>,
}

impl HeldFetches {
    /// Holds `piece` of `key` in `held` until this is dropped.
    pub(super) fn hold(
        &mut self,
        held: &Arc<Mutex<HeldPieces>>,
        key: &str,
        piece: Piece,
        bytes: &Bytes,
    ) {
        if let Ok(mut pieces) = held.lock() {
            self.hold_locked(&mut pieces, held, key, piece, bytes);
        }
    }

    /// [`Self::hold`] where the caller has locked `held` already (as `pieces`).
    pub(super) fn hold_locked(
        &mut self,
        pieces: &mut HeldPieces,
        held: &Arc<Mutex<HeldPieces>>,
        key: &str,
        piece: Piece,
        bytes: &Bytes,
    ) {
        pieces.hold(key, piece, bytes);
        self.entries
            .push((Arc::clone(held), (key.to_owned(), piece)));
    }

    /// What `other` holds, held by this from now on.
    pub fn join(&mut self, mut other: HeldFetches) {
        self.entries.append(&mut other.entries);
    }

    /// How many objects and pieces this holds.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether this holds nothing.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

impl Drop for HeldFetches {
    fn drop(&mut self) {
        for (held, entry) in self.entries.drain(..) {
            if let Ok(mut pieces) = held.lock() {
                pieces.release(&entry);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_piece_is_held_until_its_last_holder_is_dropped() {
        let held = Arc::new(Mutex::new(HeldPieces::default()));
        let bytes = Bytes::from(vec![1u8, 2, 3, 4]);
        let mut first = HeldFetches::default();
        first.hold(&held, "0/0", Piece::Whole, &bytes);
        let mut second = HeldFetches::default();
        second.hold(&held, "0/0", Piece::Whole, &bytes);
        let range =
            |held: &Arc<Mutex<HeldPieces>>| held.lock().unwrap().piece("0/0", Piece::Range(1, 3));
        assert_eq!(range(&held).unwrap().unwrap(), Bytes::from(vec![2u8, 3]));
        drop(first);
        assert!(range(&held).is_some(), "the second still holds it");
        let mut joined = HeldFetches::default();
        joined.join(second);
        assert_eq!(joined.len(), 1);
        drop(joined);
        assert!(range(&held).is_none());
        assert_eq!(held.lock().unwrap().bytes_besides(|_, _| false), 0);
    }
}
