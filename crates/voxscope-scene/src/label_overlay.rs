//! Label overlays: a label volume on an image's grid (an OME-Zarr image's label image, or any
//! label file of the same dimensions) drawn **over** the image's picture, as napari draws a
//! labels layer over an image layer.
//!
//! How it is drawn, in every renderer and mode alike: the labels are uploaded as a volume of
//! their own, for the renderer of the image's kind, and drawn in the renderers' "first visible
//! label along the ray" mode (MIP of a label volume, `first_label` in the shaders: nearest
//! voxel, coarse levels reduced by the mode). What that pass draws is not a color but a
//! *slot*: the volume it draws holds, per voxel, the number of its label's color among the
//! visible colors (1…255, gray level = slot; 0 where the label is 0, hidden, or fully
//! transparent, so a ray passes a hidden label and stops at the next visible one). More than
//! 255 visible colors take a second pass (the slot's high part). The slot image read back is
//! turned into colors exactly, per label value ([`LabelOverlay::color_of`]: the `image-label`
//! color where the file gives one, else the labels palette), and blended over the image with
//! the layer's opacity times the color's alpha; pixels whose ray meets no visible label keep
//! the image's color bit for bit.
//!
//! The labels are drawn over the image, not depth-composited inside it: a label behind opaque
//! tissue still shows (as in napari's 3D view of a labels layer over an image layer).

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use voxscope_octree::{self as octree, BuildOptions, Colormap, OpacityMode, TransferFunction};
use voxscope_render::{
    Camera, GpuContext, RenderMode, RenderSettings, RenderTarget, RendererOptions, VolumeRenderer,
    read_image,
};
use voxscope_stream::{
    BrickData, BrickError, BrickId, BrickSource, PyramidShape, StreamOptions, ValueRange,
    ZarrSource,
};
use voxscope_volume::ome_zarr::{LabelColor, LabelImage, Pyramid};
use voxscope_volume::remote::RemoteOptions;
use voxscope_volume::{
    LoadOptions, Quantization, QuantizedVolume, Selection, ValueWindow, Volume, VoxelData,
};

use crate::LabelError;

/// The opacity a label layer is drawn with unless told (napari's labels layer's default).
pub const DEFAULT_LABEL_OPACITY: f32 = 0.7;

/// The most distinct labels (non-zero values) one label volume may hold.
pub const MAX_LABEL_VALUES: usize = 65_535;

/// Visible colors one pass encodes (gray levels 1…255).
const SLOTS_PER_PASS: usize = 255;

/// A label volume on an image's grid: its labels and, per voxel, which one.
pub struct LabelOverlay {
    /// Its name (a label image's name, or the file's).
    pub name: String,
    /// Voxels along x, y, z (the image's).
    pub dims: [usize; 3],
    /// Every non-zero label value it holds, ascending, with its voxel count.
    pub labels: Vec<(f64, u64)>,
    /// The colors its file gives (`image-label` `colors`), if any.
    pub given_colors: Vec<LabelColor>,
    /// Per voxel (x fastest): 0 for label 0, else 1 + the label's index in `labels`.
    label_index: Vec<u16>,
}

impl LabelOverlay {
    /// The labels of `volume`, which must lie on a grid of `image_dims` (else one line naming
    /// both grids), named `name`, colored by `given_colors` where they say.
    pub fn new(
        name: &str,
        volume: &Volume,
        image_dims: [usize; 3],
        given_colors: Vec<LabelColor>,
    ) -> Result<Self, LabelError> {
        if volume.dims != image_dims {
            return Err(LabelError::OffGrid {
                name: name.to_owned(),
                dims: volume.dims,
                image_dims,
            });
        }
        let scale = volume.value_scale;
        let value_of = |index: usize| scale.apply(volume.data.get(index).unwrap_or(0.0));
        // Distinct values first (exact, by their bits; -0 is 0).
        let mut counts: HashMap<u64, u64> = HashMap::new();
        for index in 0..volume.voxel_count() {
            let value = value_of(index);
            if value != 0.0 && !value.is_nan() {
                *counts.entry(value.to_bits()).or_default() += 1;
                if counts.len() > MAX_LABEL_VALUES {
                    return Err(LabelError::TooManyLabels(name.to_owned()));
                }
            }
        }
        let mut labels: Vec<(f64, u64)> = counts
            .into_iter()
            .map(|(bits, count)| (f64::from_bits(bits), count))
            .collect();
        labels.sort_by(|a, b| a.0.total_cmp(&b.0));
        let position: HashMap<u64, u16> = labels
            .iter()
            .enumerate()
            .map(|(i, (value, _))| (value.to_bits(), (i + 1) as u16))
            .collect();
        let label_index = (0..volume.voxel_count())
            .map(|index| {
                position
                    .get(&value_of(index).to_bits())
                    .copied()
                    .unwrap_or(0)
            })
            .collect();
        Ok(Self {
            name: name.to_owned(),
            dims: volume.dims,
            labels,
            given_colors,
            label_index,
        })
    }

