use super::*;
use crate::readback::read_buffer;
use crate::uncleared_texture::uncleared_texture;

fn cell(x: u32, y: u32, z: u32) -> wgpu::Origin3d {
    let side = PADDED_BRICK as u32;
    wgpu::Origin3d {
        x: x * side,
        y: y * side,
        z: z * side,
    }
}

#[test]
fn runs_are_cells_that_follow_each_other_along_x_within_the_buffer() {
    let side = PADDED_BRICK as u32;
    let row_bytes = 2 * PADDED_BRICK;
    // Given out of order: cells 0–4 of row (0, 0), cell 7 of it, cell 1 of row (1, 0)
    // and cell 0 of slice 1.
    let origins = [
        cell(3, 0, 0),
        cell(0, 0, 1),
        cell(1, 0, 0),
        cell(7, 0, 0),
        cell(0, 0, 0),
        cell(1, 1, 0),
        cell(2, 0, 0),
        cell(4, 0, 0),
    ];
    let (runs, staged) = plan_runs(&origins, side, row_bytes, MAX_BUFFER_BYTES);
    // x 0–4, then 7, row y = 1, slice z = 1.
    assert_eq!(runs, vec![vec![4, 2, 6, 0, 7], vec![3], vec![5], vec![1]]);
    assert!(staged.iter().all(|&s| s));
    // Five bricks' rows (340 bytes) take two of a copy's 256-byte rows: with room for four
    // such, the run and one more; the last two cells wait for the queue.
    let (runs, staged) = plan_runs(&origins, side, row_bytes, 4 * run_bytes(1, row_bytes));
    assert_eq!(runs, vec![vec![4, 2, 6, 0, 7], vec![3], vec![5]]);
    assert_eq!(
        staged,
        vec![true, false, true, true, true, true, true, true]
    );
    // Room for one brick: the first cell alone.
    let (runs, _) = plan_runs(&origins, side, row_bytes, run_bytes(1, row_bytes));
    assert_eq!(runs, vec![vec![4, 2, 6]]);
}

#[test]
fn a_runs_rows_are_the_rows_of_its_box_in_the_atlas() {
    for bytes_per_texel in [1, 2, 4] {
        let row_bytes = PADDED_BRICK * bytes_per_texel;
        for count in [1, 3, 8] {
            let pitch = run_pitch(count, row_bytes);
            assert_eq!(pitch % 256, 0);
            assert!(pitch >= count * row_bytes && pitch < count * row_bytes + 256);
            let bricks: Vec<Vec<u8>> = (0..count)
                .map(|brick| {
                    (0..PADDED_BRICK * PADDED_BRICK * row_bytes)
                        .map(|byte| (byte * 7 + brick * 31) as u8)
                        .collect()
                })
                .collect();
            let texels: Vec<&[u8]> = bricks.iter().map(|b| b.as_slice()).collect();
            let mut rows = vec![0u8; run_bytes(count, row_bytes)];
            write_run(&mut rows, &texels, row_bytes, pitch);
            // The copy reads row r (y and z of the box) as `count × row_bytes` bytes at
            // r × pitch: brick i's row r, for i in order.
            for row in 0..PADDED_BRICK * PADDED_BRICK {
                let read = &rows[row * pitch..row * pitch + count * row_bytes];
                for (index, brick) in bricks.iter().enumerate() {
                    assert_eq!(
                        &read[index * row_bytes..(index + 1) * row_bytes],
                        &brick[row * row_bytes..(row + 1) * row_bytes],
                        "row {row} of brick {index} of {count}, {bytes_per_texel}-byte texels"
                    );
                }
            }
        }
    }
}

