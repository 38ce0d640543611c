//! The streaming renderer's part of the Octree panel: its GPU budget, and what it holds and
//! does (per level: bricks total, resident, empty, requested; the atlas and RAM cache's fill,
//! hit rate, bytes read, upload rate), and every brick that could not be read (level, brick,
//! cause, whether it is asked for again); the status bar's words on streaming.

use egui::Ui;

use super::numbers::{format_bytes, group_digits};
use super::settings::AppSettings;
use voxscope_render::BUDGET_STEPS;
use voxscope_scene::Scene;
use voxscope_stream::{Failures, FullDetailBudget, StreamStatus, format_budget};

/// The GPU budgets offered: the steps a budget-limited view's status names, from 64 MiB to
/// 16 GiB (the device's largest 3D texture bounds the atlas anyway).
fn gpu_budgets() -> impl Iterator<Item = u64> {
    BUDGET_STEPS
        .into_iter()
        .filter(|&bytes| (64 << 20..=16 << 30).contains(&bytes))
}

/// The budget row of the renderer grid (shown when the streaming renderer is chosen); where
/// the view on screen is budget-limited, a button that takes the budget holding it whole.
pub fn budget_row(ui: &mut Ui, settings: &mut AppSettings, scene: Option<&Scene>) {
    let label = ui.label("GPU budget");
    ui.horizontal(|ui| {
        egui::ComboBox::from_id_salt("stream_gpu_memory")
            .selected_text(format_budget(settings.stream_gpu_memory))
            .show_ui(ui, |ui| {
                for bytes in gpu_budgets() {
                    ui.selectable_value(&mut settings.stream_gpu_memory, bytes, format_budget(bytes));
                }
            })
            .response
            .labelled_by(label.id)
            .on_hover_text("GPU memory the streaming renderer holds: its brick atlas, page table and buffers (applied by uploading again)");
        let holding = scene
            .and_then(|scene| scene.stream_status.as_ref()?.budget)
            .and_then(|limit| match limit.full_detail {
                FullDetailBudget::Bytes(bytes) => Some(bytes),
                _ => None,
            })
            .filter(|&bytes| bytes != settings.stream_gpu_memory);
        if let Some(bytes) = holding
            && ui
                .button(format!("Use {}", format_budget(bytes)))
                .on_hover_text("The view on screen is budget-limited (coarser where least important); an atlas of this budget holds it at full detail, where the GPU has the memory")
                .clicked()
        {
            settings.stream_gpu_memory = bytes;
        }
    });
    ui.end_row();
}

/// The status bar's word on streaming: `refining: N bricks` while visible detail is missing;
/// `incomplete: N bricks unreadable` while the view needs bricks that could not be read.
pub fn refining_text(scene: &Scene) -> Option<String> {
    let status = scene.stream_status.as_ref()?;
    let budget = status.budget.map(|budget| {
        format!(
            "{} in {}",
            budget.describe(),
            format_bytes(status.counters.slot_bytes * budget.fit as u64)
        )
    });
    let plural = |n: usize| if n == 1 { "" } else { "s" };
    let state = match (status.missing, status.unreadable) {
        (0, 0) => None,
        (missing, 0) => Some(format!(
            "refining: {} brick{}",
            group_digits(missing as u64),
            plural(missing)
        )),
        (0, unreadable) => Some(format!(
            "incomplete: {} brick{} unreadable",
            group_digits(unreadable as u64),
            plural(unreadable)
        )),
        (missing, unreadable) => Some(format!(
            "refining: {} brick{}; {} unreadable",
            group_digits(missing as u64),
            plural(missing),
            group_digits(unreadable as u64)
        )),
    };
    match (state, budget) {
        (Some(state), Some(budget)) => Some(format!("{state} ({budget})")),
        (state, budget) => state.or(budget),
    }
}

