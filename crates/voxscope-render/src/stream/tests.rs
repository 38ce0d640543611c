use std::collections::HashSet;

use super::*;
use crate::raycaster::raycast_params;
use crate::staging_ring::tests::read_atlas;
use crate::{Camera, RenderSettings};
use voxscope_stream::{Downsampling, ENTRY_VISIBLE, MemorySource};
use voxscope_volume::{Quantization, ValueWindow};

#[test]
fn walked_levels_cover_and_join_only_adjacent_levels() {
    let one = |level| WalkLevels { level, two: false };
    let two = |level| WalkLevels { level, two: true };
    for walk in [one(0), two(0), one(7), two(14)] {
        assert_eq!(WalkLevels::from_code(walk.code()), walk);
        assert!(walk.code() < NOT_DRAWN && walk.code() < NO_LEVEL);
    }
    assert!(two(3).covers(one(3)) && two(3).covers(one(4)) && two(3).covers(two(3)));
    assert!(!two(3).covers(one(5)) && !two(3).covers(two(4)) && !one(3).covers(two(3)));
    assert_eq!(one(3).union(one(4)), Some(two(3)));
    assert_eq!(one(4).union(two(3)), Some(two(3)));
    assert_eq!(one(3).union(one(3)), Some(one(3)));
    assert_eq!(one(3).union(one(5)), None);
    assert_eq!(two(3).union(one(5)), None);
}

/// The levels the rays of a frame of `params` want, from the nearest to the farthest point
/// any ray meets (`stream.wgsl`'s `wanted_level` at each pixel ray's entry and exit).
fn levels_rays_want(volume: &StreamVolume, params: &RaycastParams) -> Option<(u32, u32)> {
    let shape = volume.streamer.shape();
    let finest = shape.depth().saturating_sub(params.max_level) as usize;
    let per_t = params.lod_factor * volume.streamer.options().lod_scale;
    let wanted = |footprint: f32| wanted_level(shape, finest, footprint) as u32;
    let v = |a: [f32; 4]| glam::Vec3::new(a[0], a[1], a[2]);
    let [width, height] = params.image_size;
    let mut levels: Option<(u32, u32)> = None;
    for y in 0..height {
        for x in 0..width {
            let ndc_x = 2.0 * (x as f32 + 0.5) / width as f32 - 1.0;
            let ndc_y = 1.0 - 2.0 * (y as f32 + 0.5) / height as f32;
            let dir = v(params.forward) + ndc_x * v(params.right) + ndc_y * v(params.up);
            let length =
                (1.0 + (ndc_x * params.right[3]).powi(2) + (ndc_y * params.up[3]).powi(2)).sqrt();
            // The ray through the box [0, dims], from the eye on.
            let (mut enter, mut leave) = (0.0f32, f32::MAX);
            for axis in 0..3 {
                let (origin, step) = (params.eye[axis], dir[axis]);
                if step.abs() < 1e-12 {
                    if origin < 0.0 || origin > params.volume[axis] {
                        leave = -1.0;
                    }
                    continue;
                }
                let (a, b) = ((0.0 - origin) / step, (params.volume[axis] - origin) / step);
                enter = enter.max(a.min(b));
                leave = leave.min(a.max(b));
            }
            if enter >= leave {
                continue;
            }
            let (near, far) = (
                wanted(enter * length * per_t),
                wanted(leave * length * per_t),
            );
            levels = Some(levels.map_or((near, far), |(lo, hi)| (lo.min(near), hi.max(far))));
        }
    }
    levels
}

