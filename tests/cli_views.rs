//! Showing a volume to others, through the real binary: `render --save-view` and `render --view`
//! reproduce each other, `movie --turntable` and `movie --keyframes` start (and end) at the
//! stills of their views (a composite's with each channel's color and window), every movie
//! format holds the frames drawn, and a still drawn in tiles equals the one drawn whole (the
//! streaming renderer's too).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use image::RgbaImage;

/// Small, asymmetric (a turn changes the picture) and quick to prepare.
const VOLUME: &str = "synthetic:noise:24x20x16";

fn voxscope(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Runs `args` and insists it succeeded.
fn run(args: &[&str]) -> String {
    let output = voxscope(args);
    let err = stderr(&output);
    assert!(output.status.success(), "{args:?}: {err}");
    err
}

fn text(path: &Path) -> &str {
    path.to_str().expect("a UTF-8 temporary path")
}

fn png(path: &Path) -> RgbaImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgba8()
}

/// A still of VOLUME at 64x48 with `extra` options, written to `dir/name`.
fn still(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let mut args = vec!["render", VOLUME, "--size", "64x48", "-o", text(&out)];
    args.extend_from_slice(extra);
    run(&args);
    out
}

/// Numbered PNGs of a movie written to a folder.
fn frames(folder: &Path) -> Vec<RgbaImage> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(folder)
        .expect("the folder exists")
        .map(|entry| entry.expect("an entry").path())
        .collect();
    names.sort();
    names.iter().map(|path| png(path)).collect()
}

#[test]
fn save_view_then_view_reproduces_the_render_exactly_and_options_beside_it_win() {
    let dir = tempfile::tempdir().unwrap();
    let view = dir.path().join("view.ron");
    let options = [
        "--azimuth",
        "63",
        "--elevation=-12",
        "--distance",
        "2.5",
        "--opacity-points",
        "0.2:0,0.7:0.8",
        "--colormap",
        "viridis",
        "--clip-box",
        "0:0.8,0.1:1,0:1",
        "--ambient",
        "0.3",
        "--save-view",
        text(&view),
    ];
    let first = still(dir.path(), "first.png", &options);
    let again = dir.path().join("again.png");
    // No volume and no options: all of it comes from the view.
    run(&["render", "--view", text(&view), "-o", text(&again)]);
    assert_eq!(png(&first), png(&again), "the view reproduces its render");
    let written = std::fs::read_to_string(&view).unwrap();
    assert!(written.contains(VOLUME), "{written}");

    let turned = dir.path().join("turned.png");
    run(&[
        "render",
        "--view",
        text(&view),
        "--azimuth",
        "150",
        "-o",
        text(&turned),
    ]);
    let mut direct_options = options[..options.len() - 2].to_vec();
    direct_options[1] = "150";
    let direct = still(dir.path(), "direct.png", &direct_options);
    assert_ne!(png(&turned), png(&first), "--azimuth beside --view wins");
    assert_eq!(png(&turned), png(&direct));
}

/// A view file of version 1 (written before views were the options model) draws what the
/// options that wrote it draw (tests/data/views/README.md lists them).
#[test]
fn a_version_1_view_draws_what_its_options_drew() {
    let dir = tempfile::tempdir().unwrap();
    for (view, options) in [
        (
            "tests/data/views/v1-head.ron",
            "../shared/data/mri-head-128x128x62.nii.gz --size 96x72 --azimuth 63 --elevation=-12 --distance 2.5 --opacity-points 0.2:0,0.7:0.8 --colormap viridis --clip-box 0:0.8,0.1:1,0:1 --ambient 0.3 --mode dvr --level 5",
        ),
        (
            "tests/data/views/v1-two-channels.ron",
            "tests/data/channels/two-channels.ome.tif --size 80x64 --azimuth 40 --channel-colors magenta,#00ff00 --channel-window 1:10:200 --mode mip",
        ),
    ] {
        let from_view = dir.path().join("from-view.png");
        run(&["render", "--view", view, "-o", text(&from_view)]);
        let direct = dir.path().join("direct.png");
        let mut args = vec!["render", "-o", text(&direct)];
        args.extend(options.split(' '));
        run(&args);
        assert_eq!(png(&from_view), png(&direct), "{view}");
    }
}

