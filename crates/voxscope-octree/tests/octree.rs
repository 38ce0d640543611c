//! The flat-list octree: layout, counts, colors, collapse, and random volumes.

mod support;

use proptest::prelude::*;
use voxscope_octree::{
    self, BuildOptions, LEAF, Octree, OpacityMode, TransferFunction, ValueBounds, average_color,
    full_tree_nodes, level_statistics, unpack_rgba,
};
use voxscope_volume::{QuantizedVolume, ValueWindow, Volume, VoxelData};

const FULL: BuildOptions = BuildOptions {
    collapse_uniform: false,
    labels: false,
};
const COLLAPSED: BuildOptions = BuildOptions {
    collapse_uniform: true,
    labels: false,
};

fn volume_u8(dims: [usize; 3], values: Vec<u8>) -> Volume {
    Volume::new("test", "test", dims, [1.0; 3], VoxelData::U8(values)).unwrap()
}

fn ramp(dims: [usize; 3]) -> Volume {
    let count = dims.iter().product();
    volume_u8(dims, (0..count).map(|i| (i * 37 % 251) as u8).collect())
}

fn built(
    volume: &Volume,
    options: BuildOptions,
    transfer: Option<TransferFunction>,
) -> (Octree, TransferFunction) {
    support::colored_octree(volume, transfer, options)
}

/// Every structural rule of the paper's list, checked node by node.
fn check_layout(octree: &Octree) {
    assert_eq!(octree.level_starts[0], 0);
    assert_eq!(octree.level_starts.len(), octree.depth as usize + 2);
    assert_eq!(*octree.level_starts.last().unwrap(), octree.nodes.len());
    let mut expected_next_child = octree.level_starts[1];
    for level in 0..=octree.depth {
        let next_level = octree.level_range(level).end;
        for index in octree.level_range(level) {
            let node = octree.nodes[index];
            if node.first_child == LEAF {
                continue;
            }
            assert!(
                level < octree.depth,
                "voxel-level node {index} has children"
            );
            // Breadth first, left to right: children blocks follow in parents' order.
            assert_eq!(
                node.first_child as usize, expected_next_child,
                "node {index}"
            );
            assert!(node.first_child as usize >= next_level);
            expected_next_child += 8;
        }
    }
    assert_eq!(
        expected_next_child,
        octree.nodes.len(),
        "every node but the root is a child"
    );
}

/// Parent colors are the opacity-weighted average of their children, alpha rounded up.
fn check_colors(octree: &Octree) {
    for node in &octree.nodes {
        if node.first_child != LEAF {
            let first = node.first_child as usize;
            let children = std::array::from_fn(|c| octree.nodes[first + c].color);
            assert_eq!(node.color, average_color(children));
            let alpha_sum: u32 = children.iter().map(|&c| unpack_rgba(c)[3] as u32).sum();
            assert_eq!(node.alpha() as u32, alpha_sum.div_ceil(8));
        }
    }
}

#[test]
fn cubic_full_tree_has_eight_to_the_level_nodes_and_equation_one_total() {
    let volume = ramp([16, 16, 16]);
    let (octree, _) = built(&volume, FULL, None);
    assert_eq!(octree.depth, 4);
    for level in 0..=4 {
        assert_eq!(octree.level_range(level).len(), 8usize.pow(level));
    }
    assert_eq!(octree.nodes.len() as u64, full_tree_nodes(4));
    assert_eq!(full_tree_nodes(4), 1 + 8 + 64 + 512 + 4096);
    check_layout(&octree);
    check_colors(&octree);
}

