//! Fetched bytes kept in RAM by object and piece ([`super::FETCH_CACHE_BYTES`]); a piece is
//! also cut from the whole object where that is kept (a server that ignores `Range` sends it).

use std::collections::{HashMap, HashSet, VecDeque};
use std::time::{Duration, Instant};

use zarrs::storage::Bytes;
use zarrs::storage::byte_range::ByteRange;

use super::FETCH_CACHE_BYTES;
use super::fault::Failure;

/// Which bytes of an object are asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Piece {
    /// The whole object.
    Whole,
    /// Bytes `start..end`.
    Range(u64, u64),
    /// From an offset to the end.
    From(u64),
    /// The last bytes.
    Suffix(u64),
}

impl Piece {
    /// The piece zarrs's `range` asks for.
    pub(crate) fn of(range: ByteRange) -> Self {
        match range {
            // zarrs reads a whole chunk as the range from its start: the same bytes as a
            // whole object's, which a prefetch asked for.
            ByteRange::FromStart(0, None) => Self::Whole,
            ByteRange::FromStart(offset, Some(length)) => {
                Self::Range(offset, offset.saturating_add(length))
            }
            ByteRange::FromStart(offset, None) => Self::From(offset),
            ByteRange::Suffix(length) => Self::Suffix(length),
        }
    }

    /// The same piece counted from `offset` (a range inside a run fetched from `offset`).
    pub(crate) fn shifted_back(self, offset: u64) -> Self {
        match self {
            Self::Range(a, b) => Self::Range(a.saturating_sub(offset), b.saturating_sub(offset)),
            Self::From(a) => Self::From(a.saturating_sub(offset)),
            other => other,
        }
    }

    /// Whether it holds no byte (answered without a request).
    pub(crate) fn is_empty(self) -> bool {
        matches!(self, Self::Range(a, b) if a >= b) || self == Self::Suffix(0)
    }

    /// This piece of the whole object `whole`; an error if it lies beyond the object's end
    /// (a damaged shard index points there).
    pub(crate) fn cut(self, whole: &Bytes) -> Result<Bytes, Failure> {
        let len = whole.len() as u64;
        let (start, end) = match self {
            Self::Whole => (0, len),
            Self::Range(a, b) => (a, b),
            Self::From(a) => (a, len),
            // As HTTP answers a suffix longer than the object: all of it.
            Self::Suffix(n) => (len.saturating_sub(n), len),
        };
        if start > end || end > len {
            return Err(Failure::permanent(format!(
                "bytes {start}..{end} lie beyond the object's {len}"
            )));
        }
        Ok(whole.slice(start as usize..end as usize))
    }
}

/// Objects found missing that a [`FetchCache`] remembers, at most (a sparse store's skipped
/// chunks: a brick's reads and a prefetch's would each ask again).
const MAX_MISSING: usize = 1 << 20;

/// How long an object fetched ahead counts as waiting for its read: one the streamer stopped
/// wanting (a MIP ray saturated by brighter bricks, a view turned away) is never read, and
/// would hold back fetching ahead until the cache dropped it.
const UNREAD_FOR: Duration = Duration::from_secs(2);

/// Whole objects whose sizes decide what each object fetched ahead is expected to bring: the
/// largest of the latest this many (a store's chunks range from a few kilobytes of background
/// to hundreds of tissue, and the first read are often the small ones); until this many were
/// fetched, the most an object may have.
const SIZES_KNOWN: usize = 16;

/// Fetched bytes by object and piece, the oldest dropped first beyond its capacity
/// ([`FETCH_CACHE_BYTES`] unless the streamer's RAM budget sets less); and objects found
/// missing. It also knows what fetching ahead may add: whole objects fetched ahead of their
/// reads wait here to be read, and are fetched again if dropped first.
pub(super) struct FetchCache {
    pieces: HashMap<(String, Piece), Bytes>,
    order: VecDeque<(String, Piece)>,
    bytes: u64,
    capacity: u64,
    missing: HashSet<String>,
    /// Whole objects fetched ahead and not read since, with their bytes and when they came
    /// (also in that order, some read or dropped since), and their bytes in all.
    unread: HashMap<String, (u64, Instant)>,
    unread_order: VecDeque<(String, Instant)>,
    unread_bytes: u64,
    /// Sizes of the latest whole objects fetched since the store opened (chunks, mostly), at
    /// most [`SIZES_KNOWN`].
    sizes: VecDeque<u64>,
}

impl Default for FetchCache {
    fn default() -> Self {
        Self {
            pieces: HashMap::new(),
            order: VecDeque::new(),
            bytes: 0,
            capacity: FETCH_CACHE_BYTES,
            missing: HashSet::new(),
            unread: HashMap::new(),
            unread_order: VecDeque::new(),
            unread_bytes: 0,
            sizes: VecDeque::new(),
        }
    }
}