/// A channel hidden in a view (the app's eye toggle) stays hidden where the command line
/// draws the view, and the view it saves again says so.
#[test]
fn a_hidden_channel_of_a_view_is_not_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let shown = dir.path().join("shown.ron");
    let both = dir.path().join("both.png");
    run(&[
        "render",
        "tests/data/channels/two-channels.ome.tif",
        "--size",
        "48x40",
        "--channel-colors",
        "magenta,green",
        "--mode",
        "mip",
        "--save-view",
        text(&shown),
        "-o",
        text(&both),
    ]);
    let written = std::fs::read_to_string(&shown).unwrap();
    assert!(written.contains("hidden: []"), "{written}");
    let hidden = dir.path().join("hidden.ron");
    std::fs::write(&hidden, written.replace("hidden: []", "hidden: [0]")).unwrap();
    let green = dir.path().join("green.png");
    let again = dir.path().join("again.ron");
    run(&[
        "render",
        "--view",
        text(&hidden),
        "--save-view",
        text(&again),
        "-o",
        text(&green),
    ]);
    let (both, green) = (png(&both), png(&green));
    assert!(both != green, "hiding a channel changes the image");
    let red = |image: &RgbaImage| image.pixels().map(|p| u64::from(p[0])).sum::<u64>();
    assert!(
        red(&both) > 0,
        "magenta shows in the image of both channels"
    );
    assert_eq!(red(&green), 0, "no magenta where channel 0 is hidden");
    let resaved = voxscope_scene::SavedView::read(&again).expect("render saved its view");
    assert_eq!(resaved.draw.channels.hidden, vec![0]);
    // The composite marches voxels: the view keeps the level asked for (none: the deepest),
    // not the composite's own 0, for a renderer of one channel that opens it.
    assert_eq!(resaved.draw.transfer.level, None);
}

#[test]
fn a_malformed_view_or_one_whose_data_is_missing_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let bad = dir.path().join("bad.ron");
    std::fs::write(&bad, "(version: 1, camera: (azimuth_deg: ").unwrap();
    let missing = dir.path().join("missing.ron");
    std::fs::write(
        &missing,
        "(version: 2, open: (source: Some(\"no/such/head.nii.gz\")))",
    )
    .unwrap();
    let newer = dir.path().join("newer.ron");
    std::fs::write(&newer, "(version: 99)").unwrap();
    for (view, expected) in [
        (&bad, "not a voxscope view file"),
        (&missing, "its data no/such/head.nii.gz does not exist"),
        (&newer, "a newer voxscope wrote it"),
    ] {
        let output = voxscope(&["render", "--view", text(view), "-o", text(&out)]);
        let err = stderr(&output);
        assert_eq!(output.status.code(), Some(1), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(text(view)) && err.contains(expected), "{err}");
    }
    assert!(!out.exists());
}

#[test]
fn a_turntable_starts_at_the_still_and_every_frame_turns() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("turn");
    let err = run(&[
        "movie",
        VOLUME,
        "--turntable",
        "--frames",
        "12",
        "--azimuth",
        "40",
        "--size",
        "64x48",
        "-o",
        text(&folder),
    ]);
    assert!(err.contains("frames/s written"), "{err}");
    let movie = frames(&folder);
    assert_eq!(movie.len(), 12);
    let start = still(dir.path(), "start.png", &["--azimuth", "40"]);
    assert_eq!(movie[0], png(&start), "the first frame is the still");
    let quarter = still(dir.path(), "quarter.png", &["--azimuth", "130"]);
    assert_eq!(
        movie[3],
        png(&quarter),
        "frame 3 of 12 is a quarter turn on"
    );
    for (index, pair) in movie.windows(2).enumerate() {
        assert_ne!(pair[0], pair[1], "frames {index} and {} differ", index + 1);
    }
}

