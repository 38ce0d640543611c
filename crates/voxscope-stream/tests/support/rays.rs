//! A CPU stand-in for the streaming renderer's rays (`shaders/stream.wgsl`'s segment loop), for
//! tests of what the streamer makes of a view without a GPU: each ray walks the volume segment
//! by segment at the level its pixel footprint wants, draws the brick where the page table has
//! it in the atlas (or uniform), else asks for it (a request buffer of a fixed capacity,
//! appended in the order the GPU's workgroups run: 8×8 tiles, the image's top rows first) and
//! draws the finest coarser brick the table has; each slot drawn is marked `2·frame + 1` where
//! the ray wanted its level, `2·frame` where it stood in. DVR rays stop once they have drawn a
//! given depth of the volume (opacity), MIP rays cross it whole. What the rays drew is kept
//! brick by brick, for the tests to measure the cut a view settles on.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;
use std::time::{Duration, Instant};

use voxscope_stream::{
    BRICK_SIZE, BrickData, BrickError, BrickId, BrickSource, ENTRY_FAILED, ENTRY_VISIBLE, Feedback,
    PADDED_BRICK, PADDED_BRICK_VOXELS, PyramidShape, StreamStatus, Streamer, TableEntry, ViewPoint,
};
use voxscope_volume::Quantization;

/// How rays take the volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// The maximum: a ray crosses the volume whole.
    Mip,
    /// Compositing: a ray stops once it has drawn this many level-0 voxels of the volume.
    Dvr { depth: f64 },
}

/// A pinhole camera in level-0 voxel space.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    pub eye: [f64; 3],
    pub forward: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    pub width: u32,
    pub height: u32,
    tan_half_fov: f64,
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let length = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / length)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl Camera {
    /// From `eye` towards `target` (z up), `width`×`height` pixels over `fov_y_deg`.
    pub fn looking_at(
        eye: [f64; 3],
        target: [f64; 3],
        width: u32,
        height: u32,
        fov_y_deg: f64,
    ) -> Self {
        let forward = normalize(std::array::from_fn(|a| target[a] - eye[a]));
        let right = normalize(cross(forward, [0.0, 0.0, 1.0]));
        let up = cross(right, forward);
        Self {
            eye,
            forward,
            right,
            up,
            width,
            height,
            tan_half_fov: (fov_y_deg.to_radians() * 0.5).tan(),
        }
    }

    /// Where the streamer sees the camera.
    pub fn view_point(&self) -> ViewPoint {
        let (aspect, tan) = (self.width as f64 / self.height as f64, self.tan_half_fov);
        ViewPoint {
            extent: Some([
                self.right.map(|c| c * tan * aspect),
                self.up.map(|c| c * tan),
            ]),
            ..ViewPoint::new(self.eye, self.forward)
        }
    }

    /// The angle one pixel spans (radians): a pixel's footprint at distance `t` is `t` times it.
    pub fn pixel_angle(&self) -> f64 {
        2.0 * self.tan_half_fov / self.height as f64
    }

    fn ray(&self, x: u32, y: u32) -> [f64; 3] {
        let aspect = self.width as f64 / self.height as f64;
        let u = (2.0 * (x as f64 + 0.5) / self.width as f64 - 1.0) * self.tan_half_fov * aspect;
        let v = (1.0 - 2.0 * (y as f64 + 0.5) / self.height as f64) * self.tan_half_fov;
        normalize(std::array::from_fn(|a| {
            self.forward[a] + u * self.right[a] + v * self.up[a]
        }))
    }
}

/// The rays of one view.
#[derive(Debug, Clone, Copy)]
pub struct Rays {
    pub camera: Camera,
    pub mode: Mode,
    /// Multiplies the pixel footprint before it picks a level (`--lod-scale`; 0: every ray
    /// wants [`Self::finest`]).
    pub lod_scale: f64,
    /// The finest level a ray wants (the max-level slider's).
    pub finest: u32,
    /// Keys the request buffer holds per frame (`stream.rs`'s `REQUEST_CAPACITY`).
    pub capacity: usize,
}

/// What one frame's rays did.
#[derive(Debug, Clone, Default)]
pub struct Drawn {
    pub requests: Vec<u32>,
    /// Distinct asks, those beyond the buffer's capacity included.
    pub asked: u32,
    pub usage: Vec<u32>,
    /// Per brick a ray wanted (its key): the key of the brick drawn in its place (itself where
    /// it was in the atlas or uniform).
    pub drawn: HashMap<u32, u32>,
    /// Per brick a ray wanted: the finest brick the table could draw there, itself or coarser,
    /// whether the ray drew it or passed over it (MIP: below its maximum so far): the level the
    /// view resolves it at, its cut.
    pub resolved: HashMap<u32, u32>,
}