impl FetchCache {
    /// Keeps at most `capacity` bytes from now on, dropping the oldest pieces beyond it.
    pub(super) fn set_capacity(&mut self, capacity: u64) {
        self.capacity = capacity;
        self.shrink();
    }

    /// Bytes kept.
    pub(super) fn bytes(&self) -> u64 {
        self.bytes
    }

    fn shrink(&mut self) {
        while self.bytes > self.capacity {
            let Some(oldest) = self.order.pop_front() else {
                break;
            };
            self.drop_piece(&oldest);
        }
    }

    fn drop_piece(&mut self, entry: &(String, Piece)) {
        if let Some(dropped) = self.pieces.remove(entry) {
            self.bytes -= dropped.len() as u64;
            if entry.1 == Piece::Whole {
                self.mark_read(&entry.0);
            }
        }
    }

    /// Keeps the whole object `key` fetched ahead of its read: unread until
    /// [`Self::mark_read`], dropped, or [`UNREAD_FOR`] old. An object kept already (a read
    /// fetched it meanwhile) is not marked.
    pub(super) fn insert_ahead(&mut self, key: &str, bytes: &Bytes) {
        if self.insert(key, Piece::Whole, bytes) {
            let (size, now) = (bytes.len() as u64, Instant::now());
            self.unread.insert(key.to_owned(), (size, now));
            self.unread_order.push_back((key.to_owned(), now));
            self.unread_bytes += size;
        }
    }

    /// A read took the object `key`: what was fetched ahead of it is used.
    pub(super) fn mark_read(&mut self, key: &str) {
        if let Some((size, _)) = self.unread.remove(key) {
            self.unread_bytes -= size;
        }
    }

    /// Forgets the marks of objects fetched ahead before `now` − [`UNREAD_FOR`].
    fn expire_unread(&mut self, now: Instant) {
        while let Some((key, came)) = self.unread_order.front() {
            if now.saturating_duration_since(*came) < UNREAD_FOR {
                break;
            }
            // The mark of this arrival, unless it was read (and perhaps fetched again) since.
            if self.unread.get(key).is_some_and(|&(_, at)| at == *came) {
                let key = key.clone();
                self.mark_read(&key);
            }
            self.unread_order.pop_front();
        }
    }

    /// Counts a whole object of `bytes` fetched (what [`Self::ahead_room`] expects of the
    /// next).
    pub(super) fn note_object(&mut self, bytes: u64) {
        if self.sizes.len() == SIZES_KNOWN {
            self.sizes.pop_front();
        }
        self.sizes.push_back(bytes);
    }

    /// How many more whole objects may be fetched ahead with `in_flight` on their way: what
    /// was fetched ahead and is unread, and what is coming, stay within half the capacity
    /// (the rest for what the reads fetch themselves), so that what is fetched ahead is
    /// seldom dropped before its read. Each object coming is expected to be as large as the
    /// largest of the latest [`SIZES_KNOWN`] fetched, or, before that many were, as large as
    /// `bound` (the most one may have).
    pub(super) fn ahead_room(&mut self, in_flight: usize, bound: u64) -> usize {
        self.expire_unread(Instant::now());
        let each = match self.sizes.iter().max() {
            Some(&largest) if self.sizes.len() == SIZES_KNOWN => largest,
            _ => bound,
        }
        .max(1);
        let coming = self
            .unread_bytes
            .saturating_add((in_flight as u64).saturating_mul(each));
        ((self.capacity / 2).saturating_sub(coming) / each) as usize
    }

    pub(super) fn get(&self, key: &str, piece: Piece) -> Option<Bytes> {
        self.pieces.get(&(key.to_owned(), piece)).cloned()
    }