#[test]
fn a_scattering_ring_holds_a_frame_within_its_bound_and_its_share_of_the_budget() {
    let brick = PADDED_BRICK * PADDED_BRICK * PADDED_BRICK; // 8-bit texels
    // 512 MiB: the bound (16 MB) holds 426 bricks behind their placements.
    let (bricks, bytes) = scatter_size(10_000, brick, 512 << 20).expect("room");
    assert_eq!(bricks, 426);
    assert_eq!(bytes as usize, whole_bytes(426, brick));
    assert!(bytes as usize <= MAX_SCATTER_BYTES);
    assert!(whole_bytes(427, brick) > MAX_SCATTER_BYTES);
    // A frame's own allowance of bricks, when smaller.
    assert_eq!(scatter_size(100, brick, 512 << 20).map(|s| s.0), Some(100));
    // 16 MiB: a sixteenth, 1 MiB, holds 26.
    assert_eq!(scatter_size(10_000, brick, 16 << 20).map(|s| s.0), Some(26));
    // Not one brick in a sixteenth of 512 KiB: the ring copies instead.
    assert_eq!(scatter_size(10_000, brick, 512 << 10), None);
}

/// A brick of `bytes_per_texel` texels numbered by `seed`: every byte differs from its
/// neighbours and from other seeds' bricks; 16-bit texels are finite half floats (normal
/// and subnormal), so each format stores them as they are.
fn numbered_brick(seed: usize, bytes_per_texel: usize) -> Vec<u8> {
    let texels = PADDED_BRICK * PADDED_BRICK * PADDED_BRICK;
    let mut bytes = Vec::with_capacity(texels * bytes_per_texel);
    for texel in 0..texels {
        let n = (texel * 2654435761 + seed * 40503) as u32;
        match bytes_per_texel {
            1 => bytes.push((n >> 13) as u8),
            _ => {
                // Exponent 0–30 (31 is infinity and NaN), any sign and mantissa.
                let half = (((n >> 7) as u16) % (31 << 10)) | ((n as u16) & 0x8000);
                bytes.extend_from_slice(&half.to_le_bytes());
            }
        }
    }
    bytes
}

/// The atlas's texels, as `format`'s bytes, x fastest.
pub(crate) fn read_atlas(
    context: &GpuContext,
    atlas: &wgpu::Texture,
    bytes_per_texel: usize,
) -> Vec<u8> {
    let size = atlas.size();
    let row = size.width as usize * bytes_per_texel;
    let pitch = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize);
    let rows = (size.height * size.depth_or_array_layers) as usize;
    let buffer = context.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("test_atlas_copy"),
        size: (pitch * rows) as u64,
        usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    encoder.copy_texture_to_buffer(
        atlas.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(pitch as u32),
                rows_per_image: Some(size.height),
            },
        },
        size,
    );
    context.queue.submit([encoder.finish()]);
    let padded = read_buffer(context, &buffer, buffer.size()).expect("atlas read back");
    padded
        .chunks_exact(pitch)
        .flat_map(|r| &r[..row])
        .copied()
        .collect()
}

