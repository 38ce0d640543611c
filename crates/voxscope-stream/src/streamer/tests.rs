use super::*;
use crate::NoiseSource;

/// A streamer of 128³ noise into 8³ slots with one loader and `ram_cache` bytes of RAM,
/// nothing read yet.
fn noise_streamer(ram_cache: u64) -> Streamer {
    let source = Arc::new(NoiseSource::new("noise", [128, 128, 128]).expect("a source"));
    let options = StreamOptions {
        workers: 1,
        ram_cache,
        ..StreamOptions::default()
    };
    Streamer::new(
        source,
        [8, 8, 8],
        AtlasTexels::Unorm16,
        options,
        vec![0; (1 << 16) + 1],
    )
    .expect("a streamer")
}

#[test]
fn the_pinned_levels_are_read_once_and_the_ram_budget_shared_then() {
    let mut streamer = noise_streamer(64 << 20);
    assert_eq!(
        streamer.pinned_slots(),
        0,
        "nothing read before load_pinned"
    );
    assert_eq!(streamer.counters.ram_capacity, 0);
    let uploads = streamer.load_pinned().expect("the pinned levels");
    let pinned = streamer.pinned_slots();
    assert!(
        pinned > 0 && uploads.len() == pinned,
        "{pinned} slots, {} uploads",
        uploads.len()
    );
    assert_eq!(
        streamer.counters.ram_capacity + streamer.counters.source_cache_capacity,
        64 << 20
    );
    // Again: nothing more read or pinned.
    assert!(streamer.load_pinned().expect("no error").is_empty());
    assert_eq!(streamer.pinned_slots(), pinned);
}

#[test]
fn the_upload_allowance_counts_the_gpus_copies_with_the_cpus_staging() {
    let mut streamer = noise_streamer(StreamOptions::default().ram_cache);
    streamer.load_pinned().expect("the pinned levels");
    let megabyte = 1u64 << 20;
    // The CPU: 1 ms a megabyte.
    streamer.set_upload_cost(megabyte, 0.001, &UploadParts::default());
    let cpu_only = streamer.counters.upload_allowance;
    let expected = UPLOAD_SECONDS_PER_FRAME / 0.001 * megabyte as f64;
    assert!(
        (cpu_only as f64 - expected).abs() < 2.0,
        "{cpu_only} ≠ {expected}"
    );
    // The GPU's copies take as long again: half the bytes fit.
    streamer.set_upload_gpu_cost(2 * megabyte, 0.002);
    let both = streamer.counters.upload_allowance;
    assert!(
        (both as f64 - expected / 2.0).abs() < 2.0,
        "{both} ≠ {}",
        expected / 2.0
    );
    let parts = streamer.counters.upload_parts;
    assert_eq!(
        (parts.copy_timed_bytes, parts.copy_gpu_seconds),
        (2 * megabyte, 0.002)
    );
    // A copy the GPU did not time leaves the allowance as it was.
    streamer.set_upload_gpu_cost(megabyte, 0.0);
    assert_eq!(streamer.counters.upload_allowance, both);
    // While the view moves, a frame uploads that much; while it stands still, twice that.
    let view = |x: f64| ViewPoint::new([x, 0.0, -3.0], [0.0, 0.0, 1.0]);
    streamer.begin_frame(None, Some(view(0.0)));
    streamer.begin_frame(None, Some(view(0.1)));
    assert_eq!(streamer.upload_allowance(), both);
    streamer.begin_frame(None, Some(view(0.1)));
    let still = (both as f64 * UPLOAD_SECONDS_STILL / UPLOAD_SECONDS_PER_FRAME) as u64;
    assert_eq!(streamer.upload_allowance(), still);
    // Frames no one watches: all that is ready while still (within the upload budget),
    // as much as ever while moving.
    assert_eq!(
        streamer.set_still_uploads(StillUploads::AllReady),
        StillUploads::Paced
    );
    assert_eq!(
        streamer.upload_allowance(),
        streamer.options().upload_bytes_per_frame
    );
    streamer.begin_frame(None, Some(view(0.2)));
    assert_eq!(streamer.upload_allowance(), both);
    streamer.begin_frame(None, Some(view(0.2)));
    streamer.set_still_uploads(StillUploads::Paced);
    // Never more than the renderer's staging holds at once, and never less than a brick.
    streamer.set_upload_ceiling(both / 3);
    assert_eq!(streamer.upload_allowance(), both / 3);
    streamer.set_upload_ceiling(1);
    assert_eq!(streamer.upload_allowance(), streamer.counters.slot_bytes);
}