#[test]
fn non_cubic_volume_is_padded_to_the_enclosing_cube_with_transparent_nodes() {
    let volume = ramp([5, 3, 7]);
    let (octree, _) = built(&volume, FULL, None);
    assert_eq!(octree.depth, 3, "7 voxels need a cube of 8");
    assert_eq!(octree.nodes.len() as u64, full_tree_nodes(3));
    check_layout(&octree);
    // Exactly 5·3·7 voxel nodes are real; the padding is empty and transparent.
    let voxels = octree.level_range(3);
    let real = voxels
        .clone()
        .filter(|&i| !octree.bounds[i].is_empty())
        .count();
    assert_eq!(real, 5 * 3 * 7);
    for i in voxels {
        if octree.bounds[i].is_empty() {
            assert_eq!(octree.nodes[i].color, 0);
        }
    }
}

#[test]
fn leaves_at_the_voxel_level_carry_their_voxels_color() {
    let volume = ramp([6, 9, 4]);
    let window = ValueWindow {
        low: 0.0,
        high: 250.0,
    };
    let transfer = TransferFunction::gray(window);
    let (octree, _) = built(&volume, FULL, Some(transfer));
    let side = octree.side();
    // Walk from the root to every voxel by coordinates and compare.
    for z in 0..4 {
        for y in 0..9 {
            for x in 0..6 {
                let mut index = 0usize;
                for level in 0..octree.depth {
                    let shift = octree.depth - 1 - level;
                    let child =
                        ((x >> shift) & 1) | (((y >> shift) & 1) << 1) | (((z >> shift) & 1) << 2);
                    index = octree.nodes[index].first_child as usize + child;
                }
                let value = volume.value(x, y, z).unwrap();
                let expected = transfer.color_of_normalized(window.normalize(value));
                assert_eq!(
                    unpack_rgba(octree.nodes[index].color),
                    expected,
                    "voxel {x},{y},{z}"
                );
                assert_eq!(octree.bounds[index], ValueBounds::single(value as u16));
            }
        }
    }
    assert_eq!(side, 16);
}

#[test]
fn collapsing_uniform_subtrees_keeps_colors_and_saves_nodes() {
    // A 32³ volume: zero everywhere but a bright 5³ block off-center.
    let dims = [32, 32, 32];
    let mut values = vec![0u8; 32 * 32 * 32];
    for z in 9..14 {
        for y in 3..8 {
            for x in 20..25 {
                values[x + 32 * (y + 32 * z)] = 200;
            }
        }
    }
    let volume = volume_u8(dims, values);
    let window = ValueWindow {
        low: -10.0,
        high: 250.0,
    }; // zero is visible too
    let transfer = TransferFunction::gray(window);
    let (full, _) = built(&volume, FULL, Some(transfer));
    let (collapsed, _) = built(&volume, COLLAPSED, Some(transfer));
    check_layout(&collapsed);
    check_colors(&collapsed);
    assert!(
        collapsed.nodes.len() * 10 < full.nodes.len(),
        "{} vs {}",
        collapsed.nodes.len(),
        full.nodes.len()
    );
    // Same root color: collapsing is lossless.
    assert_eq!(collapsed.nodes[0].color, full.nodes[0].color);
    // A collapsed leaf above the voxel level holds a single value.
    let upper_leaves = (0..collapsed.depth)
        .flat_map(|l| collapsed.level_range(l))
        .filter(|&i| collapsed.nodes[i].is_leaf());
    for i in upper_leaves {
        assert!(collapsed.bounds[i].is_uniform() || collapsed.bounds[i].is_empty());
    }
}

#[test]
fn a_single_voxel_is_a_root_leaf() {
    let (octree, _) = built(&volume_u8([1, 1, 1], vec![9]), FULL, None);
    assert_eq!(octree.depth, 0);
    assert_eq!(octree.nodes.len(), 1);
    assert!(octree.nodes[0].is_leaf());
}