#[test]
fn a_keyframe_movie_starts_at_its_first_view_and_ends_at_its_last() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.ron"), dir.path().join("b.ron"));
    let first = still(
        dir.path(),
        "a.png",
        &[
            "--azimuth",
            "10",
            "--window",
            "0:0.8",
            "--save-view",
            text(&a),
        ],
    );
    let last = still(
        dir.path(),
        "b.png",
        &[
            "--azimuth",
            "100",
            "--distance",
            "2",
            "--window",
            "0.3:1",
            "--save-view",
            text(&b),
        ],
    );
    let folder = dir.path().join("path");
    let keyframes = format!("{},{}", text(&a), text(&b));
    run(&[
        "movie",
        "--keyframes",
        &keyframes,
        "--frames",
        "3",
        "-o",
        text(&folder),
    ]);
    let movie = frames(&folder);
    assert_eq!(
        movie.len(),
        4,
        "3 frames of the segment, then the last view"
    );
    assert_eq!(movie[0], png(&first));
    assert_eq!(movie[3], png(&last));
    assert!(movie[1] != movie[0] && movie[1] != movie[3] && movie[2] != movie[1]);
}

/// Two stills of `render BASE… --size 32x24`, with `first`'s and `last`'s options beside, each
/// saving its view; then the movie through those two views in 2 frames a segment: the stills
/// and the movie's frames.
fn keyframe_movie(
    base: &[&str],
    first: &[&str],
    last: &[&str],
) -> (RgbaImage, RgbaImage, Vec<RgbaImage>) {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.ron"), dir.path().join("b.ron"));
    let draw = |name: &str, view: &Path, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec!["render"];
        args.extend_from_slice(base);
        args.extend_from_slice(&["--size", "32x24", "-o", text(&out)]);
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--save-view", text(view)]);
        run(&args);
        png(&out)
    };
    let first = draw("a.png", &a, first);
    let last = draw("b.png", &b, last);
    let folder = dir.path().join("path");
    let keyframes = format!("{},{}", text(&a), text(&b));
    run(&[
        "movie",
        "--keyframes",
        &keyframes,
        "--frames",
        "2",
        "-o",
        text(&folder),
    ]);
    (first, last, frames(&folder))
}

#[test]
fn a_composite_keyframe_movie_follows_each_channels_window_and_color() {
    let (first, last, movie) = keyframe_movie(
        &["tests/data/channels/hyperstack.tif"],
        &["--channel-window", "1:0:1700"],
        &[
            "--azimuth",
            "80",
            "--channel-window",
            "1:0:300",
            "--channel-colors",
            "cyan,red",
        ],
    );
    assert_eq!(movie.len(), 3);
    assert_eq!(movie[0], first, "starts with the first view's channels");
    assert_eq!(movie[2], last, "ends with the last view's channels");
    assert!(movie[1] != first && movie[1] != last);
}

/// Keyframes of a streamed composite of chosen channels (the nine-channel store's 1 and 8) keep
/// their windows by the file's channel numbers: the movie ends on the last view's channels.
#[test]
fn keyframes_of_a_streamed_composite_apply_their_channels_by_file_number() {
    let (first, last, movie) = keyframe_movie(
        &[
            "tests/data/ome-zarr/channels9-v05-sharded.ome.zarr",
            "--renderer",
            "stream",
            "--channels",
            "1,8",
            "--lod-scale",
            "0",
        ],
        &[],
        &["--azimuth", "80", "--channel-window", "8:0:9000"],
    );
    assert_eq!(movie.len(), 3);
    assert!(movie[0] == first, "starts with the first view's channels");
    assert!(
        movie[2] == last,
        "ends with channel 8's window of the last view"
    );
}

