//! The chunks of a `Data` dataset indexed once, so that reading one costs one read of the file:
//! libhdf5 writes chunked datasets (unless asked for its newest formats) with a version-1
//! B-tree as their index, which `hdf5-reader`'s region reads walk whole for every region (its
//! pruned lookup serves 2-D reads only). A 20 GB file of 2 MiB chunks has 10 000 of them; read
//! one by one, each walk would cost thousands of node reads. Here the tree is walked once per
//! dataset, when its first chunk is asked for, into a map from chunk position to the chunk's
//! place in the file; a chunk is then one positioned read and the filter pipeline. Datasets of
//! the newer indexes (fixed and extensible arrays, version-2 B-trees: direct lookups) are read
//! through `hdf5-reader`'s region reads ([`super::hdf5::read_box`]).

use std::collections::HashMap;

use hdf5_reader::btree_v1::{BTreeV1Key, collect_btree_v1_leaves_storage};
use hdf5_reader::io::Cursor;
use hdf5_reader::messages::HdfMessage;
use hdf5_reader::messages::filter_pipeline::FilterDescription;
use hdf5_reader::messages::layout::DataLayout;
use hdf5_reader::{ByteOrder, Dataset, Datatype, Hdf5File};

use crate::error::printable;

/// Where one chunk lies in the file.
#[derive(Debug, Clone, Copy)]
struct Stored {
    address: u64,
    size: u64,
    /// Filters of the pipeline skipped for this chunk (bit i: filter i).
    filter_mask: u32,
}

/// A chunked dataset's chunks by position (z, y, x chunk indices).
pub(super) struct ChunkMap {
    chunks: HashMap<[u64; 3], Stored>,
    filters: Vec<FilterDescription>,
    /// Voxels of a chunk, z, y, x.
    shape: [u64; 3],
    element: usize,
    big_endian: bool,
}

impl ChunkMap {
    /// The map of `dataset`'s chunks where its index is a version-1 B-tree of 3-D chunks;
    /// `None` for any other layout (read by region instead).
    pub(super) fn of(file: &Hdf5File, dataset: &Dataset) -> Result<Option<Self>, String> {
        let header = file
            .get_or_parse_header(dataset.address())
            .map_err(|e| printable(&e.to_string()))?;
        let mut layout = None;
        let mut filters = Vec::new();
        for message in &header.messages {
            match message {
                HdfMessage::DataLayout(message) => layout = Some(&message.layout),
                HdfMessage::FilterPipeline(pipeline) => filters = pipeline.filters.clone(),
                _ => {}
            }
        }
        let Some(DataLayout::Chunked {
            address,
            dims,
            chunk_indexing: None,
            ..
        }) = layout
        else {
            return Ok(None);
        };
        let (element, big_endian) = match dataset.dtype() {
            Datatype::FixedPoint {
                size, byte_order, ..
            }
            | Datatype::FloatingPoint { size, byte_order } => (
                usize::from(*size),
                matches!(byte_order, ByteOrder::BigEndian),
            ),
            _ => return Ok(None),
        };
        let [cz, cy, cx] = dims[..] else {
            return Ok(None);
        };
        let shape = [u64::from(cz), u64::from(cy), u64::from(cx)];
        if shape.contains(&0) {
            return Err("has a chunk dimension of 0".to_owned());
        }
        let superblock = file.superblock();
        let mut chunks = HashMap::new();
        // An index never written: no chunk is stored.
        if !Cursor::is_undefined_offset(*address, superblock.offset_size) {
            let leaves = collect_btree_v1_leaves_storage(
                file.storage(),
                *address,
                superblock.offset_size,
                superblock.length_size,
                Some(3),
                dims,
                None,
            )
            .map_err(|e| format!("its chunk index: {}", printable(&e.to_string())))?;
            for (key, child) in leaves {
                let BTreeV1Key::RawData {
                    chunk_size,
                    filter_mask,
                    offsets,
                } = key
                else {
                    continue;
                };
                let at: Vec<u64> = offsets.iter().zip(shape).map(|(o, c)| o / c).collect();
                let aligned = offsets.iter().zip(shape).all(|(o, c)| o % c == 0);
                if offsets.len() < 3 || !aligned {
                    return Err(format!(
                        "its chunk index holds a chunk at {offsets:?}, not on the chunk grid"
                    ));
                }
                chunks.insert(
                    [at[0], at[1], at[2]],
                    Stored {
                        address: child,
                        size: u64::from(chunk_size),
                        filter_mask,
                    },
                );
            }
        }
        Ok(Some(Self {
            chunks,
            filters,
            shape,
            element,
            big_endian,
        }))
    }

