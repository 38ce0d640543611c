use voxscope_octree::{Colormap, OpacityMode};
use voxscope_render::{Camera, RendererKind};

use super::*;
use crate::ChannelChoice;

#[test]
fn a_view_round_trips_and_a_file_with_few_fields_loads_with_defaults() {
    let view = SavedView {
        open: OpenOptions {
            source: Some("head.nii.gz".into()),
            time: 2,
            channel: Some(ChannelChoice::All),
            raw: Some(voxscope_volume::RawLayout::parse("8x9x10:i16:be").expect("a layout")),
            ..OpenOptions::default()
        },
        draw: DrawOptions {
            camera: Camera {
                azimuth_deg: 75.5,
                ..Camera::default()
            },
            size: (64, 48),
            ..DrawOptions::default()
        },
        rulers: vec![ViewRuler {
            from: [1.0, 2.0, 3.0],
            to: [4.0, 5.0, 6.0],
        }],
        ..SavedView::default()
    };
    let text =
        ron::ser::to_string_pretty(&view, ron::ser::PrettyConfig::default()).expect("encodes");
    assert!(text.contains("channel: Some(\"all\")"), "{text}");
    assert!(text.contains("raw: Some(\"8x9x10:i16:be\")"), "{text}");
    assert_eq!(SavedView::parse(&text), Ok(view));
    let few = SavedView::parse("(version: 2, draw: (camera: (azimuth_deg: 10.0, elevation_deg: 5.0, distance: 2.0, fov_y_deg: 30.0, pan: (0.0, 0.0, 0.0))))")
        .expect("loads");
    assert_eq!(few.draw.camera.azimuth_deg, 10.0);
    assert_eq!(few.draw.size, (1024, 768));
    assert_eq!(few.open.source, None);
}

#[test]
fn a_version_1_file_opens_as_what_it_held() {
    // Written by `render --save-view` before the options model (tests/data/views/README.md).
    let text = include_str!("../../../../tests/data/views/v1-head.ron");
    let view = SavedView::parse(text).expect("a version 1 view loads");
    assert_eq!(view.version, VIEW_VERSION);
    assert_eq!(
        view.open.source.as_deref(),
        Some("../shared/data/mri-head-128x128x62.nii.gz")
    );
    let draw = &view.draw;
    assert_eq!(draw.size, (96, 72));
    assert_eq!(draw.camera.azimuth_deg, 63.0);
    let saved = draw.transfer.saved.expect("its transfer function");
    assert!(matches!(saved.transfer.opacity, OpacityMode::Points(_)));
    assert_eq!(saved.transfer.colormap, Colormap::Viridis);
    assert_eq!(draw.transfer.level, Some(5));
    assert_eq!(draw.transfer.shading.ambient, 0.3);
    assert_eq!(draw.clip.bounds, Some([[0.0, 0.8], [0.1, 1.0], [0.0, 1.0]]));
    assert_eq!(draw.renderer, Some(RendererKind::Octree));
    assert_eq!(draw.max_wait, std::time::Duration::from_secs(30));
    // What it opens as is written as today's view, and reads back the same.
    let text = ron::ser::to_string_pretty(&view, Default::default()).expect("encodes");
    assert_eq!(SavedView::parse(&text), Ok(view));

    let composite = SavedView::parse(include_str!(
        "../../../../tests/data/views/v1-two-channels.ron"
    ))
    .expect("a version 1 composite loads");
    let channels = &composite.draw.channels;
    assert_eq!(channels.colors, vec![[255, 0, 255], [0, 255, 0]]);
    assert_eq!(channels.windows[1].1.low, 10.0);
    assert!(channels.hidden.is_empty());
    let hidden = include_str!("../../../../tests/data/views/v1-two-channels.ron").replacen(
        "visible: true",
        "visible: false",
        1,
    );
    let hidden = SavedView::parse(&hidden).expect("loads");
    assert_eq!(hidden.draw.channels.hidden, vec![0]);
}

#[test]
fn bad_files_say_what_is_wrong_in_one_line() {
    for (text, expected) in [
        ("(version: 1, camera: (", "not a voxscope view file"),
        ("(version: 7)", "a newer voxscope wrote it"),
        ("(size: (0, 10))", "the size 0x10"),
        ("(version: 2, draw: (size: (10, 0)))", "the size 10x0"),
        ("(data: (channel: Some(\"red\")))", "channel: channel 'red'"),
        (
            "(version: 2, open: (channel: Some(\"red\")))",
            "'red' is not a number or 'all'",
        ),
        ("(version: 2, open: (raw: Some(\"8x8:u8\")))", "raw"),
        (
            "(version: 2, draw: (max_wait: -1.0))",
            "-1 is not a number of seconds",
        ),
        (
            "(version: 2, draw: (transfer: (density: Some(0.0))))",
            "(density) 0",
        ),
        ("[1, 2, 3]", "not a voxscope view file"),
    ] {
        let error = SavedView::parse(text).expect_err(text).to_string();
        assert!(error.contains(expected), "{text}: {error}");
        assert_eq!(error.lines().count(), 1, "{error}");
    }
}

#[test]
fn urls_are_stored_without_credentials_or_query() {
    let open = OpenOptions {
        source: Some("https://me:secret@example.org/a.ome.zarr?token=x".into()),
        channels_from: Some(vec!["../data/head.nii.gz".into()]),
        ..OpenOptions::default()
    }
    .stored();
    assert_eq!(
        open.source.as_deref(),
        Some("https://example.org/a.ome.zarr")
    );
    assert_eq!(open.channels_from, Some(vec!["../data/head.nii.gz".into()]));
}
