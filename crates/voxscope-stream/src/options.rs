//! The choices that size a streamer: GPU and RAM budgets, upload budget, loader threads, the
//! pixel LOD, prefetch and how failed bricks are retried.

use std::time::Duration;

/// Choices that size the streamer.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct StreamOptions {
    /// GPU memory for everything the streaming renderer holds (atlas, page table, request and
    /// usage buffers, lookup tables, the uploads' staging on the GPU), in bytes
    /// (`--gpu-memory`). Default 1 GiB; never more than the device allows (its largest 3D
    /// texture bounds the atlas).
    pub gpu_memory: u64,
    /// Bytes of decoded bricks kept in RAM (`--ram-cache`). Default 2 GiB.
    pub ram_cache: u64,
    /// Bytes uploaded to the atlas per frame at most (`--upload-budget`). Within it, a frame
    /// uploads what its measured upload cost lets it do in a few milliseconds
    /// ([`crate::UPLOAD_SECONDS_PER_FRAME`]). Default 256 MiB. (With a fixed 8 MiB, runs
    /// 46–47 on an H200 kept 199 of 200 frames under 16 ms, and 32 MiB took up to 100 ms a
    /// frame: docs/performance-log.md, "Uploads into the atlas".)
    pub upload_bytes_per_frame: u64,
    /// How bricks reach the atlas (`--uploads`). Default [`UploadPath::Scatter`].
    pub uploads: UploadPath,
    /// How the atlas is zeroed before its first use (`--atlas-zero`). Default
    /// [`AtlasZero::Auto`].
    pub atlas_zero: AtlasZero,
    /// Worker threads loading bricks. Default: the machine's cores less one (at least one).
    /// Not in a view file: it is the machine's, not the view's.
    #[serde(skip)]
    pub workers: usize,
    /// The pixel footprint is multiplied by this before it picks a level: 1 takes the level
    /// whose voxel is no larger than a pixel's footprint, 2 one level coarser, 0 always the
    /// max level (no pixel LOD).
    pub lod_scale: f32,
    /// Load the neighbours of wanted bricks into RAM while nothing visible waits.
    pub prefetch: bool,
    /// Frames whose rays all want one level of at most 65 536 bricks, every brick of it in the
    /// atlas or drawn without it, walk that level's page-table entries copied flat (the bricks
    /// renderer's grid walk), and once a view lacks nothing the rest of such a level is loaded
    /// into free atlas slots (not over a network); off (`--no-level-walk`), every ray goes
    /// segment by segment through the hashed table and no level is loaded whole. The images
    /// are the same. Default on.
    pub level_walk: bool,
    /// A brick that failed to load (a dead server, a damaged chunk) is asked for again after
    /// this long, then after twice as long each time it fails again (at most 5 minutes): a
    /// view recovers when the server returns. Default 5 s. Not in a view file (the
    /// network's, not the view's).
    #[serde(skip)]
    pub retry_after: Duration,
}

impl Default for StreamOptions {
    fn default() -> Self {
        let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
        Self {
            gpu_memory: 1 << 30,
            ram_cache: 2 << 30,
            upload_bytes_per_frame: 256 << 20,
            uploads: UploadPath::Scatter,
            atlas_zero: AtlasZero::Auto,
            workers: cores.saturating_sub(1).max(1),
            lod_scale: 1.0,
            prefetch: true,
            level_walk: true,
            retry_after: Duration::from_secs(5),
        }
    }
}

/// How a frame's bricks reach the atlas.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum UploadPath {
    /// Through the staging ring (buffers mapped once), each brick whole after the last; two
    /// copies (placements, bricks) take them to the GPU and one compute dispatch writes them
    /// into their cells. A frame uploads no more than a ring buffer holds (16 MB).
    /// Where the device cannot write the atlas's texel format from a shader, as
    /// [`Self::Copies`].
    #[default]
    Scatter,
    /// Through the staging ring, one copy command per run of cells along x.
    Copies,
    /// A queue write per brick.
    Queue,
}

/// How the atlas is zeroed before its first use. The images are the same.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum AtlasZero {
    /// [`Self::Shader`] on a GPU, [`Self::Wgpu`] on a CPU's Vulkan (lavapipe), which stores
    /// texels from a shader more slowly than it copies them.
    #[default]
    Auto,
    /// The atlas is made without wgpu's zero fill (on Vulkan) and a compute pass writes 0 into
    /// every texel before the first uploads. Where the device is not Vulkan, or the uploads are
    /// not scattered ([`UploadPath::Scatter`]: no shader writes the atlas), as [`Self::Wgpu`].
    Shader,
    /// wgpu zeroes the atlas at its first use, with buffer copies slice by slice.
    Wgpu,
}
