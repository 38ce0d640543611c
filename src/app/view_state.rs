//! What the app shows of the volume on screen that belongs to that volume alone and is reset
//! when another opens: its value window, the max level of each view, and the per-level
//! statistics under the live transfer function. (What carries over from one volume to the
//! next is in [`super::AppSettings`].)

use voxscope_octree::{Clip, ClipPlane, LevelStatistics, TransferFunction};
use voxscope_render::{RendererKind, SliceView};
use voxscope_scene::{ChannelState, TransferChoice};
use voxscope_volume::ValueWindow;

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
    /// The transfer function and clip [`Self::statistics`] were counted under.
    pub statistics_for: Option<(TransferFunction, Clip)>,
    /// The point every view shares (the slices' crossing), in voxel space: voxel `(i, j, k)`
    /// is the cube `[i, i+1) × [j, j+1) × [k, k+1)`, displayed (RAS-reordered) order.
    pub cursor: [f64; 3],
    /// What is clipped away.
    pub clipping: Clipping,
    /// Distances measured, in voxel space (shown in mm).
    pub rulers: Vec<Ruler>,
    /// The zoom and pan of the slice views across x, y and z (their slice is the cursor's).
    pub slice_views: [SliceView; 3],
    /// Each channel's color, visibility and transfer function, for the composite (empty for
    /// a one-channel file); the active one's transfer function is the panel's, live.
    pub channels: Vec<ChannelState>,
    /// The channel the transfer function editor edits.
    pub active_channel: usize,
    /// The renderer this volume's data called for where it differs from the one chosen in
    /// the Octree panel (a store larger than memory streams; an octree too large for the
    /// GPU's buffers is drawn with bricks), until the user chooses another. It is no choice
    /// of the user's: the next volume opens with theirs.
    pub data_renderer: Option<RendererKind>,
    /// The transfer function of the rendering mode not on screen (DVR's while MIP is shown,
    /// MIP's while DVR is): switching modes swaps it with the panel's, so a CT's MIP is not
    /// drawn through the soft-tissue preset's narrow window and going back restores the DVR
    /// curve as it was. `None` until the first switch (the mode then opens with what fits it).
    pub other_mode: Option<ModeLook>,
}

/// A rendering mode's transfer function: the panel's choices and the window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeLook {
    pub transfer: TransferChoice,
    pub window: ValueWindow,
}

/// The crop box and clip plane as the panel edits them: each kept while switched off, so
/// switching it on again restores it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clipping {
    pub box_on: bool,
    /// Per axis, the kept fraction `[low, high]`.
    pub bounds: [[f32; 2]; 3],
    pub plane_on: bool,
    pub plane: ClipPlane,
}

impl Default for Clipping {
    fn default() -> Self {
        Self {
            box_on: false,
            bounds: [[0.0, 1.0]; 3],
            plane_on: false,
            plane: ClipPlane {
                normal: [0.0, 0.0, 1.0],
                distance: 0.5,
            },
        }
    }
}

impl From<Clip> for Clipping {
    /// The panel's state for `clip`: what it lacks stays at the defaults, switched off.
    fn from(clip: Clip) -> Self {
        let defaults = Self::default();
        Self {
            box_on: clip.bounds.is_some(),
            bounds: clip.bounds.unwrap_or(defaults.bounds),
            plane_on: clip.plane.is_some(),
            plane: clip.plane.unwrap_or(defaults.plane),
        }
    }
}

impl Clipping {
    /// The clip the renderers and statistics use.
    pub fn clip(&self) -> Clip {
        Clip {
            bounds: self.box_on.then_some(self.bounds),
            plane: self.plane_on.then_some(self.plane),
        }
    }
}

/// A measured distance between two points (voxel space).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ruler {
    pub from: [f64; 3],
    pub to: [f64; 3],
}

impl Ruler {
    /// Its length in the file's unit (usually mm) for voxels of `spacing`.
    pub fn length(&self, spacing: [f64; 3]) -> f64 {
        (0..3)
            .map(|a| ((self.to[a] - self.from[a]) * spacing[a]).powi(2))
            .sum::<f64>()
            .sqrt()
    }
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
            cursor: [0.0; 3],
            clipping: Clipping::default(),
            rulers: Vec::new(),
            slice_views: std::array::from_fn(|axis| SliceView::new(axis, 0)),
            channels: Vec::new(),
            active_channel: 0,
            data_renderer: None,
            other_mode: None,
        }
    }
}

impl ViewState {
    /// The state a newly opened volume of `dims` voxels starts with: its octree of `depth`
    /// drawn in full, colored by `transfer`, whose statistics are `statistics`; the cursor in
    /// the middle, nothing clipped or measured.
    pub fn new(
        dims: [usize; 3],
        depth: u32,
        transfer: TransferFunction,
        statistics: Vec<LevelStatistics>,
    ) -> Self {
        Self {
            window: transfer.window,
            max_level: depth,
            grid_levels: default_grid_levels(depth),
            statistics,
            statistics_for: Some((transfer, Clip::NONE)),
            cursor: dims.map(|d| (d / 2) as f64 + 0.5),
            clipping: Clipping::default(),
            rulers: Vec::new(),
            slice_views: std::array::from_fn(|axis| SliceView::new(axis, dims[axis] / 2)),
            channels: Vec::new(),
            active_channel: 0,
            data_renderer: None,
            other_mode: None,
        }
    }