    /// The chunk's shape, z, y, x.
    pub(super) fn shape(&self) -> [u64; 3] {
        self.shape
    }

    /// The chunk at `position` (z, y, x chunk indices) decoded, as little-endian values, z
    /// slowest; zeros (HDF5's default fill) where the file has none.
    pub(super) fn read(&self, file: &Hdf5File, position: [u64; 3]) -> Result<Vec<u8>, String> {
        let bytes = self.shape.iter().product::<u64>() as usize * self.element;
        let Some(stored) = self.chunks.get(&position) else {
            return Ok(vec![0; bytes]);
        };
        let size = usize::try_from(stored.size).unwrap_or(usize::MAX);
        let raw = file
            .storage()
            .read_range(stored.address, size)
            .map_err(|e| format!("chunk {position:?}: {}", printable(&e.to_string())))?;
        let mut decoded = hdf5_reader::filters::apply_pipeline_with_limit(
            raw.as_ref(),
            &self.filters,
            stored.filter_mask,
            self.element,
            None,
            Some(bytes),
        )
        .map_err(|e| format!("chunk {position:?}: {}", printable(&e.to_string())))?;
        if decoded.len() != bytes {
            return Err(format!(
                "chunk {position:?} decodes to {} bytes, not the {bytes} of its voxels",
                decoded.len()
            ));
        }
        if self.big_endian && self.element > 1 {
            for value in decoded.chunks_exact_mut(self.element) {
                value.reverse();
            }
        }
        Ok(decoded)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> Hdf5File {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/imaris")
            .join(name);
        super::super::hdf5::open(&path).unwrap()
    }

    #[test]
    fn version_1_b_trees_are_mapped_and_read_chunk_by_chunk() {
        let file = fixture("cells.ims");
        let data = file
            .dataset("DataSet/ResolutionLevel 0/TimePoint 0/Channel 1/Data")
            .unwrap();
        let map = ChunkMap::of(&file, &data)
            .unwrap()
            .expect("a B-tree v1 index");
        assert_eq!(map.shape(), [4, 5, 6]);
        // 2 x 2 x 2 chunks of the padded 8 x 10 x 12 dataset.
        assert_eq!(map.chunks.len(), 8);
        // Chunk (1, 1, 1) starts at voxel (4, 5, 6): the voxels plus 1000 there.
        let bytes = map.read(&file, [1, 1, 1]).unwrap();
        assert_eq!(bytes.len(), 4 * 5 * 6 * 2);
        let voxels = std::fs::read(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../tests/data/codecs/voxels.u16le"),
        )
        .unwrap();
        let at = |x: usize, y: usize, z: usize| {
            let i = 2 * (x + 10 * (y + 9 * z));
            u16::from_le_bytes([voxels[i], voxels[i + 1]]) + 1000
        };
        assert_eq!(u16::from_le_bytes([bytes[0], bytes[1]]), at(6, 5, 4));
        // A chunk past the grid reads as zeros.
        assert!(map.read(&file, [5, 0, 0]).unwrap().iter().all(|&b| b == 0));
        // libver 'latest' indexes and unchunked data are read by region.
        let file = fixture("lz4-time.ims");
        let data = file
            .dataset("DataSet/ResolutionLevel 0/TimePoint 0/Channel 0/Data")
            .unwrap();
        assert!(ChunkMap::of(&file, &data).unwrap().is_none());
    }
}