#[test]
fn scattered_and_copied_bricks_land_in_their_cells_bit_for_bit_the_rest_zeroed() {
    let context = GpuContext::new_headless()
        .expect("a GPU adapter (lavapipe: mesa-vulkan-drivers, WGPU_BACKEND=vulkan)");
    let side = PADDED_BRICK as u32;
    // Height and depth differ: a dispatch that swapped them would leave texels unwritten.
    let grid = [3u32, 3, 2];
    // Five frames through the three buffers (the first two mapped again and written a
    // second time): five bricks (three cells in a run along x); one over a cell the first
    // filled, while the GPU's staging still holds the first frame's later placements (a
    // dispatch over more than this frame's bricks would write them again); then more,
    // over cells already filled.
    let frames: [&[(usize, [u32; 3])]; 5] = [
        &[
            (0, [1, 0, 0]),
            (1, [0, 1, 1]),
            (2, [0, 0, 0]),
            (3, [2, 1, 0]),
            (4, [2, 0, 0]),
        ],
        &[(5, [0, 1, 1])],
        &[(6, [1, 1, 1]), (7, [2, 0, 0])],
        &[(8, [0, 0, 0])],
        &[(9, [1, 0, 0]), (10, [2, 1, 1]), (11, [1, 1, 1])],
    ];
    for (format, bytes_per_texel) in [
        (wgpu::TextureFormat::R8Unorm, 1),
        (wgpu::TextureFormat::R16Unorm, 2),
        (wgpu::TextureFormat::R16Float, 2),
    ] {
        if format == wgpu::TextureFormat::R16Unorm && !context.has_norm16_textures {
            // No atlas of this device has this format (16-bit values go as half floats).
            continue;
        }
        let scatter = context
            .atlas_scatter(format)
            .unwrap_or_else(|| panic!("{format:?}: the device cannot write it from a shader"));
        let size = wgpu::Extent3d {
            width: grid[0] * side,
            height: grid[1] * side,
            depth_or_array_layers: grid[2] * side,
        };
        // What the atlas holds after both frames.
        let row = size.width as usize * bytes_per_texel;
        let mut expected = vec![0u8; row * (size.height * size.depth_or_array_layers) as usize];
        let bricks: Vec<Vec<u8>> = (0..12)
            .map(|seed| numbered_brick(seed, bytes_per_texel))
            .collect();
        for &(seed, cell) in frames.iter().flat_map(|f| f.iter()) {
            let brick_row = PADDED_BRICK * bytes_per_texel;
            for (r, texels) in bricks[seed].chunks_exact(brick_row).enumerate() {
                let y = cell[1] as usize * PADDED_BRICK + r % PADDED_BRICK;
                let z = cell[2] as usize * PADDED_BRICK + r / PADDED_BRICK;
                let at = (z * size.height as usize + y) * row + cell[0] as usize * brick_row;
                expected[at..at + brick_row].copy_from_slice(texels);
            }
        }
        eprintln!("{format:?}: {} bytes checked", expected.len());
        for scattering in [true, false] {
            let desc = wgpu::TextureDescriptor {
                label: Some("test_atlas"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format,
                usage: wgpu::TextureUsages::COPY_DST
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::STORAGE_BINDING,
                view_formats: &[],
            };
            // A scattering ring's atlas is made as the stream renderer makes it on Vulkan,
            // without wgpu's zero fill; the bytes it may hold are written first, then the
            // ring's pass zeroes them, and the cells no frame fills must read 0.
            // SAFETY: every texel is written (by the queue) before anything reads it.
            let atlas =
                match scattering.then(|| unsafe { uncleared_texture(&context.device, &desc) }) {
                    Some(Some(made)) => made.expect("room for a test atlas"),
                    Some(None) => {
                        assert_ne!(
                            context.adapter_info.backend,
                            wgpu::Backend::Vulkan,
                            "a Vulkan device makes the atlas without wgpu's zero fill"
                        );
                        context.device.create_texture(&desc)
                    }
                    None => context.device.create_texture(&desc),
                };
            let mut ring = if scattering {
                let garbage = vec![0xa5u8; expected.len()];
                context.queue.write_texture(
                    atlas.as_image_copy(),
                    &garbage,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row as u32),
                        rows_per_image: Some(size.height),
                    },
                    size,
                );
                let ring =
                    StagingRing::scattering(&context, 8, bytes_per_texel as u32, &atlas, scatter);
                let mut encoder = context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
                assert!(ring.zero_atlas(&mut encoder));
                context.queue.submit([encoder.finish()]);
                ring
            } else {
                StagingRing::new(&context, 8, bytes_per_texel as u32)
            };
            for frame in frames {
                // Wait for the ring's next buffer to be mapped again (the app never does:
                // it writes through the queue meanwhile).
                context.wait_idle().expect("GPU");
                let staged: Vec<StagedBrick<'_>> = frame
                    .iter()
                    .map(|&(seed, cell)| StagedBrick {
                        texels: &bricks[seed],
                        origin: wgpu::Origin3d {
                            x: cell[0] * side,
                            y: cell[1] * side,
                            z: cell[2] * side,
                        },
                    })
                    .collect();
                let mut encoder = context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
                let done = ring.stage(&mut encoder, &atlas, &staged);
                assert!(
                    done.staged.len() == frame.len() && done.staged.iter().all(|&s| s),
                    "{format:?}, scattering {scattering}: {:?}",
                    done.staged
                );
                assert_eq!(done.dispatches, scattering as usize);
                context.queue.submit([encoder.finish()]);
                ring.submitted();
            }
            let atlas_bytes = read_atlas(&context, &atlas, bytes_per_texel);
            let wrong = atlas_bytes.iter().zip(&expected).position(|(a, b)| a != b);
            assert!(
                wrong.is_none(),
                "{format:?}, scattering {scattering}: byte {wrong:?} of the atlas differs"
            );
        }
    }
}