    /// The composite's channels as drawn now: the stored states, the active one with `live`
    /// (the panel's transfer function) as its transfer function.
    pub fn composite_channels(&self, live: TransferFunction) -> Vec<ChannelState> {
        let mut channels = self.channels.clone();
        if let Some(active) = channels.get_mut(self.active_channel) {
            active.transfer = live;
        }
        channels
    }

    /// The voxel under the cursor.
    pub fn cursor_voxel(&self, dims: [usize; 3]) -> [usize; 3] {
        std::array::from_fn(|a| (self.cursor[a].max(0.0) as usize).min(dims[a].saturating_sub(1)))
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

    /// The levels of a grid of `count` panes, capped at `depth`, pane by pane.
    pub fn grid_levels_shown(&self, count: usize, depth: u32) -> Vec<u32> {
        (0..count.min(MAX_GRID_PANES))
            .map(|index| self.grid_level(index, count, depth))
            .collect()
    }

    /// The level grid goes from `from` panes to `to`: its panes keep the levels shown (the
    /// finest of them where there are fewer panes), and new panes take the deepest levels not
    /// shown yet, so no level is drawn twice while the octree has levels enough
    /// (`depth + 1`); panes in order of level.
    pub fn resize_grid(&mut self, from: usize, to: usize, depth: u32) {
        let to = to.clamp(1, MAX_GRID_PANES);
        let mut levels = self.grid_levels_shown(from, depth);
        levels.sort_unstable();
        levels.dedup();
        // Fewer panes: the finest levels stay.
        let keep_from = levels.len().saturating_sub(to);
        levels.drain(..keep_from);
        for level in (0..=depth).rev() {
            if levels.len() >= to {
                break;
            }
            if !levels.contains(&level) {
                levels.push(level);
            }
        }
        levels.sort_unstable();
        // Fewer levels than panes (a shallow octree): the coarsest repeats.
        while levels.len() < to {
            levels.insert(0, levels.first().copied().unwrap_or(0));
        }
        if self.grid_levels.len() < MAX_GRID_PANES {
            self.grid_levels = default_grid_levels(depth);
        }
        for (index, level) in levels.into_iter().enumerate() {
            self.grid_levels[grid_slot(index, to)] = level;
        }
    }

    /// True when the statistics describe `transfer` within the current clip.
    pub fn statistics_current(&self, transfer: &TransferFunction) -> bool {
        self.statistics_for == Some((*transfer, self.clipping.clip()))
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
        let view = ViewState::new([256; 3], 8, transfer, Vec::new());
        let levels: Vec<u32> = (0..4).map(|i| view.grid_level(i, 4, 8)).collect();
        assert_eq!(levels, [5, 6, 7, 8]);
        let shallow = ViewState::new([8; 3], 3, transfer, Vec::new());
        let levels: Vec<u32> = (0..6).map(|i| shallow.grid_level(i, 6, 3)).collect();
        assert_eq!(levels, [0, 0, 0, 1, 2, 3]);
    }

    #[test]
    fn a_grid_grown_or_shrunk_draws_no_level_twice() {
        let transfer = TransferFunction::gray(ValueWindow {
            low: 0.0,
            high: 1.0,
        });
        let mut view = ViewState::new([256; 3], 8, transfer, Vec::new());
        // Four panes, the first set to level 3 by the user: 3, 6, 7, 8.
        *view.grid_level_mut(0, 4).unwrap() = 3;
        assert_eq!(view.grid_levels_shown(4, 8), [3, 6, 7, 8]);
        // Six panes keep those and add the deepest levels not shown (it showed 3, 4, 3, 6, 7, 8).
        view.resize_grid(4, 6, 8);
        assert_eq!(view.grid_levels_shown(6, 8), [3, 4, 5, 6, 7, 8]);
        *view.grid_level_mut(5, 6).unwrap() = 1;
        // Three panes keep the finest three shown.
        view.resize_grid(6, 3, 8);
        assert_eq!(view.grid_levels_shown(3, 8), [5, 6, 7]);
        view.resize_grid(3, 2, 8);
        assert_eq!(view.grid_levels_shown(2, 8), [6, 7]);
        view.resize_grid(2, 5, 8);
        assert_eq!(view.grid_levels_shown(5, 8), [4, 5, 6, 7, 8]);
        // A shallow octree has four levels for six panes: the coarsest repeats, nothing else.
        let mut shallow = ViewState::new([8; 3], 3, transfer, Vec::new());
        shallow.resize_grid(4, 6, 3);
        assert_eq!(shallow.grid_levels_shown(6, 3), [0, 0, 0, 1, 2, 3]);
    }
}