/// The segment's interval of the box `[low, high)` along `origin + t·dir`.
fn interval(origin: [f64; 3], dir: [f64; 3], low: [f64; 3], high: [f64; 3]) -> (f64, f64) {
    let (mut enter, mut leave) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        if dir[a].abs() < 1e-12 {
            if origin[a] < low[a] || origin[a] >= high[a] {
                return (1.0, 0.0);
            }
            continue;
        }
        let (t0, t1) = (
            (low[a] - origin[a]) / dir[a],
            (high[a] - origin[a]) / dir[a],
        );
        enter = enter.max(t0.min(t1));
        leave = leave.min(t0.max(t1));
    }
    (enter.max(0.0), leave)
}

impl Rays {
    /// The level a segment starting at distance `t` wants (`stream.wgsl`'s `wanted_level`).
    fn wanted_level(&self, shape: &PyramidShape, t: f64) -> u32 {
        let footprint = t * self.camera.pixel_angle() * self.lod_scale;
        let mut level = self.finest;
        while (level as usize + 1) < shape.levels.len()
            && shape.levels[level as usize + 1].scale as f64 <= footprint
        {
            level += 1;
        }
        level
    }

    /// Frame `frame`'s rays against `streamer`'s page table.
    pub fn draw(&self, streamer: &Streamer, frame: u32, slots: usize) -> Drawn {
        let mut drawn = Drawn {
            usage: vec![0; slots],
            ..Drawn::default()
        };
        let mut asked = HashSet::new();
        let (w, h) = (self.camera.width, self.camera.height);
        for tile_y in (0..h).step_by(8) {
            for tile_x in (0..w).step_by(8) {
                for y in tile_y..(tile_y + 8).min(h) {
                    for x in tile_x..(tile_x + 8).min(w) {
                        self.ray(
                            streamer,
                            frame,
                            self.camera.ray(x, y),
                            &mut drawn,
                            &mut asked,
                        );
                    }
                }
            }
        }
        drawn
    }

    fn ray(
        &self,
        streamer: &Streamer,
        frame: u32,
        dir: [f64; 3],
        drawn: &mut Drawn,
        asked: &mut HashSet<u32>,
    ) {
        let shape = streamer.shape();
        let table = streamer.table();
        let dims = shape.dims().map(|d| d as f64);
        let origin = self.camera.eye;
        let (t_enter, t_leave) = interval(origin, dir, [0.0; 3], dims);
        let mut t = t_enter;
        let (mut depth, mut running) = (0.0, 0u32);
        let mark = |usage: &mut Vec<u32>, slot: u32, value: u32| {
            let slot = (slot & !ENTRY_VISIBLE) as usize;
            usage[slot] = usage[slot].max(value);
        };
        while t < t_leave {
            let ahead = 1e-3;
            let wanted = self.wanted_level(shape, t);
            let side = (BRICK_SIZE * shape.levels[wanted as usize].scale) as f64;
            let p: [f64; 3] = std::array::from_fn(|a| origin[a] + (t + ahead) * dir[a]);
            let grid = shape.levels[wanted as usize].grid;
            let cell: [u32; 3] = std::array::from_fn(|a| {
                ((p[a] / side).floor().max(0.0) as usize).min(grid[a] - 1) as u32
            });
            let low = cell.map(|c| c as f64 * side);
            let high = cell.map(|c| (c + 1) as f64 * side);
            let (_, exit) = interval(origin, dir, low, high);
            let t_out = exit.min(t_leave).max(t + ahead);
            let id = BrickId {
                level: wanted,
                brick: cell,
                channel: 0,
            };
            let key = shape.key(id).expect("inside the grid");
            let entry = table.get(key);
            // As `stream_ray`: a brick missing (or unreadable, or not drawable and able to
            // show) is asked for and drawn from the finest coarser brick the table can draw; a
            // brick drawn only where it can show (MIP: its maximum above the ray's so far;
            // DVR: its range visible), else the ray passes over it without a mark.
            let drawable = |e: &TableEntry| {
                e.is_resident()
                    || (e.cell & ENTRY_FAILED == 0 && (e.range & 0xffff) == (e.range >> 16))
            };
            let shows = |e: &TableEntry, running: u32| match self.mode {
                Mode::Mip => (e.range >> 16) > running,
                Mode::Dvr { .. } => e.slot & ENTRY_VISIBLE != 0,
            };
            let mut chosen = None;
            let mut skip = false;
            match entry {
                Some(e) if e.cell & ENTRY_FAILED == 0 && drawable(&e) => {
                    chosen = Some((key, e, true));
                }
                Some(e) if e.cell & ENTRY_FAILED == 0 && !shows(&e, running) => skip = true,
                _ => {
                    if asked.insert(key) {
                        drawn.asked += 1;
                        if drawn.requests.len() < self.capacity {
                            drawn.requests.push(key);
                        }
                    }
                }
            }
            if !skip && chosen.is_none() {
                let mut up = shape.parent(id);
                while let Some(coarser) = up {
                    let k = shape.key(coarser).expect("a parent");
                    if let Some(e) = table.get(k).filter(|e| drawable(e)) {
                        chosen = Some((k, e, false));
                        break;
                    }
                    up = shape.parent(coarser);
                }
            }
            if let Some((brick, _, _)) = chosen {
                drawn.resolved.insert(key, brick);
            }
            if let Some((brick, e, wanted)) = chosen.filter(|(_, e, _)| shows(e, running)) {
                if e.is_resident() {
                    mark(&mut drawn.usage, e.slot, 2 * frame + u32::from(wanted));
                }
                running = running.max(e.range >> 16);
                drawn.drawn.insert(key, brick);
                depth += t_out - t;
            }
            if let Mode::Dvr { depth: most } = self.mode
                && depth >= most
            {
                break;
            }
            t = t_out;
        }
    }
}