    /// `piece` of `key`: kept as such, or cut from the whole object where that is kept.
    pub(super) fn piece(&self, key: &str, piece: Piece) -> Option<Result<Bytes, Failure>> {
        if let Some(bytes) = self.get(key, piece) {
            return Some(Ok(bytes));
        }
        let whole = self.get(key, Piece::Whole)?;
        Some(piece.cut(&whole))
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

    /// Drops `piece` of `key` (a coalesced run, once its pieces are kept on their own).
    pub(super) fn remove(&mut self, key: &str, piece: Piece) {
        let entry = (key.to_owned(), piece);
        if self.pieces.contains_key(&entry) {
            self.drop_piece(&entry);
            self.order.retain(|kept| kept != &entry);
        }
    }

    /// Keeps `piece` of `key`; whether it was not kept before and is now (a piece over a
    /// quarter of the capacity is never kept; one kept already stays as it was).
    pub(super) fn insert(&mut self, key: &str, piece: Piece, bytes: &Bytes) -> bool {
        let size = bytes.len() as u64;
        let entry = (key.to_owned(), piece);
        if size > self.capacity / 4 || self.pieces.contains_key(&entry) {
            return false;
        }
        self.pieces.insert(entry.clone(), bytes.clone());
        self.order.push_back(entry.clone());
        self.bytes += size;
        self.shrink();
        self.pieces.contains_key(&entry)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bytes(n: usize) -> Bytes {
        Bytes::from(vec![7u8; n])
    }

    #[test]
    fn keeps_at_most_its_capacity_oldest_dropped_first() {
        let mut cache = FetchCache::default();
        cache.set_capacity(1000);
        for i in 0..10 {
            cache.insert(&format!("0/{i}"), Piece::Whole, &bytes(200));
        }
        assert!(cache.bytes() <= 1000, "{}", cache.bytes());
        assert!(cache.get("0/9", Piece::Whole).is_some(), "the newest stays");
        assert!(cache.get("0/0", Piece::Whole).is_none(), "the oldest went");
        // A piece over a quarter of the capacity is never kept.
        cache.insert("big", Piece::Whole, &bytes(251));
        assert!(cache.get("big", Piece::Whole).is_none());
        // A smaller capacity drops what no longer fits at once.
        cache.set_capacity(300);
        assert!(cache.bytes() <= 300, "{}", cache.bytes());
        assert!(cache.get("0/9", Piece::Whole).is_some());
    }

    #[test]
    fn what_is_fetched_ahead_and_unread_bounds_what_may_be_fetched_ahead() {
        let mut cache = FetchCache::default();
        cache.set_capacity(2000);
        // Too few objects' sizes known yet: each as large as it may be.
        assert_eq!(cache.ahead_room(0, 250), 4);
        assert_eq!(cache.ahead_room(3, 250), 1);
        assert_eq!(cache.ahead_room(0, 1 << 40), 0);
        for size in 1..SIZES_KNOWN as u64 {
            cache.note_object(1000 + size);
        }
        assert_eq!(cache.ahead_room(0, 250), 4);
        // The largest of the latest: 200 bytes an object once the larger ones are older.
        for _ in 0..SIZES_KNOWN {
            cache.note_object(50);
        }
        cache.note_object(200);
        // Half the capacity, 200 bytes an object: five, less those on their way.
        assert_eq!(cache.ahead_room(0, 1 << 40), 5);
        assert_eq!(cache.ahead_room(2, 1 << 40), 3);
        cache.insert_ahead("0/0", &bytes(200));
        cache.insert_ahead("0/1", &bytes(200));
        assert_eq!(cache.unread_bytes, 400);
        assert_eq!(cache.ahead_room(0, 1 << 40), 3);
        // Read: room again.
        cache.mark_read("0/0");
        cache.mark_read("0/0");
        assert_eq!(cache.unread_bytes, 200);
        assert_eq!(cache.ahead_room(0, 1 << 40), 4);
        // Dropped unread (the oldest first): no longer waiting to be read.
        for i in 2..12 {
            cache.insert(&format!("1/{i}"), Piece::Whole, &bytes(200));
        }
        assert!(cache.get("0/1", Piece::Whole).is_none());
        assert_eq!(cache.unread_bytes, 0);
        cache.mark_read("0/1");
        assert_eq!(cache.unread_bytes, 0);
        cache.insert_ahead("0/2", &bytes(200));
        cache.remove("0/2", Piece::Whole);
        assert_eq!(cache.unread_bytes, 0);
        // Too large to keep: never waiting.
        cache.insert_ahead("big", &bytes(600));
        assert_eq!(cache.unread_bytes, 0);
        // Kept already (a read fetched it meanwhile): not waiting either.
        cache.insert("0/3", Piece::Whole, &bytes(200));
        cache.insert_ahead("0/3", &bytes(200));
        assert_eq!(cache.unread_bytes, 0);
        // Never read (the streamer stopped wanting it): waiting no longer after a while.
        cache.insert_ahead("0/4", &bytes(200));
        cache.insert_ahead("0/5", &bytes(200));
        cache.mark_read("0/5");
        cache.insert_ahead("0/6", &bytes(100));
        assert_eq!(cache.unread_bytes, 300);
        cache.expire_unread(Instant::now());
        assert_eq!(cache.unread_bytes, 300);
        cache.expire_unread(Instant::now() + UNREAD_FOR);
        assert_eq!(cache.unread_bytes, 0);
        assert!(cache.unread.is_empty() && cache.unread_order.is_empty());
        assert!(cache.get("0/4", Piece::Whole).is_some(), "still kept");
    }
}
