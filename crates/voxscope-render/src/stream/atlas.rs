//! How a GPU budget becomes the atlas: its grid of slots and texel format, the share the
//! page table and buffers take, the level a footprint wants, and the budget a view would need
//! at full detail.

use super::*;

/// The level a ray wants where its footprint is `footprint` finest-level voxels: the coarsest
/// from `finest` on whose voxel is no larger (`stream.wgsl`'s `wanted_level`).
pub(super) fn wanted_level(
    shape: &voxscope_stream::PyramidShape,
    finest: usize,
    footprint: f32,
) -> usize {
    let mut level = finest;
    while level + 1 < shape.levels.len() && shape.levels[level + 1].scale as f32 <= footprint {
        level += 1;
    }
    level
}

/// Slots an atlas of `budget` bytes holds (after the renderer's other buffers), bounded by
/// what the pyramid can use and the device's 3D texture size; as a grid of slots.
pub(super) fn atlas_grid(
    context: &GpuContext,
    budget: u64,
    staging_bytes: u64,
    slot_bytes: u64,
    bricks_in_pyramid: u64,
) -> Result<[usize; 3], RenderError> {
    // The lookup table, the request buffer and its set, each readback's copy of the requests
    // (the usage marks are counted per slot), and the uploads' staging on the GPU (with the
    // level copy's buffer).
    let fixed = staging_bytes
        + 65536 * 4
        + (1 + REQUEST_CAPACITY as u64 + REQUEST_SET as u64) * 4
        + READBACKS as u64 * (1 + REQUEST_CAPACITY as u64) * 4;
    let per_slot = slot_bytes + TABLE_BYTES_PER_SLOT + 4 + READBACKS as u64 * 4;
    let max_side = (context.limits.max_texture_dimension_3d as usize / PADDED_BRICK).min(1024);
    let slots = (budget.saturating_sub(fixed) / per_slot)
        .min((max_side * max_side * max_side) as u64) as usize;
    // Every brick of the pyramid and the streamer's margin where the budget allows, in whole
    // layers of a square grid.
    let wanted = slots.min(bricks_in_pyramid.saturating_add(8).min(usize::MAX as u64) as usize);
    let side = ((wanted as f64).cbrt().floor() as usize).clamp(1, max_side);
    let mut depth = wanted.div_ceil(side * side);
    if side * side * depth > slots {
        depth = slots / (side * side);
    }
    let depth = depth.clamp(1, max_side);
    let grid = [side, side, depth];
    if side * side * depth > slots {
        return Err(RenderError::DoesNotFit(format!(
            "a GPU budget of {budget} bytes holds no atlas (a brick takes {slot_bytes} bytes)"
        )));
    }
    Ok(grid)
}

/// The GPU budgets a budget-limited view's status may name: from 1 MiB on, each power of two
/// and the step halfway to the next (64, 96, 128, 192 MiB, …); the app offers those from
/// 64 MiB to 16 GiB.
pub const BUDGET_STEPS: [u64; 50] = {
    let mut steps = [0u64; 50];
    let mut i = 0;
    while i < 25 {
        steps[2 * i] = 1 << (20 + i);
        steps[2 * i + 1] = 3 << (19 + i);
        i += 1;
    }
    steps
};

/// How a GPU budget becomes this volume's atlas, as [`StreamVolume::new`] makes it: to size
/// the budget a view larger than the atlas would need.
#[derive(Debug, Clone, Copy)]
pub(super) struct AtlasSizing {
    /// The budget the atlas was made in: a larger one is named, never this or less.
    pub(super) budget: u64,
    pub(super) slot_bytes: u64,
    pub(super) bricks_in_pyramid: u64,
    /// Bricks a frame uploads through the scattering ring, whose buffer the budget holds,
    /// where the options ask for it and the device can (`None`: the ring copies, out of no
    /// share of the budget).
    pub(super) scatter_per_frame: Option<usize>,
    /// The level copy's bytes where the options ask for the level walk (else 0).
    pub(super) level_cells_bytes: u64,
    /// Bricks of the always-resident levels, which every atlas must hold with a view.
    pub(super) pinned_levels: usize,
    /// Slots of the always-resident levels once read (a uniform one takes none).
    pub(super) pinned: usize,
}

/// What [`AtlasSizing::plan`] chose for a budget: the atlas's grid of slots, and whether the
/// scattering ring's staging and the level copy took their bytes from the budget.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct AtlasPlan {
    pub(super) grid: [usize; 3],
    pub(super) scatter: bool,
    pub(super) level_walk: bool,
}