/// The status bar's notice when bricks newly could not be read: how many and the most common
/// cause (each cause's first brick is also on stderr; the panel lists every one).
pub fn failure_notice(scene: &Scene) -> Option<String> {
    let failures = scene.renderer.streamer()?.failures();
    let groups = failures.groups();
    let first = groups.first()?;
    let count = failures.count();
    Some(format!(
        "{} brick{} could not be read ({}): drawn from coarser levels; the Octree panel lists {}",
        group_digits(count as u64),
        if count == 1 { "" } else { "s" },
        shorten(&first.cause, 120),
        if count == 1 { "it" } else { "them" }
    ))
}

/// `text` cut to `max` characters with an ellipsis.
fn shorten(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text.to_owned(),
    }
}

/// The numbers of the streaming renderer: state, atlas, RAM cache, reads and uploads, and
/// the per-level brick table (max level m draws pyramid level depth − m).
pub fn show(ui: &mut Ui, scene: &Scene) {
    let (Some(status), Some(streamer)) = (&scene.stream_status, scene.renderer.streamer()) else {
        return;
    };
    let shape = streamer.shape();
    let depth = shape.depth();
    let counters = &status.counters;
    ui.strong("Streaming");
    egui::Grid::new("stream_grid")
        .num_columns(2)
        .spacing([8.0, 3.0])
        .show(ui, |ui| {
            ui.label("State");
            // Wrapped within the panel: a budget-limited view's state is a sentence, which
            // would otherwise widen the panel over the image.
            ui.add(egui::Label::new(state_text(status)).wrap());
            ui.end_row();
            ui.label("Rays");
            ui.label(walk_text(status, scene.renderer.renderer().stream_paths().and_then(|p| p.walk_level), depth))
                .on_hover_text("Where every ray wants one pyramid level (or one near and the next coarser one far) and each of its bricks is in the atlas (or drawn without it), rays walk that level's grid as the bricks renderer does (then the coarser one's); otherwise segment by segment. Once a view lacks nothing, the rest of such a level (or of both) is loaded into free atlas slots");
            ui.end_row();
            ui.label("Atlas");
            ui.label(format!(
                "{} of {} slots ({} pinned), {} each",
                group_digits(counters.slots_used as u64),
                group_digits(counters.slots as u64),
                counters.slots_pinned,
                format_bytes(counters.slot_bytes),
            ));
            ui.end_row();
            ui.label("RAM cache");
            ui.label(format!(
                "{} of {}, hit rate {:.0} %",
                format_bytes(counters.ram_bytes),
                format_bytes(counters.ram_capacity),
                100.0 * counters.ram_hit_rate(),
            ));
            ui.end_row();
            if counters.source_cache_capacity > 0 {
                // A store's decoded chunks and fetched bytes, within the same RAM budget.
                ui.label("Store cache");
                ui.label(format!(
                    "{} of {}",
                    format_bytes(counters.source_cache_bytes),
                    format_bytes(counters.source_cache_capacity),
                ));
                ui.end_row();
            }
            ui.label("Read");
            ui.label(format!(
                "{} bricks ({} prefetched), {}",
                group_digits(counters.loads),
                group_digits(counters.prefetch_loads),
                format_bytes(counters.bytes_read),
            ));
            ui.end_row();
            ui.label("Not read");
            ui.label(format!(
                "{} bricks known empty from the store",
                group_digits(counters.skipped_unread),
            ))
            .on_hover_text("The store's chunk ranges (voxscope convert writes them) showed these bricks invisible under the transfer function");
            ui.end_row();
            ui.label("Uploaded");
            ui.label(format!(
                "{}, {}/s now; {} evicted",
                format_bytes(counters.bytes_uploaded),
                format_bytes(counters.upload_bytes_per_s as u64),
                group_digits(counters.evictions),
            ));
            ui.end_row();
            if let Some(network) = &scene.network {
                let stats = network.stats;
                ui.label("Network");
                ui.label(format!(
                    "{} in flight, {} done, {} ({}/s)",
                    stats.in_flight,
                    group_digits(stats.requests),
                    format_bytes(stats.bytes),
                    format_bytes(network.bytes_per_s as u64),
                ))
                .on_hover_text("Requests to the store (a shard's range is one), bytes received, and the rate over the last half second");
                ui.end_row();
                if stats.errors > 0 {
                    ui.label("");
                    ui.colored_label(
                        ui.visuals().warn_fg_color,
                        format!(
                            "{} requests failed after their retries (those bricks drawn coarser; see the log)",
                            stats.errors
                        ),
                    );
                    ui.end_row();
                }
            }
            if counters.failed > 0 {
                ui.label("Unreadable");
                ui.colored_label(
                    ui.visuals().warn_fg_color,
                    format!(
                        "{} brick{} could not be read (drawn from coarser levels; listed below)",
                        group_digits(counters.failed as u64),
                        if counters.failed == 1 { "" } else { "s" }
                    ),
                );
                ui.end_row();
            }
        });
    failed_bricks(ui, streamer.failures(), depth);
    egui::ScrollArea::horizontal()
        .id_salt("stream_levels_scroll")
        .show(ui, |ui| {
            egui::Grid::new("stream_levels")
                .striped(true)
                .num_columns(9)
                .spacing([10.0, 2.0])
                .show(ui, |ui| {
                    for header in [
                        "level", "voxels", "bricks", "resident", "empty", "wanted", "coarser",
                        "read", "evicted",
                    ] {
                        ui.strong(header).on_hover_text(column_help(header));
                    }
                    ui.end_row();
                    // Coarse first, as the max-level slider counts.
                    for (pyramid_level, (level, shape)) in
                        counters.levels.iter().zip(&shape.levels).enumerate().rev()
                    {
                        ui.label((depth as usize - pyramid_level).to_string());
                        ui.monospace(voxscope_volume::format_dims(shape.dims));
                        ui.monospace(group_digits(level.total));
                        ui.monospace(group_digits(level.resident as u64));
                        ui.monospace(group_digits(level.empty as u64));
                        ui.monospace(group_digits(level.requested as u64));
                        ui.monospace(group_digits(level.left_out as u64));
                        ui.monospace(group_digits(level.loaded));
                        ui.monospace(group_digits(level.evicted));
                        ui.end_row();
                    }
                });
        });
}

