//! A view within the atlas: when the bricks a view's rays ask for do not fit the slots it may
//! still fill, the ones that matter least give way to their parents, eight siblings for one,
//! the finest level first, until the rest fits. Which matter least within a level is the
//! caller's rank ([`cut_ranked`]): under DVR the farthest from the view's center
//! ([`cut_within`]), under MIP, which weighs every pixel alike, the dimmest (`streamer/cut.rs`).
//! The parents stand for them: while the view stays, whatever is asked for below a standing
//! brick is drawn from it and not loaded, so a view larger than the budget completes at the
//! resolution the budget allows instead of evicting what it draws to load what it lacks.
//! Since the finest level always gives way first, the asks of one cut end up at most one
//! level apart wherever the budget coarsened them (a restricted cut); `streamer/refine.rs`
//! keeps it so across frames.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::frame::ViewPoint;
use super::key_hash::{KeyMap, KeySet};
use super::pyramid::PyramidShape;
use super::queue::{Priority, Request, Tier};
use crate::BrickId;

/// What a view's asks come to within the room left: the bricks to load (the asked ones that
/// fit, and the parents that stand for the groups left out) and the asked bricks left out.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Cut {
    /// Bricks to load, in the loader's order.
    pub load: Vec<Request>,
    /// Asked bricks left out (drawn from a coarser level while the view stays).
    pub left_out: Vec<u32>,
    /// The coarser bricks that stand for the groups left out (each in [`Self::load`]).
    pub standing: Vec<u32>,
    /// The coarsest level a left-out region is drawn from (its nearest ancestor in
    /// [`Self::load`] or already satisfied); `None` when nothing is left out.
    pub coarsest: Option<u32>,
}

/// A group of siblings in the cut: their parent's key and rank (how readily it gives way).
/// The heap pops the group to give way first: the finest level, then the highest rank.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Group {
    parent: u32,
    level: u32,
    rank: f32,
}

impl Eq for Group {}

impl Ord for Group {
    fn cmp(&self, other: &Self) -> Ordering {
        // Finer children (a lower level) first, then the higher rank.
        other
            .level
            .cmp(&self.level)
            .then(self.rank.total_cmp(&other.rank))
            .then(self.parent.cmp(&other.parent))
    }
}

impl PartialOrd for Group {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// What a brick of a cut takes of the room the view has in the atlas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlotNeed {
    /// Nothing of the room: drawn from its value (uniform), failed, invisible, pinned, or in
    /// a slot the room counts already (a brick the view's rays want).
    Nothing,
    /// In a slot the room does not count: drawn in place of finer bricks (a stand-in). As a
    /// brick of the cut it keeps that slot; as an ancestor of one it gives it up once the
    /// finer bricks are in (the frame's own share of the atlas holds it until then).
    Held,
    /// Not in the atlas: a slot to load it into.
    Load,
}

/// The cut of `asked` (the bricks a frame's rays lacked, each missing) within `room` slots
/// of the atlas. `need(key)`: what a brick takes of the room ([`SlotNeed`]). A brick of the
/// cut takes a slot unless it needs [`SlotNeed::Nothing`]; so does each ancestor not in the
/// atlas that is loaded with it (the loader brings the coarser bricks above a brick down to
/// the first the atlas holds, so the picture refines level by level, and frames draw them
/// until the finer ones are in). Asked bricks are only ever replaced by ancestors, so every
/// region stays drawn, at its own level where it fits and coarser where it does not. Within a
/// level, the groups farthest from `view`'s center give way first.
pub fn cut_within(
    asked: &[Request],
    room: usize,
    shape: &PyramidShape,
    view: &ViewPoint,
    need: impl Fn(u32) -> SlotNeed,
) -> Cut {
    let rank = |parent: BrickId| Some(view.off_center(shape.brick_center(parent)));
    cut_ranked(asked, room, shape, rank, need)
}

