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
//!
//! Where one level's grid is small, the table also keeps a flat copy of that level's entries,
//! brick by brick ([`PageTable::copy_level`]), and counts the bricks there that the shader's
//! level walk (`stream.wgsl`, `level_walk`) could not take ([`walkable`]). Where there are
//! none, and every ray wants that level, frames walk it as the bricks renderer walks its grid:
//! a brick's entry read at its index, with no hash, no probing and no per-segment work.

use super::pyramid::{EMPTY_KEY, KEY_LEVEL_SHIFT};

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

/// Whether the shader's level walk can take a brick with entry `entry` under maximum intensity
/// projection (`max_projection`) or not, whatever the ray has seen before it: known and
/// readable, and drawable (in the atlas, or uniform: one value) or unable to change any pixel
/// (DVR: no value of its range visible; MIP: a maximum of 0). Keep in sync with `walkable` in
/// `stream.wgsl` (at a running maximum of 0, where a MIP ray skips the fewest bricks).
pub fn walkable(entry: &TableEntry, max_projection: bool) -> bool {
    let failed = entry.cell & ENTRY_FAILED != 0;
    let uniform = (entry.range & 0xffff) == (entry.range >> 16);
    let drawable = entry.is_resident() || (!failed && uniform);
    let visible = if max_projection {
        entry.range >> 16 > 0
    } else {
        entry.slot & ENTRY_VISIBLE != 0
    };
    entry.key != EMPTY_KEY && !failed && (drawable || !visible)
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

/// One level's entries in the order of its bricks (x fastest: a key's low bits), then, where two
/// levels are copied, the next coarser level's; the bricks the table does not hold as
/// [`TableEntry::EMPTY`]; the cells changed since the last upload.
struct LevelCopy {
    level: u32,
    /// The cells of `level`; those after them are `level + 1`'s.
    split: usize,
    cells: Vec<TableEntry>,
    /// Changed cells, as one range (first, end).
    dirty: Option<(usize, usize)>,
    /// The cells not [`walkable`] under DVR (0) and under MIP (1).
    unwalkable: [usize; 2],
    /// The cells the table holds no entry for.
    unknown: usize,
}

impl LevelCopy {
    /// A copy of `bricks[0]` cells of `level` and `bricks[1]` of the next coarser one, none
    /// known yet.
    fn new(level: u32, bricks: [usize; 2]) -> Self {
        let cells = bricks[0] + bricks[1];
        Self {
            level,
            split: bricks[0],
            cells: vec![TableEntry::EMPTY; cells],
            dirty: None,
            unwalkable: [cells; 2],
            unknown: cells,
        }
    }

    /// How many levels it copies: 1, or 2 (`level` and the next coarser one).
    fn levels(&self) -> u32 {
        1 + u32::from(self.cells.len() > self.split)
    }

    /// The cell of brick `key`, where it is one of the copied levels'.
    fn index(&self, key: u32) -> Option<usize> {
        let brick = (key & ((1 << KEY_LEVEL_SHIFT) - 1)) as usize;
        let index = match key >> KEY_LEVEL_SHIFT {
            level if level == self.level => (brick < self.split).then_some(brick)?,
            level if level == self.level + 1 => self.split + brick,
            _ => return None,
        };
        (index < self.cells.len()).then_some(index)
    }

    /// The key of cell `index`.
    fn key(&self, index: usize) -> u32 {
        if index < self.split {
            self.level << KEY_LEVEL_SHIFT | index as u32
        } else {
            (self.level + 1) << KEY_LEVEL_SHIFT | (index - self.split) as u32
        }
    }

    fn set(&mut self, key: u32, entry: TableEntry) {
        let Some(index) = self.index(key) else {
            return;
        };
        let cell = &mut self.cells[index];
        if *cell != entry {
            for (count, mip) in self.unwalkable.iter_mut().zip([false, true]) {
                *count = *count + usize::from(!walkable(&entry, mip))
                    - usize::from(!walkable(cell, mip));
            }
            self.unknown = self.unknown + usize::from(entry.key == EMPTY_KEY)
                - usize::from(cell.key == EMPTY_KEY);
            *cell = entry;
            self.dirty = Some(match self.dirty {
                Some((first, end)) => (first.min(index), end.max(index + 1)),
                None => (index, index + 1),
            });
        }
    }
}

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
    /// The flat copy of one level, if one is kept.
    level_copy: Option<LevelCopy>,
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
            level_copy: None,
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
                if let Some(copy) = self.level_copy.as_mut() {
                    copy.set(entry.key, entry);
                }
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
        if let Some(copy) = self.level_copy.as_mut() {
            copy.set(key, TableEntry::EMPTY);
        }
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
                if let Some(copy) = self.level_copy.as_mut() {
                    copy.set(changed.key, changed);
                }
            }
        }
    }

    /// Every entry (for tests and the first upload).
    pub fn entries(&self) -> &[TableEntry] {
        &self.entries
    }

    /// Keeps a flat copy of level `level`'s entries, `bricks[0]` of them (the level's bricks),
    /// followed by the next coarser level's, `bricks[1]` (0: that level is not copied); or
    /// none. A new copy is made from the table (every cell dirty); the same levels again keep
    /// the copy as it is.
    pub fn copy_level(&mut self, level: Option<(u32, [usize; 2])>) {
        let Some((level, bricks)) = level else {
            self.level_copy = None;
            return;
        };
        if self.level_copy.as_ref().is_some_and(|copy| {
            copy.level == level && [copy.split, copy.cells.len() - copy.split] == bricks
        }) {
            return;
        }
        let mut copy = LevelCopy::new(level, bricks);
        for entry in self.entries.iter().filter(|e| e.key != EMPTY_KEY) {
            copy.set(entry.key, *entry);
        }
        let cells = copy.cells.len();
        copy.dirty = (cells > 0).then_some((0, cells));
        self.level_copy = Some(copy);
    }

    /// The finest level whose flat copy is kept, and how many levels are (1 or 2), if any.
    pub fn copied_level(&self) -> Option<(u32, u32)> {
        self.level_copy
            .as_ref()
            .map(|copy| (copy.level, copy.levels()))
    }

    /// How many bricks of the copied levels the level walk could not take ([`walkable`]) under
    /// MIP (`max_projection`) or DVR; `None` where no level is copied.
    pub fn level_unwalkable(&self, max_projection: bool) -> Option<usize> {
        let copy = self.level_copy.as_ref()?;
        Some(copy.unwalkable[usize::from(max_projection)])
    }

    /// The atlas slots of the copied levels' bricks in the atlas.
    pub fn level_slots(&self) -> impl Iterator<Item = u32> + '_ {
        self.level_copy.iter().flat_map(|copy| {
            copy.cells
                .iter()
                .filter(|cell| cell.is_resident())
                .map(|cell| cell.slot & !ENTRY_VISIBLE)
        })
    }

    /// How many bricks of the copied levels the table holds no entry for; `None` where no
    /// level is copied.
    pub fn level_unknown(&self) -> Option<usize> {
        self.level_copy.as_ref().map(|copy| copy.unknown)
    }

    /// The keys of the copied levels' bricks that the level walk could not take, brick order
    /// (the finer level's first).
    pub fn level_unwalkable_keys(&self, max_projection: bool) -> impl Iterator<Item = u32> + '_ {
        self.level_copy.iter().flat_map(move |copy| {
            copy.cells
                .iter()
                .enumerate()
                .filter(move |(_, cell)| !walkable(cell, max_projection))
                .map(move |(index, _)| copy.key(index))
        })
    }

    /// The copied levels' cells changed since the last call: (first cell, the cells), one
    /// range. What to copy to the GPU after [`Self::take_dirty`]'s runs.
    pub fn take_level_dirty(&mut self) -> Option<(usize, &[TableEntry])> {
        let copy = self.level_copy.as_mut()?;
        let (first, end) = copy.dirty.take()?;
        Some((first, &copy.cells[first..end]))
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

    /// A key of level `level`, brick `index`.
    fn level_key(level: u32, index: u32) -> u32 {
        level << KEY_LEVEL_SHIFT | index
    }

    #[test]
    fn a_level_copy_follows_inserts_removals_and_updates_of_its_level_only() {
        let mut table = PageTable::new(1024);
        table.insert(entry(level_key(2, 5))).expect("room");
        table.insert(entry(level_key(1, 5))).expect("room");
        table.copy_level(Some((2, [8, 0])));
        assert_eq!(table.copied_level(), Some((2, 1)));
        let (first, cells) = table.take_level_dirty().expect("all cells, once");
        assert_eq!((first, cells.len()), (0, 8));
        assert_eq!(cells[5], entry(level_key(2, 5)));
        assert!(
            cells
                .iter()
                .enumerate()
                .all(|(i, c)| i == 5 || *c == TableEntry::EMPTY)
        );
        assert!(table.take_level_dirty().is_none());

        // Another level's changes leave the copy as it is.
        table.insert(entry(level_key(1, 6))).expect("room");
        table.remove(level_key(1, 5));
        assert!(table.take_level_dirty().is_none());

        // The copied level's: an insert, a removal (of an entry a collision chain moves, too),
        // an update.
        let keys: Vec<u32> = (0..8).map(|i| level_key(2, i)).collect();
        table.insert(entry(keys[2])).expect("room");
        table.insert(entry(keys[7])).expect("room");
        table.remove(keys[5]);
        let (first, cells) = table.take_level_dirty().expect("changed");
        assert_eq!((first, cells.len()), (2, 6));
        assert_eq!(cells[0], entry(keys[2]));
        assert_eq!(cells[3], TableEntry::EMPTY);
        assert_eq!(cells[5], entry(keys[7]));
        table.update_each(|e| {
            (e.key == keys[7]).then_some(TableEntry {
                slot: e.slot | ENTRY_VISIBLE,
                ..*e
            })
        });
        let (first, cells) = table.take_level_dirty().expect("updated");
        assert_eq!(
            (first, cells[0].slot),
            (7, entry(keys[7]).slot | ENTRY_VISIBLE)
        );
        // Each cell equals the table's own entry for its key.
        table.copy_level(Some((2, [8, 0])));
        table.copy_level(None);
        table.copy_level(Some((2, [8, 0])));
        let cells = table.take_level_dirty().expect("made again").1.to_vec();
        for (index, cell) in cells.iter().enumerate() {
            let key = level_key(2, index as u32);
            assert_eq!(
                *cell,
                table.get(key).unwrap_or(TableEntry::EMPTY),
                "cell {index}"
            );
        }
    }

    #[test]
    fn a_level_copy_counts_the_bricks_the_level_walk_cannot_take() {
        let mut table = PageTable::new(1024);
        table.copy_level(Some((1, [6, 0])));
        assert_eq!(table.level_unwalkable(false), Some(6), "none known yet");
        assert_eq!(table.level_unknown(), Some(6));
        let key = |index| level_key(1, index);
        // In the atlas; uniform; visible under DVR, not in the atlas; its maximum 0, not in
        // the atlas; failed. The sixth stays unknown.
        table.insert(entry(key(0))).expect("room");
        let slotless = |index, range, slot| TableEntry {
            key: key(index),
            cell: 0,
            range,
            slot,
        };
        table.insert(slotless(1, 7 << 16 | 7, 0)).expect("room");
        table
            .insert(slotless(2, 9 << 16 | 3, ENTRY_VISIBLE))
            .expect("room");
        table.insert(slotless(3, 0, 0)).expect("room");
        table
            .insert(TableEntry {
                cell: ENTRY_FAILED,
                ..slotless(4, 9 << 16, ENTRY_VISIBLE)
            })
            .expect("room");
        assert_eq!(table.level_unknown(), Some(1));
        // DVR: 2 (visible), 4 (failed), 5 (unknown); MIP: 2 (its maximum above 0) as well.
        assert_eq!(table.level_unwalkable(false), Some(3));
        assert_eq!(table.level_unwalkable(true), Some(3));
        let dvr: Vec<u32> = table.level_unwalkable_keys(false).collect();
        assert_eq!(dvr, [key(2), key(4), key(5)]);
        // Invisible under DVR: walkable there, not under MIP.
        table.insert(slotless(2, 9 << 16 | 3, 0)).expect("room");
        assert_eq!(table.level_unwalkable(false), Some(2));
        assert_eq!(table.level_unwalkable(true), Some(3));
        // Placed in the atlas, read, and removed again.
        table.insert(entry(key(2))).expect("room");
        table.insert(entry(key(5))).expect("room");
        assert_eq!(table.level_unwalkable(true), Some(1));
        table.remove(key(0));
        assert_eq!(table.level_unwalkable(false), Some(2));
        assert_eq!(table.level_unknown(), Some(1), "5 known, 0 unknown again");
        assert_eq!(
            table.level_unwalkable_keys(true).collect::<Vec<_>>(),
            [key(0), key(4)]
        );
        // Made again from the table: the same counts.
        table.copy_level(None);
        assert_eq!(table.level_unwalkable(false), None);
        table.copy_level(Some((1, [6, 0])));
        assert_eq!(table.level_unwalkable(false), Some(2));
    }

    #[test]
    fn a_copy_of_two_levels_holds_the_coarser_levels_cells_after_the_finer_ones() {
        let mut table = PageTable::new(1024);
        table.insert(entry(level_key(1, 3))).expect("room");
        table.insert(entry(level_key(2, 1))).expect("room");
        table.insert(entry(level_key(3, 0))).expect("room");
        table.copy_level(Some((1, [6, 2])));
        assert_eq!(table.copied_level(), Some((1, 2)));
        let (first, cells) = table.take_level_dirty().expect("all cells");
        assert_eq!((first, cells.len()), (0, 8));
        assert_eq!(cells[3], entry(level_key(1, 3)));
        assert_eq!(cells[6 + 1], entry(level_key(2, 1)));
        assert_eq!(cells.iter().filter(|c| c.key != EMPTY_KEY).count(), 2);
        // Level 3 is not copied; a change of the coarser copied level is.
        table.insert(entry(level_key(3, 1))).expect("room");
        assert!(table.take_level_dirty().is_none());
        table.insert(entry(level_key(2, 0))).expect("room");
        assert_eq!(
            table.take_level_dirty().map(|(first, c)| (first, c.len())),
            Some((6, 1))
        );
        assert_eq!(table.level_unknown(), Some(5));
        assert_eq!(table.level_slots().count(), 3);
        let keys: Vec<u32> = table.level_unwalkable_keys(false).collect();
        assert_eq!(
            keys,
            [0, 1, 2, 4, 5].map(|i| level_key(1, i)),
            "the finer level's unknown five; the coarser level's two are in the atlas"
        );
        // One level of the same first level is another copy.
        table.copy_level(Some((1, [6, 0])));
        assert_eq!(table.copied_level(), Some((1, 1)));
        assert_eq!(table.level_unknown(), Some(5));
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