#[test]
fn statistics_count_transparent_and_opaque_nodes_per_level() {
    let volume = ramp([8, 8, 8]);
    let window = ValueWindow {
        low: 0.0,
        high: 250.0,
    };
    let binary = TransferFunction {
        opacity: OpacityMode::Binary,
        window,
        threshold: 0.5,
        colormap: Default::default(),
    };
    let (octree, _) = built(&volume, FULL, Some(binary));
    let stats = level_statistics(&octree);
    assert_eq!(stats.len(), 4);
    let voxels = &stats[3];
    let above = (0..512)
        .filter(|i| (i * 37 % 251) as f64 / 250.0 >= 0.5)
        .count() as u64;
    assert_eq!(voxels.opaque, above);
    assert_eq!(voxels.transparent, 512 - above);
    assert_eq!(voxels.leaves, 512);
    assert_eq!(voxels.bytes, 512 * 8);
    assert_eq!(stats[0].nodes, 1);
}

#[test]
fn recolor_changes_colors_but_never_the_topology() {
    let volume = ramp([12, 10, 9]);
    let (mut octree, _) = built(&volume, COLLAPSED, None);
    let topology: Vec<u32> = octree.nodes.iter().map(|n| n.first_child).collect();
    let before: Vec<u32> = octree.nodes.iter().map(|n| n.color).collect();
    let window = ValueWindow {
        low: 100.0,
        high: 200.0,
    };
    voxscope_octree::recolor(
        &mut octree,
        &TransferFunction {
            opacity: OpacityMode::Binary,
            window,
            threshold: 0.2,
            colormap: Default::default(),
        },
    );
    assert_eq!(
        topology,
        octree
            .nodes
            .iter()
            .map(|n| n.first_child)
            .collect::<Vec<_>>()
    );
    assert_ne!(
        before,
        octree.nodes.iter().map(|n| n.color).collect::<Vec<_>>()
    );
    check_colors(&octree);
}

#[test]
fn mri_head_256_builds_a_valid_paper_sized_octree() {
    let volume = voxscope_volume::load(
        support::shared_data("mri-head-256.nii.gz")
            .to_str()
            .unwrap(),
        &Default::default(),
    )
    .unwrap();
    let quantized = QuantizedVolume::new(&volume);
    let octree = voxscope_octree::build(&quantized, COLLAPSED).unwrap();
    assert_eq!(octree.depth, 8);
    check_layout(&octree);
    // Correctness only here; build speed is measured by `voxscope info` and the benchmark.
    assert!(octree.nodes.len() as u64 <= full_tree_nodes(8));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn random_volumes_build_valid_octrees(
        dims in (1usize..12, 1usize..12, 1usize..12),
        seed in any::<u64>(),
        levels in 1u8..6,
        collapse in any::<bool>(),
        threshold in 0.0f32..1.0,
    ) {
        let dims = [dims.0, dims.1, dims.2];
        let count = dims.iter().product::<usize>();
        // Few distinct values so that uniform regions (and collapse) happen.
        let mut state = seed | 1;
        let values: Vec<u8> = (0..count).map(|_| {
            state ^= state << 13; state ^= state >> 7; state ^= state << 17;
            (state % levels as u64) as u8 * 40
        }).collect();
        let volume = volume_u8(dims, values.clone());
        let window = ValueWindow { low: 0.0, high: 200.0 };
        let transfer = TransferFunction { opacity: OpacityMode::Binary, window, threshold, colormap: Default::default() };
        let (octree, _) = built(&volume, BuildOptions { collapse_uniform: collapse, labels: false }, Some(transfer));
        check_layout(&octree);
        check_colors(&octree);
        // The root's bounds cover exactly the voxels' range.
        let root = octree.bounds[0];
        // (levels count from the data's minimum: compare in data units)
        prop_assert_eq!(octree.quantization.value(root.min()), *values.iter().min().unwrap() as f64);
        prop_assert_eq!(octree.quantization.value(root.max()), *values.iter().max().unwrap() as f64);
        // Alpha 0 at a node means every voxel below is transparent.
        let any_visible = values.iter().any(|&v| v as f64 / 200.0 >= threshold as f64);
        prop_assert_eq!(octree.nodes[0].alpha() > 0, any_visible);
        if !collapse {
            prop_assert_eq!(octree.nodes.len() as u64, full_tree_nodes(octree.depth));
        }
    }
}
