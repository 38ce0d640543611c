//! What the app shows of the volume on screen that belongs to that volume alone and is reset
//! when another opens: its value window, the max level of each view, and the per-level
//! statistics under the live transfer function. (What carries over from one volume to the
//! next is in [`super::AppSettings`].)

use crate::octree::{LevelStatistics, TransferFunction};
use crate::volume::ValueWindow;

/// The level grid's largest pane count.
pub const MAX_GRID_PANES: usize = 6;

/// The view state of one volume.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewState {
    /// The value window (data units).
    pub window: ValueWindow,
    /// Deepest level drawn in the single and pair views.
    pub max_level: u32,
    /// One level per pane of the level grid ([`MAX_GRID_PANES`]; a grid of `n` panes shows
    /// the last `n`).
    pub grid_levels: Vec<u32>,
    /// Nodes, leaves, transparent and opaque nodes per level.
    pub statistics: Vec<LevelStatistics>,
    /// The transfer function [`Self::statistics`] were counted under.
    pub statistics_for: Option<TransferFunction>,
}

impl Default for ViewState {
    fn default() -> Self {
        Self {
            window: ValueWindow {
                low: 0.0,
                high: 1.0,
            },
            max_level: 0,
            grid_levels: Vec::new(),
            statistics: Vec::new(),
            statistics_for: None,
        }
    }
}

impl ViewState {
    /// The state a newly opened volume starts with: its octree of `depth` drawn in full,
    /// colored by `transfer`, whose statistics are `statistics`.
    pub fn new(depth: u32, transfer: TransferFunction, statistics: Vec<LevelStatistics>) -> Self {
        Self {
            window: transfer.window,
            max_level: depth,
            grid_levels: default_grid_levels(depth),
            statistics,
            statistics_for: Some(transfer),
        }
    }

    /// The level of pane `index` of a level grid of `count` panes, capped at `depth`.
    pub fn grid_level(&self, index: usize, count: usize, depth: u32) -> u32 {
        self.grid_levels
            .get(grid_slot(index, count))
            .copied()
            .unwrap_or(depth)
            .min(depth)
    }

    /// The level of pane `index` of `count`, as an editable value.
    pub fn grid_level_mut(&mut self, index: usize, count: usize) -> Option<&mut u32> {
        self.grid_levels.get_mut(grid_slot(index, count))
    }

    /// True when the statistics describe `transfer`.
    pub fn statistics_current(&self, transfer: &TransferFunction) -> bool {
        self.statistics_for.as_ref() == Some(transfer)
    }
}

/// Levels of the six grid panes: the deepest six, ending at the voxels. A grid of `n` panes
/// shows the last `n` (depth 8, four panes: 5, 6, 7, 8, as in the paper's Figure 3).
fn default_grid_levels(depth: u32) -> Vec<u32> {
    (0..MAX_GRID_PANES as u32)
        .map(|i| (depth + i).saturating_sub(MAX_GRID_PANES as u32 - 1))
        .collect()
}

/// Index into [`ViewState::grid_levels`] of pane `index` of `count`.
fn grid_slot(index: usize, count: usize) -> usize {
    (MAX_GRID_PANES - count.min(MAX_GRID_PANES)) + index
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_of_four_shows_the_deepest_four_levels() {
        let transfer = TransferFunction::gray(ValueWindow {
            low: 0.0,
            high: 1.0,
        });
        let view = ViewState::new(8, transfer, Vec::new());
        let levels: Vec<u32> = (0..4).map(|i| view.grid_level(i, 4, 8)).collect();
        assert_eq!(levels, [5, 6, 7, 8]);
        let shallow = ViewState::new(3, transfer, Vec::new());
        let levels: Vec<u32> = (0..6).map(|i| shallow.grid_level(i, 6, 3)).collect();
        assert_eq!(levels, [0, 0, 0, 1, 2, 3]);
    }
}
