//! Bricks into the atlas: a step's uploads staged through the ring and copied or scattered
//! into their slots (the first write zeroes an atlas made without wgpu's fill), the changed
//! page-table entries written, and the upload rate measured.

use super::*;

impl StreamVolume {
    /// Writes `uploads` into their atlas slots (through the staging ring, the rest through the
    /// queue while no ring buffer is mapped) and the page table's changed entries; tells the
    /// streamer what that cost.
    pub(super) fn write(&mut self, context: &GpuContext, uploads: &[Upload]) {
        if std::mem::take(&mut self.unzeroed) {
            // On the frame's thread: an app's loading thread, which made the volume, submits
            // nothing to the window's device (docs/architecture.md).
            let mut encoder =
                context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::stream_atlas_zero"),
                    });
            let zeroed = self.ring.zero_atlas(&mut encoder);
            assert!(zeroed, "an atlas zeroes itself only with a scattering ring");
            context.queue.submit([encoder.finish()]);
            self.skip_upload_rate = true;
        }
        let started = Instant::now();
        let side = PADDED_BRICK as u32;
        let [gx, gy, _] = self.atlas_grid.map(|g| g as u32);
        let origin = |slot: u32| wgpu::Origin3d {
            x: (slot % gx) * side,
            y: ((slot / gx) % gy) * side,
            z: (slot / (gx * gy)) * side,
        };
        let mut parts = UploadParts::default();
        let mut staged = Vec::new();
        if !uploads.is_empty() {
            let bricks: Vec<StagedBrick<'_>> = uploads
                .iter()
                .take(self.ring.bricks_per_buffer())
                .map(|upload| StagedBrick {
                    texels: &upload.texels,
                    origin: origin(upload.slot),
                })
                .collect();
            let mut encoder =
                context
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("voxscope::stream_uploads"),
                    });
            let timing = self.copy_timer.as_mut().and_then(|t| t.begin(&mut encoder));
            let staging = self.ring.stage(&mut encoder, &self.atlas, &bricks);
            staged = staging.staged;
            parts.ring_copies = staging.copies as u64;
            parts.scatter_dispatches = staging.dispatches as u64;
            parts.staging_seconds = staging.staging_seconds;
            let submitting = Instant::now();
            if staged.contains(&true) {
                if let (Some(timer), Some(timing)) = (self.copy_timer.as_mut(), timing) {
                    let bytes = bricks
                        .iter()
                        .zip(&staged)
                        .filter(|(_, staged)| **staged)
                        .map(|(brick, _)| brick.texels.len() as u64)
                        .sum();
                    timer.end(&mut encoder, timing, bytes);
                }
                context.queue.submit([encoder.finish()]);
                self.ring.submitted();
                if let Some(timer) = self.copy_timer.as_mut() {
                    timer.submitted();
                }
            }
            parts.submit_seconds = staging.record_seconds + submitting.elapsed().as_secs_f64();
        }
        let queueing = Instant::now();
        staged.resize(uploads.len(), false);
        let to_queue = uploads.iter().zip(&staged).filter(|(_, staged)| !**staged);
        for (upload, _) in to_queue {
            context.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &self.atlas,
                    mip_level: 0,
                    origin: origin(upload.slot),
                    aspect: wgpu::TextureAspect::All,
                },
                &upload.texels,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(side * self.texels.bytes() as u32),
                    rows_per_image: Some(side),
                },
                wgpu::Extent3d {
                    width: side,
                    height: side,
                    depth_or_array_layers: side,
                },
            );
        }
        parts.queue_seconds = queueing.elapsed().as_secs_f64();
        parts.ring_bricks = staged.iter().filter(|&&s| s).count() as u64;
        parts.queue_bricks = uploads.len() as u64 - parts.ring_bricks;
        // The first uploads after the zero pass count their time but set no rate.
        let skip_rate = !uploads.is_empty() && std::mem::take(&mut self.skip_upload_rate);
        let bytes: u64 = if skip_rate {
            0
        } else {
            uploads.iter().map(|u| u.texels.len() as u64).sum()
        };
        self.streamer
            .set_upload_cost(bytes, started.elapsed().as_secs_f64(), &parts);
        let entry_bytes = std::mem::size_of::<TableEntry>() as u64;
        for (start, entries) in self.streamer.table_mut().take_dirty() {
            context.queue.write_buffer(
                &self.table,
                start as u64 * entry_bytes,
                bytemuck::cast_slice(entries),
            );
        }
        if let Some((start, cells)) = self.streamer.table_mut().take_level_dirty() {
            context.queue.write_buffer(
                &self.level_cells,
                start as u64 * entry_bytes,
                bytemuck::cast_slice(cells),
            );
        }
    }
}