    /// Label image `label` of the OME-Zarr image opened from `image_spec` (`image`): the level
    /// of its pyramid on the grid of the image's volume in memory (`image_dims`), its
    /// resolution 0 being the image's (else one line naming both grids).
    pub fn open_label_image(
        image: &Pyramid,
        image_spec: &str,
        label: &LabelImage,
        image_dims: [usize; 3],
        remote: RemoteOptions,
    ) -> Result<Self, LabelError> {
        let (spec, pyramid) = open_label_pyramid(image, image_spec, label, remote)?;
        let level = pyramid
            .levels
            .iter()
            .position(|level| level.dims == image_dims)
            .ok_or_else(|| LabelError::NoLevelOf {
                spec: spec.clone(),
                dims: image_dims,
            })?;
        let labels = pyramid.level_volume(level)?;
        Self::new(&label.name, &labels, image_dims, label.colors.clone())
    }

    /// A label file (NIfTI, NRRD, TIFF, …, or a Zarr store) on the grid of the image's volume
    /// in memory (`image_dims`), in the labels palette; named by `spec`.
    pub fn open_file(spec: &str, image_dims: [usize; 3]) -> Result<Self, LabelError> {
        let labels = voxscope_volume::load(spec, &LoadOptions::default())
            .map_err(LabelError::of_label_file)?;
        Self::new(spec, &labels, image_dims, Vec::new())
    }

    /// The color of label `value`: its `image-label` color where the file gives one, else the
    /// labels palette's (opaque); label 0 is transparent.
    pub fn color_of(&self, value: f64) -> [u8; 4] {
        label_color(value, &self.given_colors)
    }

    /// The label at `voxel` (0 outside the grid or for the background).
    pub fn value_at(&self, voxel: [usize; 3]) -> f64 {
        let [x, y, z] = voxel;
        let [nx, ny, nz] = self.dims;
        if x >= nx || y >= ny || z >= nz {
            return 0.0;
        }
        match self.label_index.get(x + nx * (y + ny * z)) {
            Some(&index) if index > 0 => self.labels[index as usize - 1].0,
            _ => 0.0,
        }
    }

    /// The layer to draw with the labels whose values `hidden` lists left out, and `opacity`.
    pub fn layer(
        &self,
        hidden: &[f64],
        opacity: f32,
        spacing: [f64; 3],
    ) -> Result<LabelLayer, LabelError> {
        // Each label's color, and the visible colors in slots 1, 2, … (one per distinct color).
        let mut slots: Vec<[u8; 4]> = Vec::new();
        let mut slot_of_color: HashMap<[u8; 4], usize> = HashMap::new();
        let mut slot_of_label = vec![0usize; self.labels.len() + 1];
        for (i, (value, _)) in self.labels.iter().enumerate() {
            let color = self.color_of(*value);
            if color[3] == 0 || hidden.contains(value) {
                continue;
            }
            let slot = *slot_of_color.entry(color).or_insert_with(|| {
                slots.push(color);
                slots.len()
            });
            slot_of_label[i + 1] = slot;
        }
        let passes = if slots.len() > SLOTS_PER_PASS { 2 } else { 1 };
        let passes = (0..passes)
            .map(|pass| {
                let codes: Vec<u8> = self
                    .label_index
                    .iter()
                    .map(|&index| match slot_of_label[index as usize] {
                        0 => 0,
                        slot if pass == 0 => (1 + (slot - 1) % SLOTS_PER_PASS) as u8,
                        slot => (1 + (slot - 1) / SLOTS_PER_PASS) as u8,
                    })
                    .collect();
                SlotPass::new(&self.name, self.dims, spacing, codes)
            })
            .collect::<Result<Vec<_>, LabelError>>()?;
        Ok(LabelLayer {
            name: self.name.clone(),
            slots,
            passes,
            opacity: opacity.clamp(0.0, 1.0),
        })
    }
}