#[test]
fn gif_webp_and_apng_hold_every_frame_and_mp4_without_ffmpeg_says_how_to_get_it() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("frames");
    let movie = |out: &Path| {
        run(&[
            "movie",
            VOLUME,
            "--turntable",
            "--frames",
            "3",
            "--size",
            "64x48",
            "-o",
            text(out),
        ])
    };
    movie(&folder);
    let pngs = frames(&folder);

    let webp = dir.path().join("m.webp");
    movie(&webp);
    let mut decoder =
        image_webp::WebPDecoder::new(std::io::BufReader::new(std::fs::File::open(&webp).unwrap()))
            .expect("a WebP");
    assert!(decoder.is_animated());
    assert_eq!(decoder.num_frames(), 3);
    for expected in &pngs {
        let mut buffer = vec![0; decoder.output_buffer_size().unwrap()];
        decoder.read_frame(&mut buffer).expect("a frame");
        // Lossless: the frame drawn, pixel for pixel (opaque, so RGB or RGBA alike).
        let rgb: Vec<u8> = expected.pixels().flat_map(|p| [p[0], p[1], p[2]]).collect();
        let decoded: Vec<u8> = if decoder.has_alpha() {
            buffer.chunks(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
        } else {
            buffer
        };
        assert_eq!(decoded, rgb);
    }

    let apng = dir.path().join("m.png");
    movie(&apng);
    let reader = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&apng).unwrap()))
        .read_info()
        .expect("a PNG");
    let animation = reader.info().animation_control.expect("an animated PNG");
    assert_eq!(animation.num_frames, 3);
    assert_eq!(png(&apng), pngs[0], "the default image is the first frame");

    let gif_path = dir.path().join("m.gif");
    movie(&gif_path);
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = options
        .read_info(std::fs::File::open(&gif_path).unwrap())
        .expect("a GIF");
    let mut count = 0;
    while let Some(frame) = decoder.read_next_frame().expect("a frame") {
        assert_eq!((frame.width, frame.height), (64, 48));
        count += 1;
    }
    assert_eq!(count, 3);

    // MP4 without ffmpeg on the PATH: one line, before anything is drawn.
    let mp4 = dir.path().join("m.mp4");
    let output = Command::new(env!("CARGO_BIN_EXE_voxscope"))
        .args(["movie", VOLUME, "--turntable", "-o", text(&mp4)])
        .env("PATH", dir.path())
        .output()
        .expect("the binary runs");
    let err = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("needs ffmpeg") && err.contains("apt install ffmpeg"),
        "{err}"
    );
    assert!(!mp4.exists());
}

#[test]
fn a_still_drawn_in_tiles_equals_the_one_drawn_whole() {
    let dir = tempfile::tempdir().unwrap();
    // 100x70 in tiles of 32: full tiles, a partial column and a partial row.
    for extra in [
        &["--pixel-lod"][..],
        &["--renderer", "dense"],
        &["--renderer", "bricks"],
        // Each tile refined until complete before it is read.
        &["--renderer", "stream"],
    ] {
        let draw = |name: &str, tiles: &[&str]| {
            let out = dir.path().join(name);
            let mut args = vec!["render", VOLUME, "--size", "100x70", "-o", text(&out)];
            args.extend_from_slice(extra);
            args.extend_from_slice(tiles);
            (run(&args), png(&out))
        };
        let (_, whole) = draw("whole.png", &[]);
        let (err, tiled) = draw("tiled.png", &["--tile-size", "32"]);
        assert!(err.contains("drawn in tiles of 32x32"), "{err}");
        assert_eq!(tiled, whole, "{extra:?}");
        assert!(
            support_coverage(&whole) > 0.05,
            "{extra:?}: the volume is drawn"
        );
    }
}

/// The share of pixels that are not the background.
fn support_coverage(image: &RgbaImage) -> f64 {
    let corner = *image.get_pixel(0, 0);
    image.pixels().filter(|p| **p != corner).count() as f64 / image.pixels().len() as f64
}