/// A streamer of `dims` of mostly zeros (one corner brick of a ramp) in an atlas of
/// `cells` slots, level 0 copied flat as the renderer copies the level its rays all want.
fn sparse_streamer(dims: usize, cells: [usize; 3]) -> Streamer {
    let mut values = vec![0u16; dims * dims * dims];
    for z in 0..32 {
        for y in 0..32 {
            for x in 0..32 {
                values[x + dims * (y + dims * z)] = (x * 100) as u16;
            }
        }
    }
    let quantization = voxscope_volume::Quantization {
        offset: 0.0,
        step: 1.0,
    };
    let source = crate::MemorySource::from_levels(
        "sparse",
        values,
        [dims; 3],
        quantization,
        [1.0; 3],
        crate::Downsampling::Mean,
    )
    .expect("a source");
    let options = StreamOptions {
        workers: 1,
        prefetch: false,
        ..StreamOptions::default()
    };
    let every_level_visible = (0..=(1u32 << 16)).collect();
    let mut streamer = Streamer::new(
        Arc::new(source),
        cells,
        AtlasTexels::Unorm16,
        options,
        every_level_visible,
    )
    .expect("a streamer");
    streamer.load_pinned().expect("the pinned levels");
    let bricks = streamer.shape.levels[0].brick_count() as usize;
    streamer.table_mut().copy_level(Some((0, [bricks, 0])));
    streamer
}

/// One update with a readback of the frame before, whose rays asked for `requests`.
fn step_with(streamer: &mut Streamer, requests: &[u32]) -> StreamStatus {
    let usage = vec![0u32; streamer.slots.capacity()];
    let feedback = Feedback {
        frame: streamer.frame(),
        requests,
        asked: requests.len() as u32,
        usage: &usage,
        max_projection: false,
    };
    streamer.begin_frame(Some(feedback), None).1
}

#[test]
fn the_level_fill_completes_without_readbacks_and_never_outgrows_the_page_table() {
    // 128³: level 0 has 64 bricks, 63 of them zeros; 128 slots hold them. One readback
    // that asks for nothing chooses the fill; later updates without readbacks (a window
    // that draws nothing new) place it as its loads arrive.
    let mut streamer = sparse_streamer(128, [8, 4, 4]);
    step_with(&mut streamer, &[]);
    assert_eq!(streamer.fill.len(), 64, "every brick of level 0 chosen");
    let started = Instant::now();
    loop {
        let (_, status) = streamer.begin_frame(None, None);
        if status.filling == 0 {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the fill stalled: {status:?}"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    assert_eq!(streamer.table().level_unwalkable(false), Some(0));
    assert_eq!(
        streamer.resident_keys().count(),
        1 + streamer.slots.pinned()
    );

    // 256³ in 120 slots: the table keeps 480 entries, level 0 has 512 bricks, nearly all
    // uniform (entries without slots). Once a view has made the table hold what it can,
    // no fill starts: it would drop entries the table holds to make room for others.
    let mut streamer = sparse_streamer(256, [10, 12, 1]);
    let keys: Vec<u32> = (0..512).collect();
    let started = Instant::now();
    while streamer.table.len() + 8 < streamer.max_entries {
        for batch in keys.chunks(64) {
            step_with(&mut streamer, batch);
        }
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the table never filled: {} entries",
            streamer.table.len()
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    for _ in 0..20 {
        let status = step_with(&mut streamer, &[]);
        assert_eq!(status.filling, 0, "no fill beyond the table's room");
        std::thread::sleep(Duration::from_millis(2));
    }
}