/// The color of label `value`: its color in `given` (`image-label`'s) where listed, else the
/// labels palette's (opaque); label 0 is transparent.
pub fn label_color(value: f64, given: &[LabelColor]) -> [u8; 4] {
    if value == 0.0 {
        return [0; 4];
    }
    if let Some(given) = given.iter().find(|c| c.value == value) {
        return given.rgba;
    }
    let [r, g, b] = Colormap::Labels.rgb_of(value, 0.0);
    [r, g, b, 255]
}

/// One volume of slot codes (gray level = code), quantized, its label octree colored.
pub struct SlotPass {
    pub quantized: QuantizedVolume,
    pub octree: octree::Octree,
    pub transfer: TransferFunction,
    pub spacing: [f64; 3],
}

impl SlotPass {
    fn new(
        name: &str,
        dims: [usize; 3],
        spacing: [f64; 3],
        codes: Vec<u8>,
    ) -> Result<Self, LabelError> {
        let volume = Volume::new(name, "labels", dims, spacing, VoxelData::U8(codes))?;
        let quantized = QuantizedVolume::new(&volume);
        // Always labels, whatever their count: nearest voxels, the mode, the first label.
        let options = BuildOptions {
            labels: true,
            ..BuildOptions::default()
        };
        let mut octree = octree::build(&quantized, options).map_err(|error| LabelError::Build {
            name: name.to_owned(),
            error,
        })?;
        let transfer = slot_transfer();
        octree::recolor(&mut octree, &transfer);
        Ok(Self {
            quantized,
            octree,
            transfer,
            spacing,
        })
    }
}

/// Gray = the code (0…255 over the window 0…255), every code but 0 opaque.
fn slot_transfer() -> TransferFunction {
    TransferFunction {
        opacity: OpacityMode::Binary,
        window: ValueWindow {
            low: 0.0,
            high: 255.0,
        },
        threshold: 0.5 / 255.0,
        colormap: Colormap::Grays,
    }
}

/// A label overlay ready to upload: its visible colors by slot and its slot passes.
pub struct LabelLayer {
    pub name: String,
    /// Slot `s`'s color is `slots[s - 1]`.
    pub slots: Vec<[u8; 4]>,
    pub passes: Vec<SlotPass>,
    /// The layer's opacity, 0…1 (times each color's alpha).
    pub opacity: f32,
}

impl LabelLayer {
    /// Uploads the passes for the renderer `options` names (the image's), drawn at levels up
    /// to `max_level`.
    pub fn upload(
        self,
        context: &GpuContext,
        options: RendererOptions,
        max_level: u32,
    ) -> Result<UploadedLabels, LabelError> {
        let renderers = self
            .passes
            .iter()
            .map(|pass| {
                VolumeRenderer::new(
                    context,
                    options,
                    &pass.octree,
                    &pass.quantized,
                    pass.spacing,
                    max_level.min(pass.octree.depth),
                    &pass.transfer,
                )
                .map_err(|error| LabelError::Render {
                    name: self.name.clone(),
                    error,
                })
            })
            .collect::<Result<Vec<_>, LabelError>>()?;
        Ok(UploadedLabels {
            name: self.name,
            slots: self.slots,
            opacity: self.opacity,
            renderers,
            streamed: None,
        })
    }
}

/// A label overlay on the GPU.
pub struct UploadedLabels {
    pub name: String,
    slots: Vec<[u8; 4]>,
    pub opacity: f32,
    renderers: Vec<VolumeRenderer>,
    /// Streamed from the label image's pyramid: each view is refined until complete, at most
    /// this long.
    streamed: Option<Duration>,
}

/// The settings a label pass draws with: the image's view (level, clip, pixel LOD), in the
/// first-visible-label mode, never a heat map.
pub fn label_pass_settings(image: &RenderSettings) -> RenderSettings {
    RenderSettings {
        mode: RenderMode::Mip,
        heatmap: false,
        ..*image
    }
}