#[test]
fn the_levels_a_frame_walks_hold_every_level_its_rays_want() {
    let context = GpuContext::new_headless()
        .expect("a GPU adapter (lavapipe: mesa-vulkan-drivers, WGPU_BACKEND=vulkan)");
    // 256×192×96 voxels, twice as long along z: levels 0-3 of 32³ bricks and more.
    let dims = [256, 192, 96];
    let source = MemorySource::from_levels(
        "flat",
        vec![7; dims.iter().product()],
        dims,
        Quantization {
            offset: 0.0,
            step: 1.0,
        },
        [1.0, 1.0, 2.0],
        Downsampling::Mean,
    )
    .expect("a pyramid");
    let options = StreamOptions {
        gpu_memory: 16 << 20,
        ..StreamOptions::default()
    };
    let transfer = TransferFunction::gray(ValueWindow {
        low: 0.0,
        high: 10.0,
    });
    let volume = StreamVolume::new(&context, Arc::new(source), options, &transfer)
        .expect("a streaming volume");
    let (mut one, mut two, mut more) = (0, 0, 0);
    for distance in [0.45, 0.6, 0.8, 1.0, 1.5, 2.2, 3.0, 5.0, 9.0] {
        for (azimuth_deg, elevation_deg) in [(30.0, 20.0), (90.0, 0.0), (200.0, 60.0)] {
            for size in [[64, 48], [160, 120], [320, 240]] {
                for max_level in [volume.streamer.shape().depth(), 2] {
                    let camera = Camera {
                        distance,
                        azimuth_deg,
                        elevation_deg,
                        ..Camera::default()
                    };
                    let settings = RenderSettings {
                        max_level,
                        ..RenderSettings::full_detail(volume.streamer.shape().depth())
                    };
                    let params = raycast_params(&volume, size, &camera, &settings);
                    let case = format!("{distance} {azimuth_deg}/{elevation_deg} {size:?}");
                    let Some((lo, hi)) = levels_rays_want(&volume, &params) else {
                        continue;
                    };
                    match volume.walk_level(&params) {
                        Some(walk) => {
                            // Never a level a ray wants left out.
                            assert!(
                                walk.level <= lo && walk.last() >= hi,
                                "{case}: {walk:?} for rays wanting {lo}-{hi}"
                            );
                            if walk.two {
                                two += 1;
                            } else {
                                one += 1;
                            }
                        }
                        // Only where rays want more than two levels (or may: the corners'
                        // depths bound each ray's).
                        None => {
                            assert!(hi > lo, "{case}: no walk for rays wanting {lo}-{hi}");
                            more += 1;
                        }
                    }
                }
            }
        }
    }
    // Each kind of frame was met.
    assert!(
        one > 0 && two > 0 && more > 0,
        "{one} one-level, {two} two-level, {more} other frames"
    );
}

#[test]
fn an_atlas_made_without_wgpus_fill_reads_zero_wherever_the_first_step_put_no_brick() {
    let context = GpuContext::new_headless()
        .expect("a GPU adapter (lavapipe: mesa-vulkan-drivers, WGPU_BACKEND=vulkan)");
    // Value levels up to 251: an 8-bit atlas, one byte a texel.
    let dims = [96, 64, 40];
    let levels = (0..dims.iter().product::<usize>())
        .map(|i| (i % 251) as u16 + 1)
        .collect();
    let quantization = Quantization {
        offset: 0.0,
        step: 1.0,
    };
    let source = MemorySource::from_levels(
        "ramp",
        levels,
        dims,
        quantization,
        [1.0; 3],
        Downsampling::Mean,
    )
    .expect("a pyramid");
    let options = StreamOptions {
        gpu_memory: 8 << 20,
        atlas_zero: AtlasZero::Shader,
        ..StreamOptions::default()
    };
    let transfer = TransferFunction::gray(ValueWindow {
        low: 0.0,
        high: 252.0,
    });
    let mut volume = StreamVolume::new(&context, Arc::new(source), options, &transfer)
        .expect("a streaming volume");
    assert_eq!(
        volume.atlas_zero(),
        AtlasZero::Shader,
        "lavapipe is Vulkan and writes 8-bit texels from a shader"
    );
    // What the memory may hold: every texel written before the first step.
    let size = volume.atlas.size();
    let texels = (size.width * size.height * size.depth_or_array_layers) as usize;
    context.queue.write_texture(
        volume.atlas.as_image_copy(),
        &vec![0xa5u8; texels],
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(size.width),
            rows_per_image: Some(size.height),
        },
        size,
    );
    volume.step(&context);
    let atlas = read_atlas(&context, &volume.atlas, 1);
    let held: HashSet<u32> = (volume.streamer.table().entries().iter())
        .filter(|entry| entry.is_resident())
        .map(|entry| entry.slot & !ENTRY_VISIBLE)
        .collect();
    let [gx, gy, gz] = volume.atlas_grid;
    let slots = gx * gy * gz;
    assert!(
        !held.is_empty() && held.len() < slots,
        "{} of {slots} slots hold a brick",
        held.len()
    );
    let (width, height) = (size.width as usize, size.height as usize);
    for slot in (0..slots).filter(|&s| !held.contains(&(s as u32))) {
        let corner = [slot % gx, (slot / gx) % gy, slot / (gx * gy)].map(|c| c * PADDED_BRICK);
        for z in 0..PADDED_BRICK {
            for y in 0..PADDED_BRICK {
                let row = ((corner[2] + z) * height + corner[1] + y) * width + corner[0];
                assert!(
                    atlas[row..row + PADDED_BRICK].iter().all(|&t| t == 0),
                    "slot {slot} (no brick), row {y} of slice {z}: {:?}",
                    &atlas[row..row + PADDED_BRICK]
                );
            }
        }
    }
}
