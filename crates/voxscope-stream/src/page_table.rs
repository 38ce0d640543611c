//! The page table: which bricks the GPU holds, as an open-addressing hash table the shader
//! probes (`stream.wgsl`, `table_lookup`), kept here on the CPU and copied to the GPU entry by
//! entry as it changes.
//!
//! A flat table per level would need an entry for every brick of every level: 2 M at 4096³
//! (fine), 134 M at 16384³ (not). The hash holds only what is known: bricks in the atlas, and
//! bricks known to need no atlas slot (uniform ones, drawn from their value; invisible ones
//! under the current transfer function, skipped without a request). A lookup is a hash and,
//! at the load factor kept here (≤ ¼), one or two 16-byte reads.
//!
//! Linear probing, no tombstones: removal shifts the entries after the removed one back
//! towards their home, so a key is always found before the first empty entry, and never more
//! than [`MAX_PROBES`] entries from home (an insert that would go further fails instead).

use super::pyramid::EMPTY_KEY;

/// The most entries a lookup reads. Keep in sync with `MAX_PROBES` in `stream.wgsl`.
pub const MAX_PROBES: u32 = 32;

/// Set in [`TableEntry::cell`] when the brick is in the atlas (at the cell in the low 30 bits).
/// Keep in sync with `ENTRY_RESIDENT` in `stream.wgsl`.
pub const ENTRY_RESIDENT: u32 = 1 << 31;

/// Set in [`TableEntry::cell`] when the brick could not be read: rays draw its region from a
/// coarser level and still ask for it (so that the streamer knows the view needs it, counts it
/// unreadable and loads the coarser brick instead). Keep in sync with `ENTRY_FAILED` in
/// `stream.wgsl`.
pub const ENTRY_FAILED: u32 = 1 << 30;

/// Set in [`TableEntry::slot`] when some value level in the brick's range is visible under the
/// current transfer function (DVR skips the brick otherwise, without reading anything more).
/// Keep in sync with `ENTRY_VISIBLE` in `stream.wgsl`.
pub const ENTRY_VISIBLE: u32 = 1 << 31;

/// One entry of the table on the GPU. Keep in sync with the `vec4<u32>` entries of
/// `stream.wgsl` (`TABLE_*` components).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TableEntry {
    /// The brick's key ([`super::PyramidShape::key`]), or [`EMPTY_KEY`].
    pub key: u32,
    /// The atlas cell (ten bits per axis, x lowest) with [`ENTRY_RESIDENT`], or 0 when the
    /// brick is not in the atlas; [`ENTRY_FAILED`] for a brick that could not be read.
    pub cell: u32,
    /// The brick's value range, minimum in the low 16 bits.
    pub range: u32,
    /// The atlas slot (for the usage marks the LRU reads), when resident; with
    /// [`ENTRY_VISIBLE`].
    pub slot: u32,
}

const _: () = assert!(std::mem::size_of::<TableEntry>() == 16);

impl TableEntry {
    /// The entry of no brick.
    pub const EMPTY: Self = Self {
        key: EMPTY_KEY,
        cell: 0,
        range: 0,
        slot: 0,
    };

    /// Whether the brick is in the atlas.
    pub fn is_resident(&self) -> bool {
        self.cell & ENTRY_RESIDENT != 0
    }
}

/// Where `key`'s probe sequence starts (before masking). Keep in sync with `table_hash` in
/// `stream.wgsl`.
pub fn table_hash(key: u32) -> u32 {
    let h = key.wrapping_mul(0x9E37_79B1);
    h ^ (h >> 16)
}

/// An insert found no empty entry within [`MAX_PROBES`] of the key's home.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableFull;

/// The CPU's copy of the GPU's page table, and which entries changed since the last upload.
pub struct PageTable {
    entries: Vec<TableEntry>,
    /// Each entry's key again, densely: a lookup probes these (a quarter of the bytes of the
    /// entries, so a frame's thousands of lookups stay in the CPU's caches).
    keys: Vec<u32>,
    mask: u32,
    len: usize,
    /// Indices changed since [`Self::take_dirty`], each once (`is_dirty` marks them).
    dirty: Vec<u32>,
    is_dirty: Vec<bool>,
}

