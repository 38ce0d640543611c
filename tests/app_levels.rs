//! Each max level draws its own resolution in the app with every renderer (egui_kittest on the
//! software Vulkan device): with `bricks`, the levels between the brick level and the voxels
//! are pyramid levels, so the level grid's panes differ, and the Octree panel says what each
//! level draws.

mod support;

use egui_kittest::kittest::Queryable;
use support::app_harness::{choose_renderer, differing_pixels, harness, settle, snapshot, view};
use voxscope_render::RendererKind;

fn set_max_level(harness: &mut egui_kittest::Harness<'_, voxscope::app::VoxscopeApp>, level: u32) {
    harness
        .get_by_role_and_label(egui::accesskit::Role::Slider, "Max level")
        .set_value_accesskit(level as f64);
    settle(harness);
    assert_eq!(harness.state().view.max_level, level);
}

#[test]
fn every_level_below_the_voxels_is_a_picture_of_its_own_with_bricks_and_dense() {
    let mut harness = harness();
    // The sample head: 128×62×128, depth 7; 32³ bricks sit at level 2.
    for (name, kind, levels) in [
        ("bricks", RendererKind::Bricks, 3..=7),
        ("dense", RendererKind::Dense, 1..=7),
    ] {
        choose_renderer(&mut harness, name);
        assert_eq!(harness.state().renderer_kind(), Some(kind));
        let mut finer = None;
        for level in levels.rev() {
            set_max_level(&mut harness, level);
            let drawn = if level == 7 {
                "every voxel".to_owned()
            } else {
                let side = 1 << (7 - level);
                let dims = [128, 62, 128].map(|d: u32| d.div_ceil(side));
                format!(
                    "{}×{}×{} voxels of {side}³, filtered",
                    dims[0], dims[1], dims[2]
                )
            };
            harness.get_by_label(&drawn);
            let image = view(&harness);
            if let Some(finer) = &finer {
                let changed = differing_pixels(finer, &image);
                assert!(
                    changed > 1000,
                    "{name}: level {level} draws level {}'s picture ({changed} pixels differ)",
                    level + 1
                );
            }
            finer = Some(image);
        }
    }
}

#[test]
fn the_level_grid_with_bricks_shows_each_levels_resolution() {
    let mut harness = harness();
    choose_renderer(&mut harness, "bricks");
    // At the brick level the bricks' nodes are drawn, one color each.
    set_max_level(&mut harness, 2);
    harness.get_by_label("nodes to level 2, one color each");
    set_max_level(&mut harness, 7);
    harness.get_by_label("Level grid").click();
    settle(&mut harness);
    // The Octree panel describes the grid's panes, not the single view's max level.
    harness.get_by_label("per pane: 4, 5, 6, 7");
    harness.get_by_label("4: 16×8×16 voxels of 8³, filtered");
    harness.get_by_label("7: every voxel");
    assert!(
        harness
            .query_by_role_and_label(egui::accesskit::Role::Slider, "Max level")
            .is_none(),
        "the single view's max level slider is shown in the level grid"
    );
    snapshot(&mut harness, "level_grid_bricks");
}

/// The Octree panel's GPU time and nodes per ray are the volume's own: after an open they
/// showed the previous volume's numbers until a frame of the new one was measured.
#[test]
fn an_opened_volume_shows_no_numbers_of_the_one_before() {
    let mut harness = harness();
    assert!(
        harness.state().frame_cost().is_some(),
        "the sample measured"
    );
    let ctx = harness.ctx.clone();
    harness.state_mut().run_command(
        voxscope::app::Command::Open(voxscope_scene::VolumeSource::Spec(
            "synthetic:sphere:40".into(),
        )),
        &ctx,
    );
    let started = std::time::Instant::now();
    while !harness
        .state()
        .volume()
        .is_some_and(|(name, _)| name.contains("sphere"))
    {
        assert!(started.elapsed().as_secs() < 60, "the sphere opens");
        harness.step();
    }
    assert!(
        harness.state().frame_cost().is_none(),
        "the panel shows the sample's numbers for the sphere"
    );
    settle(&mut harness);
    assert!(
        harness.state().frame_cost().is_some(),
        "the sphere measured"
    );
}