impl UploadedLabels {
    /// Label image `pyramid` (on the grid of a streamed image) streamed brick by brick for
    /// the streaming renderer: its bricks read from the store's levels (coarser ones reduced
    /// by the mode), each voxel's label mapped to its color's slot as it arrives, colored by
    /// `given` (`image-label`) else the palette, `hidden` labels transparent. At most 255
    /// visible colors (the palette's 20 and those `image-label` gives).
    #[allow(clippy::too_many_arguments)]
    pub fn streamed(
        context: &GpuContext,
        name: &str,
        pyramid: Arc<Pyramid>,
        given: &[LabelColor],
        hidden: &[f64],
        opacity: f32,
        options: StreamOptions,
        max_wait: Duration,
    ) -> Result<Self, LabelError> {
        let inner = ZarrSource::new(pyramid)?.of_labels(true);
        let quantization = inner.quantization();
        let top = inner.max_value_level();
        let mut slots: Vec<[u8; 4]> = Vec::new();
        let mut slot_of_color: HashMap<[u8; 4], usize> = HashMap::new();
        let mut codes = vec![0u8; 1 << 16];
        for (level, code) in codes.iter_mut().enumerate().take(top as usize + 1) {
            let value = quantization.value(level as u16);
            let color = label_color(value, given);
            if color[3] == 0 || hidden.contains(&value) {
                continue;
            }
            let next = slots.len() + 1;
            let slot = *slot_of_color.entry(color).or_insert(next);
            if slot == next {
                slots.push(color);
            }
            *code = u8::try_from(slot).map_err(|_| LabelError::TooManyColors(name.to_owned()))?;
        }
        let source = SlotBricks {
            inner: Box::new(inner),
            codes,
        };
        let renderer =
            VolumeRenderer::new_stream(context, Arc::new(source), options, &slot_transfer())
                .map_err(|error| LabelError::Render {
                    name: name.to_owned(),
                    error,
                })?;
        Ok(Self {
            name: name.to_owned(),
            slots,
            opacity: opacity.clamp(0.0, 1.0),
            renderers: vec![renderer],
            streamed: Some(max_wait),
        })
    }

    /// The slot of each pixel of `target` (0: no visible label), drawn with the image's
    /// `camera` and `settings` and waited for.
    pub fn draw_slots(
        &mut self,
        context: &GpuContext,
        target: &RenderTarget,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<Vec<u16>, LabelError> {
        let settings = label_pass_settings(settings);
        let mut slots = vec![0u16; (target.width * target.height) as usize];
        for (pass, renderer) in self.renderers.iter_mut().enumerate() {
            match self.streamed {
                Some(max_wait) => {
                    crate::refine(context, renderer, target, camera, &settings, max_wait).map_err(
                        |error| LabelError::Streamed {
                            name: self.name.clone(),
                            error: Box::new(error),
                        },
                    )?;
                }
                None => {
                    renderer.render(context, target, camera, &settings);
                    context.wait_idle()?;
                }
            }
            let image = read_image(context, target)?;
            for (slot, pixel) in slots.iter_mut().zip(image.into_raw().chunks_exact(4)) {
                let code = pixel[0] as u16;
                if pass == 0 {
                    *slot = code;
                } else if *slot > 0 && code > 0 {
                    *slot += (code - 1) * SLOTS_PER_PASS as u16;
                }
            }
        }
        Ok(slots)
    }

    /// Blends the labels of `slots` (one per pixel, [`Self::draw_slots`]) over `rgba` (the
    /// image's pixels, 4 bytes each): `image · (1 − a) + color · a`, `a` = the layer's
    /// opacity × the color's alpha; pixels of slot 0 are left as they are.
    pub fn blend(&self, rgba: &mut [u8], slots: &[u16]) {
        blend_slots(rgba, slots, &self.slots, self.opacity);
    }

    /// Composes the labels of `slots` over `premultiplied` (4 numbers 0…1 a pixel, its colors
    /// premultiplied by its alpha: an overlay of layers drawn before, transparent at first), at
    /// the layer's opacity × each color's alpha; what a UI paints over the image's picture.
    pub fn compose(&self, premultiplied: &mut [f32], slots: &[u16]) {
        for (pixel, &slot) in premultiplied.chunks_exact_mut(4).zip(slots) {
            let Some(color) = (slot as usize)
                .checked_sub(1)
                .and_then(|index| self.slots.get(index))
            else {
                continue;
            };
            let alpha = self.opacity * color[3] as f32 / 255.0;
            for c in 0..3 {
                pixel[c] = color[c] as f32 / 255.0 * alpha + pixel[c] * (1.0 - alpha);
            }
            pixel[3] = alpha + pixel[3] * (1.0 - alpha);
        }
    }
}

/// [`UploadedLabels::blend`] with the slots' colors and the opacity given.
pub fn blend_slots(rgba: &mut [u8], slots: &[u16], colors: &[[u8; 4]], opacity: f32) {
    for (pixel, &slot) in rgba.chunks_exact_mut(4).zip(slots) {
        let Some(color) = (slot as usize)
            .checked_sub(1)
            .and_then(|index| colors.get(index))
        else {
            continue;
        };
        let alpha = opacity * color[3] as f32 / 255.0;
        for c in 0..3 {
            let mixed = pixel[c] as f32 * (1.0 - alpha) + color[c] as f32 * alpha;
            pixel[c] = mixed.round().clamp(0.0, 255.0) as u8;
        }
    }
}

/// A label pyramid's bricks as slot codes, for the streaming renderer: each brick as `inner`
/// reads it (label volumes' coarser levels reduced by the mode), each value level mapped
/// through `codes` (0: transparent).
struct SlotBricks {
    inner: Box<dyn BrickSource>,
    codes: Vec<u8>,
}

impl BrickSource for SlotBricks {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn shape(&self) -> &PyramidShape {
        self.inner.shape()
    }