impl PageTable {
    /// A table of at least `capacity` entries (rounded up to a power of two), all empty and all
    /// dirty (the GPU's copy starts from them).
    pub fn new(capacity: usize) -> Self {
        let size = capacity.next_power_of_two().max(MAX_PROBES as usize);
        Self {
            entries: vec![TableEntry::EMPTY; size],
            keys: vec![EMPTY_KEY; size],
            mask: size as u32 - 1,
            len: 0,
            dirty: (0..size as u32).collect(),
            is_dirty: vec![true; size],
        }
    }

    /// Entries, empty ones included (a power of two).
    pub fn capacity(&self) -> usize {
        self.entries.len()
    }

    /// `capacity() − 1`: what the shader masks hashes with.
    pub fn mask(&self) -> u32 {
        self.mask
    }

    /// Bricks in the table.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the table holds no brick.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn index_of(&self, key: u32) -> Option<usize> {
        let home = table_hash(key);
        for probe in 0..MAX_PROBES {
            let index = (home.wrapping_add(probe) & self.mask) as usize;
            match self.keys[index] {
                k if k == key => return Some(index),
                EMPTY_KEY => return None,
                _ => {}
            }
        }
        None
    }

    /// The entry of `key`, if the table has it.
    pub fn get(&self, key: u32) -> Option<TableEntry> {
        self.index_of(key).map(|index| self.entries[index])
    }

    /// Puts `entry` in (replacing the entry of the same key, if any).
    pub fn insert(&mut self, entry: TableEntry) -> Result<(), TableFull> {
        debug_assert_ne!(entry.key, EMPTY_KEY);
        let home = table_hash(entry.key);
        for probe in 0..MAX_PROBES {
            let index = (home.wrapping_add(probe) & self.mask) as usize;
            let here = self.keys[index];
            if here == entry.key || here == EMPTY_KEY {
                if here == EMPTY_KEY {
                    self.len += 1;
                }
                self.entries[index] = entry;
                self.keys[index] = entry.key;
                self.mark(index);
                return Ok(());
            }
        }
        Err(TableFull)
    }

    /// Takes `key` out, shifting the entries after it back towards their homes.
    pub fn remove(&mut self, key: u32) -> Option<TableEntry> {
        let mut hole = self.index_of(key)?;
        let removed = self.entries[hole];
        let mut next = hole;
        loop {
            next = (next + 1) & self.mask as usize;
            let entry = self.entries[next];
            if entry.key == EMPTY_KEY {
                break;
            }
            let home = table_hash(entry.key) as usize & self.mask as usize;
            // The entry may move into the hole unless its home lies after the hole, up to it
            // (cyclically): then the hole is before its home and it would never be found.
            let from_home = next.wrapping_sub(home) & self.mask as usize;
            let from_hole = next.wrapping_sub(hole) & self.mask as usize;
            if from_home >= from_hole {
                self.entries[hole] = entry;
                self.keys[hole] = entry.key;
                self.mark(hole);
                hole = next;
            }
        }
        self.entries[hole] = TableEntry::EMPTY;
        self.keys[hole] = EMPTY_KEY;
        self.mark(hole);
        self.len -= 1;
        Some(removed)
    }

    fn mark(&mut self, index: usize) {
        if !self.is_dirty[index] {
            self.is_dirty[index] = true;
            self.dirty.push(index as u32);
        }
    }

    /// The entries changed since the last call, as runs of consecutive entries: (first index,
    /// the entries), in index order. What to copy to the GPU.
    pub fn take_dirty(&mut self) -> Vec<(usize, &[TableEntry])> {
        let mut indices = std::mem::take(&mut self.dirty);
        indices.sort_unstable();
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for index in indices {
            let index = index as usize;
            self.is_dirty[index] = false;
            match runs.last_mut() {
                // Gaps of a few entries are cheaper to copy than to split a write at.
                Some((_, end)) if index <= *end + 4 => *end = index + 1,
                _ => runs.push((index, index + 1)),
            }
        }
        runs.into_iter()
            .map(|(start, end)| (start, &self.entries[start..end]))
            .collect()
    }

    /// Replaces each brick's entry by what `change` makes of it (`None`: unchanged); changed
    /// entries become dirty.
    pub fn update_each(&mut self, mut change: impl FnMut(&TableEntry) -> Option<TableEntry>) {
        for index in 0..self.entries.len() {
            if self.entries[index].key == EMPTY_KEY {
                continue;
            }
            if let Some(changed) = change(&self.entries[index]) {
                debug_assert_eq!(changed.key, self.entries[index].key);
                self.entries[index] = changed;
                self.mark(index);
            }
        }
    }

    /// Every entry (for tests and the first upload).
    pub fn entries(&self) -> &[TableEntry] {
        &self.entries
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(key: u32) -> TableEntry {
        TableEntry {
            key,
            cell: ENTRY_RESIDENT | key & 0xff,
            range: key,
            slot: key,
        }
    }

    /// Keys whose homes collide in a table of `size`: the same home, then the next one.
    fn colliding(size: u32, count: usize) -> Vec<u32> {
        let target = table_hash(0) & (size - 1);
        (0..)
            .filter(|&k| table_hash(k) & (size - 1) == target)
            .take(count)
            .collect()
    }

    #[test]
    fn inserted_keys_are_found_and_others_are_not() {
        let mut table = PageTable::new(1024);
        assert_eq!(table.capacity(), 1024);
        for key in (0..200).map(|i| i * 7919) {
            table.insert(entry(key)).expect("room");
        }
        assert_eq!(table.len(), 200);
        for key in (0..200).map(|i| i * 7919) {
            assert_eq!(table.get(key), Some(entry(key)));
        }
        assert_eq!(table.get(5), None);
        // Replacing keeps the count.
        let mut changed = entry(7919);
        changed.cell = 0;
        table.insert(changed).expect("room");
        assert_eq!(table.len(), 200);
        assert_eq!(table.get(7919), Some(changed));
    }

    #[test]
    fn removal_shifts_a_collision_chain_back_so_every_key_stays_findable() {
        let mut table = PageTable::new(64);
        let keys = colliding(64, 6);
        for &key in &keys {
            table.insert(entry(key)).expect("room");
        }
        // Remove from the middle of the chain, then the head.
        assert_eq!(table.remove(keys[2]), Some(entry(keys[2])));
        assert_eq!(table.remove(keys[0]), Some(entry(keys[0])));
        assert_eq!(table.remove(keys[0]), None);
        for &key in &[keys[1], keys[3], keys[4], keys[5]] {
            assert_eq!(table.get(key), Some(entry(key)), "key {key} after removals");
        }
        // No holes were left inside the chain: the four entries sit at the home and after.
        let home = (table_hash(keys[1]) & 63) as usize;
        let occupied: Vec<bool> = (0..6)
            .map(|i| table.entries()[(home + i) & 63].key != EMPTY_KEY)
            .collect();
        assert_eq!(occupied, [true, true, true, true, false, false]);
        assert_eq!(table.len(), 4);
        // The keys a lookup probes moved with their entries.
        let keys_of_entries: Vec<u32> = table.entries().iter().map(|e| e.key).collect();
        assert_eq!(table.keys, keys_of_entries);
    }

    #[test]
    fn removal_keeps_entries_whose_home_is_after_the_hole() {
        // A table of 64: key a at home h, key b at home h + 1 (placed at h + 1). Removing a
        // must not move b to h (it would still be found from h + 1 only by luck of probing).
        let mut table = PageTable::new(64);
        let a = 0u32;
        let home_a = table_hash(a) & 63;
        let b = (1..)
            .find(|&k| table_hash(k) & 63 == (home_a + 1) & 63)
            .expect("some key");
        table.insert(entry(a)).expect("room");
        table.insert(entry(b)).expect("room");
        table.remove(a);
        assert_eq!(table.get(b), Some(entry(b)));
        assert_eq!(table.entries()[((home_a + 1) & 63) as usize].key, b);
    }

    #[test]
    fn an_insert_beyond_the_probe_limit_fails() {
        let mut table = PageTable::new(64);
        let keys = colliding(64, MAX_PROBES as usize + 1);
        for &key in &keys[..MAX_PROBES as usize] {
            table.insert(entry(key)).expect("within the probe limit");
        }
        assert_eq!(
            table.insert(entry(keys[MAX_PROBES as usize])),
            Err(TableFull)
        );
    }

    #[test]
    fn dirty_entries_come_out_once_in_runs() {
        let mut table = PageTable::new(64);
        assert_eq!(
            table
                .take_dirty()
                .iter()
                .map(|(_, e)| e.len())
                .sum::<usize>(),
            64
        );
        assert!(table.take_dirty().is_empty());
        table.insert(entry(3)).expect("room");
        table.insert(entry(3)).expect("room");
        let runs = table.take_dirty();
        assert_eq!(runs.len(), 1);
        assert_eq!(runs[0].1, &[entry(3)]);
    }
}