impl AtlasSizing {
    /// The atlas a budget of `budget` bytes gives: with the scattering ring's staging and the
    /// level copy out of the budget; where the rest cannot hold the always-resident levels and
    /// a view ([`Streamer::check_capacity`]), without the staging (the ring copies, needing
    /// none); where even then it cannot, without the level walk too (its copy's bytes).
    pub(super) fn plan(&self, context: &GpuContext, budget: u64) -> Result<AtlasPlan, RenderError> {
        let staging = self
            .scatter_per_frame
            .and_then(|most| staging_ring::scatter_size(most, self.slot_bytes as usize, budget))
            .map(|(_, bytes)| bytes);
        let steps = [
            staging.map(|bytes| (bytes, true, self.level_cells_bytes > 0)),
            Some((0, false, self.level_cells_bytes > 0)),
            Some((0, false, false)),
        ];
        let mut last = None;
        for (staging_bytes, scatter, level_walk) in steps.into_iter().flatten() {
            let cells = if level_walk {
                self.level_cells_bytes
            } else {
                UNWALKED_LEVEL_CELLS_BYTES
            };
            let fitted = atlas_grid(
                context,
                budget,
                staging_bytes + cells,
                self.slot_bytes,
                self.bricks_in_pyramid,
            )
            .and_then(|grid| {
                Streamer::check_capacity(self.pinned_levels, grid.iter().product())
                    .map_err(|e| RenderError::DoesNotFit(e.to_string()))?;
                Ok(grid)
            });
            match fitted {
                Ok(grid) => {
                    return Ok(AtlasPlan {
                        grid,
                        scatter,
                        level_walk,
                    });
                }
                Err(error) => last = Some(error),
            }
        }
        Err(last.expect("the last step is always tried"))
    }

    /// Of the atlas a budget of `budget` bytes gives ([`Self::plan`]), the slots a view may
    /// fill ([`view_slots`]) and all its slots; `None` where it holds no atlas.
    pub(super) fn slots(&self, context: &GpuContext, budget: u64) -> Option<(usize, usize)> {
        let plan = self.plan(context, budget).ok()?;
        let slots = plan.grid.iter().product::<usize>();
        Some((view_slots(slots, self.pinned), slots))
    }

    /// The smallest of [`BUDGET_STEPS`] above the budget in use whose atlas holds a view of
    /// `needed` bricks at full detail, with the coarser bricks its refinement loads on the
    /// way (an eighth more for each finer level: a seventh in all), or every brick of the
    /// pyramid; where none does, more than the largest atlas this device makes.
    pub(super) fn full_detail_budget(
        &self,
        context: &GpuContext,
        needed: usize,
    ) -> FullDetailBudget {
        let wanted = needed + needed.div_ceil(7);
        BUDGET_STEPS
            .into_iter()
            .filter(|&budget| budget > self.budget)
            .find(|&budget| {
                self.slots(context, budget).is_some_and(|(view, slots)| {
                    view >= wanted || slots as u64 >= self.bricks_in_pyramid
                })
            })
            .map_or(FullDetailBudget::BeyondDevice, FullDetailBudget::Bytes)
    }
}

/// `visible_below[i]`: how many value levels below `i` the lookup table makes visible.
pub(super) fn visible_below(table: &[u32]) -> Vec<u32> {
    let mut counts = Vec::with_capacity(table.len() + 1);
    let mut count = 0u32;
    counts.push(0);
    for &color in table {
        count += (color >> 24 != 0) as u32;
        counts.push(count);
    }
    counts
}

/// How an atlas on `context`'s device stores value levels up to `max_level`: a byte where
/// they fit in one, else two (normalized where the device filters such textures).
pub(super) fn atlas_texels(context: &GpuContext, max_level: u16) -> AtlasTexels {
    if max_level <= 255 {
        AtlasTexels::Unorm8
    } else if context.has_norm16_textures {
        AtlasTexels::Unorm16
    } else {
        AtlasTexels::Float16
    }
}

/// The atlas texture's format for `texels`.
pub(super) fn atlas_format(texels: AtlasTexels) -> wgpu::TextureFormat {
    match texels {
        AtlasTexels::Unorm8 => wgpu::TextureFormat::R8Unorm,
        AtlasTexels::Unorm16 => wgpu::TextureFormat::R16Unorm,
        AtlasTexels::Float16 => wgpu::TextureFormat::R16Float,
    }
}

/// The formats an atlas on `context`'s device may have: a byte's, and two bytes'.
pub(crate) fn atlas_formats(context: &GpuContext) -> [wgpu::TextureFormat; 2] {
    [0, u16::MAX].map(|max_level| atlas_format(atlas_texels(context, max_level)))
}