/// [`cut_within`], the groups of a level giving way in the order of `rank(parent)`, the highest
/// first (ties: the larger key first); a group whose parent ranks `None` never gives way (it
/// stays as it is, over the room if need be).
pub fn cut_ranked(
    asked: &[Request],
    room: usize,
    shape: &PyramidShape,
    rank: impl Fn(BrickId) -> Option<f32>,
    need: impl Fn(u32) -> SlotNeed,
) -> Cut {
    let mut targets: KeyMap<Request> = asked.iter().map(|r| (r.key, *r)).collect();
    let takes_slot = |key: u32| need(key) != SlotNeed::Nothing;
    let mut cost = targets.keys().filter(|&&k| takes_slot(k)).count();
    // The ancestors to load along with the targets (not targets themselves), each counted once.
    let mut ancestors = KeySet::default();
    for &key in targets.keys() {
        let mut id = shape.brick_of(key);
        while let Some(parent) = id.and_then(|id| shape.parent(id)) {
            let Some(parent_key) = shape.key(parent) else {
                break;
            };
            if targets.contains_key(&parent_key) || need(parent_key) != SlotNeed::Load {
                break;
            }
            if !ancestors.insert(parent_key) {
                break; // counted with a sibling, and the rest above it too
            }
            cost += 1;
            id = Some(parent);
        }
    }
    if cost <= room {
        return Cut {
            load: sorted(targets.into_values().collect()),
            left_out: Vec::new(),
            standing: Vec::new(),
            coarsest: None,
        };
    }
    // The children in the cut of each parent.
    let mut children: KeyMap<Vec<u32>> = KeyMap::default();
    let mut heap = BinaryHeap::new();
    let group_of = |key: u32| -> Option<(u32, Group)> {
        let id = shape.brick_of(key)?;
        let parent = shape.parent(id)?;
        let parent_key = shape.key(parent)?;
        Some((
            parent_key,
            Group {
                parent: parent_key,
                level: id.level,
                rank: rank(parent)?,
            },
        ))
    };
    let mut queued = KeySet::default();
    for &key in targets.keys() {
        if let Some((parent, group)) = group_of(key) {
            children.entry(parent).or_default().push(key);
            if queued.insert(parent) {
                heap.push(group);
            }
        }
    }
    let asked_keys: KeySet = asked.iter().map(|r| r.key).collect();
    let mut left_out = Vec::new();
    let mut introduced = KeySet::default();
    let mut coarsest = None;
    while cost > room {
        let Some(group) = heap.pop() else {
            break; // everything is at the coarsest level: nothing more gives way
        };
        queued.remove(&group.parent);
        let Some(members) = children.remove(&group.parent) else {
            continue;
        };
        for key in members {
            if targets.remove(&key).is_some() && takes_slot(key) {
                cost -= 1;
            }
            if asked_keys.contains(&key) {
                left_out.push(key);
            }
        }
        let Some(parent_id) = shape.brick_of(group.parent) else {
            continue;
        };
        coarsest = Some(coarsest.map_or(parent_id.level, |c: u32| c.max(parent_id.level)));
        introduced.insert(group.parent);
        if let std::collections::hash_map::Entry::Vacant(slot) = targets.entry(group.parent) {
            slot.insert(Request {
                priority: Priority::new(Tier::Visible, parent_id.level, group.rank.max(0.0)),
                id: parent_id,
                key: group.parent,
            });
            // An ancestor counted already is now a brick of the cut instead.
            if !ancestors.remove(&group.parent) && takes_slot(group.parent) {
                cost += 1;
            }
        }
        // The parent may give way to its own parent in turn, with its siblings in the cut.
        if let Some((grandparent, next)) = group_of(group.parent) {
            let siblings = children.entry(grandparent).or_default();
            if !siblings.contains(&group.parent) {
                siblings.push(group.parent);
            }
            if queued.insert(grandparent) {
                heap.push(next);
            }
        }
    }
    left_out.sort_unstable();
    let mut standing: Vec<u32> = introduced
        .into_iter()
        .filter(|key| targets.contains_key(key))
        .collect();
    standing.sort_unstable();
    Cut {
        load: sorted(targets.into_values().collect()),
        left_out,
        standing,
        coarsest,
    }
}

