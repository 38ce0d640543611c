//! What [`StreamVolume::allocate`] makes on the device besides the streamer: the atlas
//! texture (zeroed by wgpu or by a pass of its own) and the buffers of the page table, the
//! requests, the usage marks, the level copy and the readbacks.

use super::*;

/// Bytes of the flat copy of one level, or of one and the next coarser one, for the level walk
/// (`level_walk`): the largest such copy within [`LEVEL_WALK_BRICKS`] bricks; one entry where
/// none is (or without the walk).
pub(super) fn walked_level_cells_bytes(
    levels: &[voxscope_stream::LevelShape],
    level_walk: bool,
) -> u64 {
    (0..levels.len())
        .flat_map(|l| {
            let one = levels[l].brick_count();
            [
                Some(one),
                levels.get(l + 1).map(|next| one + next.brick_count()),
            ]
        })
        .flatten()
        .filter(|&bricks| level_walk && bricks <= LEVEL_WALK_BRICKS)
        .max()
        .unwrap_or(1)
        .max(1)
        * std::mem::size_of::<TableEntry>() as u64
}

/// The atlas of `grid` slots in `format`, storage-bound where the uploads are scattered
/// (`scatters`), and whether it was made without wgpu's zero fill (a pass of ours zeroes it).
pub(super) fn create_atlas(
    context: &GpuContext,
    grid: [usize; 3],
    format: wgpu::TextureFormat,
    scatters: bool,
    atlas_zero: AtlasZero,
) -> Result<(wgpu::Texture, bool), RenderError> {
    let device = &context.device;
    let size = wgpu::Extent3d {
        width: (grid[0] * PADDED_BRICK) as u32,
        height: (grid[1] * PADDED_BRICK) as u32,
        depth_or_array_layers: (grid[2] * PADDED_BRICK) as u32,
    };
    let atlas_desc = wgpu::TextureDescriptor {
        label: Some("voxscope::stream_atlas"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D3,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_DST
            | ATLAS_READ_BACK
            | if scatters {
                wgpu::TextureUsages::STORAGE_BINDING
            } else {
                wgpu::TextureUsages::empty()
            },
        view_formats: &[],
    };
    // Where the scatter pass can write the atlas, a GPU's atlas is made without wgpu's zero
    // fill and a pass zeroes it instead (`write`, before the first uploads). A CPU
    // (lavapipe) stores texels from a shader more slowly than it copies them (80 ms against
    // a few for 17 M texels), and its next submission waits for that: wgpu fills it there.
    let zeroes_itself = scatters
        && match atlas_zero {
            AtlasZero::Auto => context.adapter_info.device_type != wgpu::DeviceType::Cpu,
            AtlasZero::Shader => true,
            AtlasZero::Wgpu => false,
        };
    // SAFETY: no texel is read before the zero pass: every sample is of a brick the page
    // table (or its level copy) says is in the atlas, and the first `write` submits the
    // pass before its uploads, the first that put one there; the format is one the device
    // writes from a shader (`atlas_storage_formats`, as the scatter needs).
    let uncleared = if zeroes_itself {
        unsafe { uncleared_texture(device, &atlas_desc) }
    } else {
        None
    };
    match uncleared {
        Some(Ok(atlas)) => Ok((atlas, true)),
        Some(Err(OutOfMemory)) => Err(RenderError::DoesNotFit(
            "the GPU has no room for the streaming atlas: out of memory".to_owned(),
        )),
        None => Ok((device.create_texture(&atlas_desc), false)),
    }
}

/// The buffers a streamed volume's frames use besides the atlas.
pub(super) struct StreamBuffers {
    /// The page table's entries.
    pub table: wgpu::Buffer,
    /// The keys the rays ask for this frame (a count, then the keys and their set).
    pub requests: wgpu::Buffer,
    /// The frame each slot was last used in.
    pub usage: wgpu::Buffer,
    /// The flat copy of the walked level(s).
    pub level_cells: wgpu::Buffer,
    /// Where each frame's requests and usage marks are read back.
    pub readbacks: Vec<Readback>,
}

impl StreamBuffers {
    /// The buffers of a page table of `table_capacity` entries, an atlas of `slots` slots and
    /// a level copy of `level_cells_bytes`.
    pub fn new(
        device: &wgpu::Device,
        table_capacity: usize,
        slots: usize,
        level_cells_bytes: u64,
    ) -> Self {
        let table = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_page_table"),
            size: (table_capacity * std::mem::size_of::<TableEntry>()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let requests = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_requests"),
            size: (1 + REQUEST_CAPACITY as u64 + REQUEST_SET as u64) * 4,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let usage = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_usage"),
            size: slots as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let level_cells = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxscope::stream_level_cells"),
            size: level_cells_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let readback_bytes = (1 + REQUEST_CAPACITY as u64 + slots as u64) * 4;
        let readbacks = (0..READBACKS)
            .map(|_| Readback {
                buffer: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("voxscope::stream_readback"),
                    size: readback_bytes,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                frame: 0,
                state: Arc::new(AtomicU8::new(IDLE)),
            })
            .collect();
        Self {
            table,
            requests,
            usage,
            level_cells,
            readbacks,
        }
    }
}