    fn spacing(&self) -> [f64; 3] {
        self.inner.spacing()
    }

    fn quantization(&self) -> Quantization {
        Quantization {
            offset: 0.0,
            step: 1.0,
        }
    }

    fn max_value_level(&self) -> u16 {
        SLOTS_PER_PASS as u16
    }

    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        let mut data = self.inner.read_brick(id)?;
        let (mut min, mut max) = (u16::MAX, 0u16);
        for level in &mut data.levels {
            let code = self.codes.get(*level as usize).copied().unwrap_or(0) as u16;
            *level = code;
            min = min.min(code);
            max = max.max(code);
        }
        // The apron's codes are counted too: a range a little wider than the brick's own
        // voxels only skips less.
        data.range = ValueRange {
            min: min.min(max),
            max,
        };
        Ok(data)
    }

    fn remote_stats(&self) -> Option<voxscope_volume::remote::RemoteStats> {
        self.inner.remote_stats()
    }

    fn can_fetch_ahead(&self) -> bool {
        self.inner.can_fetch_ahead()
    }

    fn fetch_ahead(&self, ids: &[BrickId]) {
        self.inner.fetch_ahead(ids);
    }

    fn reserve_decoded_caches(&self, ram: u64) -> u64 {
        self.inner.reserve_decoded_caches(ram)
    }

    fn reserve_fetch_cache(&self, ram: u64) -> u64 {
        self.inner.reserve_fetch_cache(ram)
    }

    fn fetch_store(&self) -> Option<usize> {
        self.inner.fetch_store()
    }

    fn cached_bytes(&self) -> u64 {
        self.inner.cached_bytes()
    }

    fn chunks_decoded(&self) -> u64 {
        self.inner.chunks_decoded()
    }

    fn labels(&self) -> bool {
        true
    }
}

/// The pyramid of label image `label` of the OME-Zarr image opened from `image_spec`
/// (`image`), and its spec: refused where its resolution 0 is not the image's (one line naming
/// both grids). Labels in memory and streamed labels both open theirs through it.
pub(crate) fn open_label_pyramid(
    image: &Pyramid,
    image_spec: &str,
    label: &LabelImage,
    remote: RemoteOptions,
) -> Result<(String, Pyramid), LabelError> {
    let spec = image.label_spec(image_spec, label);
    let pyramid = Pyramid::open_spec(&spec, Selection::default(), remote)?;
    let (Some(finest), Some(image_finest)) = (pyramid.levels.first(), image.levels.first()) else {
        return Err(LabelError::NoLevels(spec));
    };
    if finest.dims != image_finest.dims {
        return Err(LabelError::OffGrid {
            name: spec,
            dims: finest.dims,
            image_dims: image_finest.dims,
        });
    }
    Ok((spec, pyramid))
}