fn sorted(mut requests: Vec<Request>) -> Vec<Request> {
    requests.sort_unstable_by_key(|r| (r.priority, r.key));
    requests
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 256³ pyramid: level 0 has 8³ bricks, level 1 4³, level 2 2³, level 3 one.
    fn shape() -> PyramidShape {
        PyramidShape::new([256, 256, 256]).expect("a pyramid")
    }

    fn ask(shape: &PyramidShape, view: &ViewPoint, level: u32, brick: [u32; 3]) -> Request {
        let id = BrickId {
            level,
            brick,
            channel: 0,
        };
        Request {
            priority: Priority::new(
                Tier::Visible,
                level,
                view.off_center(shape.brick_center(id)),
            ),
            id,
            key: shape.key(id).expect("in the pyramid"),
        }
    }

    fn level0_block(shape: &PyramidShape, view: &ViewPoint, side: u32) -> Vec<Request> {
        let mut asked = Vec::new();
        for z in 0..side {
            for y in 0..side {
                for x in 0..side {
                    asked.push(ask(shape, view, 0, [x, y, z]));
                }
            }
        }
        asked
    }

    /// Looking down +z along the volume's axis through the center of brick column (3, 3).
    fn view() -> ViewPoint {
        ViewPoint::new([128.0, 128.0, -500.0], [0.0, 0.0, 1.0])
    }

    /// The root (level 3, one brick) is pinned: it takes nothing of a view's room.
    fn root(shape: &PyramidShape) -> u32 {
        shape
            .key(BrickId {
                level: 3,
                brick: [0; 3],
                channel: 0,
            })
            .expect("the root")
    }

    /// Nothing in the atlas but the pinned root.
    fn empty_atlas(shape: &PyramidShape) -> impl Fn(u32) -> SlotNeed {
        let root = root(shape);
        move |key| {
            if key == root {
                SlotNeed::Nothing
            } else {
                SlotNeed::Load
            }
        }
    }

    /// The slots the cut's bricks take once loaded, with the ancestors loaded along with
    /// them (the pinned root aside), in an atlas that holds nothing else.
    fn slots_taken(shape: &PyramidShape, cut: &Cut) -> usize {
        let root = root(shape);
        let mut taken = KeySet::default();
        for request in &cut.load {
            let mut id = Some(request.id);
            while let Some(brick) = id {
                let key = shape.key(brick).expect("in the pyramid");
                if key == root || !taken.insert(key) {
                    break;
                }
                id = shape.parent(brick);
            }
        }
        taken.len()
    }

    #[test]
    fn what_fits_is_loaded_whole_with_the_ancestors_it_brings() {
        let (shape, view) = (shape(), view());
        let asked = level0_block(&shape, &view, 4);
        // 64 asked, their 8 parents and one grandparent loaded with them.
        let cut = cut_within(&asked, 73, &shape, &view, empty_atlas(&shape));
        assert_eq!(cut.load.len(), 64);
        assert!(cut.left_out.is_empty());
        assert_eq!(cut.coarsest, None);
        // One slot fewer: the ancestors count, so a group gives way.
        let cut = cut_within(&asked, 72, &shape, &view, empty_atlas(&shape));
        assert_eq!(cut.left_out.len(), 8);
        assert!(slots_taken(&shape, &cut) <= 72);
    }

    #[test]
    fn the_farthest_groups_of_the_finest_level_give_way_to_their_parents_until_it_fits() {
        let (shape, view) = (shape(), view());
        // 8³ = 512 level-0 bricks asked, 200 slots: their 64 parents and 8 grandparents are
        // loaded with them, and each group that gives way saves its 8 (its parent was loaded
        // anyway): (512 + 72 − 200) / 8 → 48 groups, 384 bricks left out.
        let asked = level0_block(&shape, &view, 8);
        let cut = cut_within(&asked, 200, &shape, &view, empty_atlas(&shape));
        assert!(
            slots_taken(&shape, &cut) <= 200,
            "{}",
            slots_taken(&shape, &cut)
        );
        assert_eq!(cut.left_out.len(), 48 * 8);
        assert_eq!(cut.standing.len(), 48);
        assert_eq!(cut.coarsest, Some(1));
        // What stayed fine is nearest the view's center: every kept group's parent is
        // nearer it than every parent that replaced a group.
        let parent_off = |id: BrickId| {
            let parent = shape.parent(id).expect("level 0 has parents");
            view.off_center(shape.brick_center(parent))
        };
        let kept = cut
            .load
            .iter()
            .filter(|r| r.id.level == 0)
            .map(|r| parent_off(r.id))
            .fold(0.0f32, f32::max);
        let replaced = cut
            .load
            .iter()
            .filter(|r| r.id.level == 1)
            .map(|r| view.off_center(shape.brick_center(r.id)))
            .fold(f32::MAX, f32::min);
        assert!(kept <= replaced, "{kept} vs {replaced}");
        // Every asked brick is either loaded or under a loaded parent.
        for request in &asked {
            let loaded = cut.load.iter().any(|r| r.key == request.key);
            let parent = shape.parent(request.id).and_then(|p| shape.key(p));
            let under = cut.load.iter().any(|r| Some(r.key) == parent);
            assert!(loaded ^ under, "{:?}", request.id);
        }
    }

    #[test]
    fn groups_give_way_level_by_level_down_to_the_coarsest() {
        let (shape, view) = (shape(), view());
        let asked = level0_block(&shape, &view, 8);
        // 9 slots: the 512 asks become level 2's eight bricks (and then the root would do
        // too, but 8 fit).
        let cut = cut_within(&asked, 9, &shape, &view, empty_atlas(&shape));
        assert!(slots_taken(&shape, &cut) <= 9, "{:?}", cut.load.len());
        assert_eq!(cut.left_out.len(), 512);
        assert_eq!(cut.coarsest, Some(2));
        // Level 2's eight stand for everything; the level-1 parents between gave way too.
        assert_eq!(cut.standing.len(), 8);
        assert!(
            cut.standing
                .iter()
                .all(|&k| shape.brick_of(k).unwrap().level == 2)
        );
        // No room at all: everything gives way to the root, which the atlas always holds.
        let cut = cut_within(&asked, 0, &shape, &view, empty_atlas(&shape));
        assert_eq!(cut.coarsest, Some(3));
        assert_eq!(cut.load.len(), 1);
        assert_eq!(cut.load[0].key, root(&shape));
    }

    #[test]
    fn bricks_already_satisfied_cost_nothing() {
        let (shape, view) = (shape(), view());
        let asked = level0_block(&shape, &view, 4);
        // Half of them are satisfied (say uniform): 32 missing and their 9 ancestors fit in
        // 41.
        let root = root(&shape);
        let need = |k: u32| {
            if k == root || (shape.brick_of(k).unwrap().level == 0 && k.is_multiple_of(2)) {
                SlotNeed::Nothing
            } else {
                SlotNeed::Load
            }
        };
        let cut = cut_within(&asked, 41, &shape, &view, need);
        assert!(cut.left_out.is_empty());
        let cut = cut_within(&asked, 40, &shape, &view, need);
        assert!(!cut.left_out.is_empty());
    }

    #[test]
    fn stand_ins_in_the_atlas_count_where_the_cut_keeps_them_and_not_as_ancestors() {
        let (shape, view) = (shape(), view());
        let asked = level0_block(&shape, &view, 8);
        // Level 1's 64 bricks are in the atlas, drawn in place of the 512 asked (the
        // frame's stand-ins); level 2's are in it too.
        let root = root(&shape);
        let need = |k: u32| match shape.brick_of(k).unwrap().level {
            _ if k == root => SlotNeed::Nothing,
            0 => SlotNeed::Load,
            _ => SlotNeed::Held,
        };
        // The ancestors cost nothing to load: all 512 fit in 512 slots.
        let cut = cut_within(&asked, 512, &shape, &view, need);
        assert!(cut.left_out.is_empty());
        // In 64 slots, each group that gives way keeps its parent's slot (7 saved, not 8):
        // every group gives way, and the 64 stand-ins are what the view keeps.
        let cut = cut_within(&asked, 64, &shape, &view, need);
        assert_eq!(cut.left_out.len(), 512);
        assert_eq!(cut.standing.len(), 64);
        assert_eq!(cut.load.len(), 64);
        assert_eq!(cut.coarsest, Some(1));
    }

    #[test]
    fn a_ranked_cut_gives_way_in_the_rank_s_order_and_never_past_an_unranked_parent() {
        let (shape, view) = (shape(), view());
        let asked = level0_block(&shape, &view, 8);
        // Ranked by x alone (as MIP's dimmest-first rank is blind to the view's center): the
        // groups of the largest x give way first, whatever their distance from the center.
        let by_x = |parent: BrickId| Some(parent.brick[0] as f32);
        let cut = cut_ranked(&asked, 200, &shape, by_x, empty_atlas(&shape));
        assert!(slots_taken(&shape, &cut) <= 200);
        let left_out_x: Vec<u32> = cut
            .standing
            .iter()
            .map(|&k| shape.brick_of(k).unwrap().brick[0])
            .collect();
        let kept_x = cut
            .load
            .iter()
            .filter(|r| r.id.level == 0)
            .map(|r| r.id.brick[0] / 2);
        let lowest_left_out = left_out_x.iter().copied().min().expect("groups gave way");
        assert!(kept_x.into_iter().all(|x| x <= lowest_left_out));
        // A parent ranked `None` never takes its group's place: nothing above level 1 stands
        // in, though the room would want it (the cut stays over the room).
        let to_level_1 = |parent: BrickId| (parent.level <= 1).then_some(0.0);
        let cut = cut_ranked(&asked, 9, &shape, to_level_1, empty_atlas(&shape));
        assert_eq!(cut.coarsest, Some(1));
        assert_eq!(cut.standing.len(), 64);
        assert!(slots_taken(&shape, &cut) > 9);
    }
}