/// What a view came to once the streamer said it was complete.
#[derive(Debug, Clone)]
pub struct Settled {
    pub status: StreamStatus,
    pub frames: u32,
    pub seconds: f64,
    /// The last frame's rays.
    pub drawn: Drawn,
    /// The most distinct bricks (pinned ones aside) any frame drew.
    pub most_drawn: usize,
}

/// Draws `rays`' view frame after frame (the feedback a frame late, as the renderer reads it
/// back) until the streamer says it is complete; panics after `limit`.
pub fn settle(streamer: &mut Streamer, rays: &Rays, limit: Duration) -> Settled {
    let view = rays.camera.view_point();
    let max_projection = rays.mode == Mode::Mip;
    let started = Instant::now();
    let mut pending: Option<(u32, Drawn)> = None;
    let mut first = None;
    let mut most_drawn = 0;
    for frames in 0.. {
        let feedback = pending.as_ref().map(|(frame, drawn)| Feedback {
            frame: *frame,
            requests: &drawn.requests,
            asked: drawn.asked,
            usage: &drawn.usage,
            max_projection,
        });
        let (uploads, status) = streamer.begin_frame(feedback, Some(view));
        let frame = streamer.frame();
        let first = *first.get_or_insert(frame);
        let drawn = rays.draw(streamer, frame, status.counters.slots);
        let distinct: HashSet<u32> = drawn.resolved.values().copied().collect();
        most_drawn = most_drawn.max(distinct.len());
        if status.complete && status.judged_frame.is_some_and(|judged| judged >= first) {
            return Settled {
                status,
                frames,
                seconds: started.elapsed().as_secs_f64(),
                drawn,
                most_drawn,
            };
        }
        assert!(
            started.elapsed() < limit,
            "not complete after {frames} frames: {status:?}"
        );
        if status.queued + status.loading > 0 && uploads.is_empty() {
            std::thread::sleep(Duration::from_millis(1));
        }
        pending = Some((frame, drawn));
    }
    unreachable!()
}

/// How bright a brick of a [`Ramps`] pyramid is: the lowest value level of its ramp.
type Brightness = dyn Fn(&PyramidShape, BrickId) -> u16 + Send + Sync;

/// A pyramid of `dims` whose bricks are cheap to make (a ramp along x within each, from a
/// level each brick has), none uniform, all visible: what a test of the streamer's choices
/// needs, without the cost of noise.
pub struct Ramps {
    shape: PyramidShape,
    brightness: Box<Brightness>,
}

impl Ramps {
    /// Each brick's ramp from a smooth field at its center (so that a coarser brick is about
    /// as bright as the finer ones it covers, as a pyramid's levels are).
    pub fn new(dims: [usize; 3]) -> Arc<Self> {
        Self::with_brightness(dims, |shape, id| {
            let [x, y, z] = shape.brick_center(id);
            let field = (x / 347.0).sin() * (y / 251.0).cos() * 6000.0 + (z / 97.0).sin() * 2000.0;
            (20_000.0 + field) as u16
        })
    }

    /// Each brick's ramp from `brightness(shape, id)` (below 65 000).
    pub fn with_brightness(
        dims: [usize; 3],
        brightness: impl Fn(&PyramidShape, BrickId) -> u16 + Send + Sync + 'static,
    ) -> Arc<Self> {
        Arc::new(Self {
            shape: PyramidShape::new(dims).expect("a pyramid"),
            brightness: Box::new(brightness),
        })
    }
}

impl BrickSource for Ramps {
    fn name(&self) -> &str {
        "ramps"
    }
    fn shape(&self) -> &PyramidShape {
        &self.shape
    }
    fn spacing(&self) -> [f64; 3] {
        [1.0; 3]
    }
    fn quantization(&self) -> Quantization {
        Quantization {
            offset: 0.0,
            step: 1.0,
        }
    }
    fn max_value_level(&self) -> u16 {
        u16::MAX
    }
    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        if self.shape.key(id).is_none() {
            return Err(BrickError::invalid("no such brick"));
        }
        let base = (self.brightness)(&self.shape, id);
        let levels = (0..PADDED_BRICK_VOXELS)
            .map(|i| base + (i % PADDED_BRICK) as u16 + 1)
            .collect();
        Ok(BrickData::new(levels, [BRICK_SIZE; 3]))
    }
}