/// What a column of the per-level table counts.
fn column_help(header: &str) -> &'static str {
    match header {
        "level" => "The max level that draws this pyramid level (the slider's numbers)",
        "voxels" => "The level's size",
        "bricks" => "Bricks of 32³ voxels in the level",
        "resident" => "Bricks in the GPU atlas",
        "empty" => {
            "Bricks known to need no slot (uniform, or invisible under the transfer function)"
        }
        "wanted" => "Bricks the view asks for that are not on the GPU yet",
        "coarser" => {
            "Bricks the view asks for that the GPU budget leaves out: drawn from a coarser level while the view stays"
        }
        "read" => {
            "Bricks read from the source since the streaming renderer was made (a new GPU budget makes it anew); read again after the RAM cache let them go: counted again"
        }
        "evicted" => {
            "Bricks that lost their GPU slot to another since the streaming renderer was made: many against the bricks read means the views outgrow the GPU budget"
        }
        _ => "",
    }
}

/// The bricks that could not be read, one row each (at most [`LISTED_FAILURES`]): the
/// max level that draws it, the brick, why, and whether it is asked for again.
fn failed_bricks(ui: &mut Ui, failures: &Failures, depth: u32) {
    let count = failures.count();
    if count == 0 {
        return;
    }
    egui::CollapsingHeader::new(format!(
        "Unreadable bricks ({})",
        group_digits(count as u64)
    ))
    .id_salt("stream_failures")
    .show(ui, |ui| {
        for group in failures.groups() {
            ui.label(group.describe());
        }
        ui.separator();
        egui::ScrollArea::vertical()
            .id_salt("stream_failures_scroll")
            .max_height(160.0)
            .show(ui, |ui| {
                let now = std::time::Instant::now();
                for brick in failures.bricks().take(LISTED_FAILURES) {
                    let again = match brick.retry_at {
                        Some(at) => format!(
                            "asked again in {} s",
                            at.saturating_duration_since(now).as_secs().max(1)
                        ),
                        None => "not asked again".to_owned(),
                    };
                    ui.label(format!(
                        "{} (max level {}), {} tr{}, {again}: {}",
                        brick.id,
                        depth.saturating_sub(brick.id.level),
                        brick.attempts,
                        if brick.attempts == 1 { "y" } else { "ies" },
                        brick.error.cause()
                    ))
                    .on_hover_text(brick.error.to_string());
                }
                if count > LISTED_FAILURES {
                    ui.label(format!(
                        "… and {} more",
                        group_digits((count - LISTED_FAILURES) as u64)
                    ));
                }
            });
    });
}

