//! The level walk: the levels every ray of a frame wants ([`WalkLevels`]), worked out from
//! the view, and which a frame walks flat from the page table's copy instead of segment by
//! segment.

use super::*;

/// The levels every ray of a frame wants wherever it meets the volume: `level`, and where
/// `two`, the next coarser one too (from some distance on, each ray from its own).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct WalkLevels {
    pub(super) level: u32,
    pub(super) two: bool,
}

impl WalkLevels {
    /// As `walk_wanted` holds it (far below its [`NO_LEVEL`] and [`NOT_DRAWN`]).
    pub(super) fn code(self) -> u32 {
        self.level * 2 + u32::from(self.two)
    }

    pub(super) fn from_code(code: u32) -> Self {
        Self {
            level: code / 2,
            two: code % 2 == 1,
        }
    }

    /// The coarsest of them.
    pub(super) fn last(self) -> u32 {
        self.level + u32::from(self.two)
    }

    /// Whether these levels include all of `other`'s: a copy of these serves frames that want
    /// those (`main_levels`: a ray that wants only the coarser level starts in it).
    pub(super) fn covers(self, other: Self) -> bool {
        self.level <= other.level && other.last() <= self.last()
    }

    /// The levels of both, where they make one level or two adjacent ones.
    pub(super) fn union(self, other: Self) -> Option<Self> {
        let (first, last) = (self.level.min(other.level), self.last().max(other.last()));
        (last - first <= 1).then_some(Self {
            level: first,
            two: last > first,
        })
    }

    /// The levels the page table copies, if any.
    pub(super) fn copied(table: &voxscope_stream::PageTable) -> Option<Self> {
        let (level, levels) = table.copied_level()?;
        Some(Self {
            level,
            two: levels == 2,
        })
    }

    /// The bricks of the level and of the next coarser one (0 where it is not walked).
    pub(super) fn bricks(self, shape: &voxscope_stream::PyramidShape) -> Option<[usize; 2]> {
        let bricks = |level: u32| {
            (shape.levels.get(level as usize)).map(|level| level.brick_count() as usize)
        };
        Some([
            bricks(self.level)?,
            if self.two { bricks(self.level + 1)? } else { 0 },
        ])
    }
}

impl StreamVolume {
    /// The level every ray of a frame of `params` wants wherever it meets the volume (the
    /// pixel LOD's, `wanted_level` in `stream.wgsl`), or the two levels (one and the next
    /// coarser) between which every ray's wanted level lies, where the page table may copy them
    /// flat (at most [`LEVEL_WALK_BRICKS`] bricks); `None` where rays want more levels. Worked
    /// out from the depths of the volume box's corners and the widest pixel's footprint, with a
    /// margin, so that it never leaves out a level some ray would want.
    pub(super) fn walk_level(&self, params: &RaycastParams) -> Option<WalkLevels> {
        if !self.streamer.options().level_walk {
            return None;
        }
        let shape = self.streamer.shape();
        let finest = shape.depth().saturating_sub(params.max_level) as usize;
        let per_depth = params.lod_factor * self.streamer.options().lod_scale.max(0.0);
        let level = if per_depth > 0.0 {
            // A point's depth (its ray's t: the world distance along the image center's
            // direction) is linear in its voxel coordinates; a ray's footprint at depth t is
            // t · its world length · `per_depth`, the world length 1 at the center and largest
            // at the image's corners.
            let vector = |v: [f32; 4]| glam::Vec3::new(v[0], v[1], v[2]);
            let camera = glam::Mat3::from_cols(
                vector(params.forward),
                vector(params.right),
                vector(params.up),
            );
            if camera.determinant().abs() < 1e-20 {
                return None;
            }
            let depth_of = camera.inverse().row(0);
            let eye = vector(params.eye);
            let dims = vector(params.volume);
            let depths = (0..8).map(|corner| {
                let select = glam::Vec3::new(
                    (corner & 1) as f32,
                    (corner >> 1 & 1) as f32,
                    (corner >> 2 & 1) as f32,
                );
                depth_of.dot(dims * select - eye)
            });
            let (nearest, farthest) = depths.fold((f32::MAX, f32::MIN), |(lo, hi), depth| {
                (lo.min(depth), hi.max(depth))
            });
            let widest = (1.0 + params.right[3].powi(2) + params.up[3].powi(2)).sqrt();
            let level = wanted_level(shape, finest, nearest.max(0.0) * per_depth * 0.999);
            let far = wanted_level(
                shape,
                finest,
                farthest.max(0.0) * widest * per_depth * 1.001,
            );
            let two = match far.checked_sub(level)? {
                0 => false,
                1 => true,
                _ => return None,
            };
            WalkLevels {
                level: level as u32,
                two,
            }
        } else {
            WalkLevels {
                level: finest as u32,
                two: false,
            }
        };
        let bricks: usize = level.bricks(shape)?.iter().sum();
        (bricks as u64 <= LEVEL_WALK_BRICKS).then_some(level)
    }

    /// The levels a frame of `params` walks (`main_level`, `main_levels`): those the table
    /// copies, where they include [`Self::walk_level`]'s and every brick of them there is
    /// walkable in the frame's mode.
    pub(super) fn walked_level(&self, params: &RaycastParams) -> Option<WalkLevels> {
        let table = self.streamer.table();
        let copied = WalkLevels::copied(table)?;
        let walkable = table.level_unwalkable(max_projection(params)) == Some(0);
        (walkable && copied.covers(self.walk_level(params)?)).then_some(copied)
    }

    /// The finest level whose bricks the page table copies flat (every ray of the latest frame
    /// wanted it, or it and the next coarser one), how many levels it copies (1 or 2), and how
    /// many of their bricks the level walk could not take in that frame's mode: 0 when frames
    /// walk them. `None` where rays want more levels, or levels too large to copy.
    pub fn walk_level_state(&self) -> Option<(u32, u32, usize)> {
        let table = self.streamer.table();
        let mip = self.max_projection.load(Ordering::Acquire);
        let (level, levels) = table.copied_level()?;
        Some((level, levels, table.level_unwalkable(mip)?))
    }

    /// How many frames (a band of one counts too) the level walk has drawn.
    pub fn level_walk_frames(&self) -> u64 {
        self.walked_frames.load(Ordering::Relaxed)
    }
}