/// Failed bricks listed one by one, at most.
const LISTED_FAILURES: usize = 200;

/// How the rays are drawn: walking one level whole, or segment by segment and why. Levels
/// as the table below numbers them (max level `depth − pyramid level`).
fn walk_text(status: &StreamStatus, walk: Option<(u32, u32, usize)>, depth: u32) -> String {
    // The panel's levels (depth − pyramid level): the finer one, and the coarser beyond it.
    let walk = walk.map(|(pyramid_level, levels, left)| {
        let level = depth.saturating_sub(pyramid_level);
        let named = match levels {
            1 => format!("level {level}"),
            _ => format!("levels {level} and {}", level.saturating_sub(1)),
        };
        (named, left)
    });
    match walk {
        Some((levels, 0)) => format!("walking {levels} whole"),
        Some((levels, _)) if status.filling > 0 => format!(
            "by segment; {levels} loading, {} to go",
            group_digits(status.filling as u64)
        ),
        Some((levels, left)) => format!(
            "by segment; {} bricks of {levels} out",
            group_digits(left as u64)
        ),
        None => "by segment".to_owned(),
    }
}

fn state_text(status: &StreamStatus) -> String {
    let budget = status
        .budget
        .map(|budget| format!("; {}", budget.describe()))
        .unwrap_or_default();
    if status.unreadable > 0 && status.missing == 0 {
        format!(
            "incomplete: {} brick{} the view needs could not be read (drawn from coarser levels){budget}",
            group_digits(status.unreadable as u64),
            if status.unreadable == 1 { "" } else { "s" }
        )
    } else if status.missing > 0 {
        format!(
            "refining: {} bricks missing, {} queued, {} loading{}{budget}",
            group_digits(status.missing as u64),
            status.queued,
            status.loading,
            if status.unreadable > 0 {
                format!("; {} unreadable", group_digits(status.unreadable as u64))
            } else {
                String::new()
            },
        )
    } else if status.complete && status.budget.is_some() {
        format!("complete at the budget{budget}")
    } else if status.complete {
        "complete: nothing visible is missing".to_owned()
    } else {
        "checking the view…".to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rays_row_names_the_walked_levels_in_the_panels_numbering() {
        let idle = StreamStatus::default();
        let filling = StreamStatus {
            filling: 1_234,
            ..StreamStatus::default()
        };
        // Pyramid level 0 of a depth-8 octree is the panel's level 8; the next coarser, 7.
        assert_eq!(
            walk_text(&idle, Some((0, 1, 0)), 8),
            "walking level 8 whole"
        );
        assert_eq!(
            walk_text(&idle, Some((0, 2, 0)), 8),
            "walking levels 8 and 7 whole"
        );
        assert_eq!(
            walk_text(&filling, Some((1, 2, 40)), 8),
            "by segment; levels 7 and 6 loading, 1\u{202f}234 to go"
        );
        assert_eq!(
            walk_text(&idle, Some((1, 1, 40)), 8),
            "by segment; 40 bricks of level 7 out"
        );
        assert_eq!(walk_text(&idle, None, 8), "by segment");
    }
}
