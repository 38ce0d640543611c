//! Picking in the 3D view: the point the ray under the pointer reaches half opacity (the
//! maximum, in MIP), found by the GPU probe for that one pixel without stalling a frame. Hover
//! asks for the status bar's voxel; a click moves the cursor there, or with the Ruler tool sets
//! a ruler's ends. At most one probe is in flight; the latest request waits behind it.

use egui::{Rect, Ui};

use super::AppGpu;
use super::settings::Tool;
use super::view_state::{Ruler, ViewState};
use super::viewport::DrawKey;
use voxscope_render::{GpuProbe, ProbeRequest};
use voxscope_scene::Scene;

/// Picking points in the 3D view: the GPU probe, and what its answers are for.
pub struct Picking {
    probe: GpuProbe,
    /// The next pixel to probe (the latest the pointer asked for).
    wanted: Option<PickRequest>,
    /// The probe on its way back.
    in_flight: Option<PickRequest>,
    /// The voxel-space point under the pointer, as last probed.
    hovered: Option<[f64; 3]>,
    /// The first end of a ruler measured in the 3D view.
    ruler_start: Option<[f64; 3]>,
}

/// A pixel of a 3D pane to probe, and why.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PickRequest {
    pane: usize,
    pixel: [u32; 2],
    purpose: PickPurpose,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PickPurpose {
    /// The status bar's value under the pointer.
    Hover,
    /// A click: move the cursor there, or a ruler's end.
    Click,
}

impl Picking {
    /// Nothing picked yet, on `gpu`.
    pub fn new(gpu: &AppGpu) -> Self {
        Self {
            probe: GpuProbe::new(&gpu.context),
            wanted: None,
            in_flight: None,
            hovered: None,
            ruler_start: None,
        }
    }

    /// True while a probe is asked for or on its way back.
    pub fn is_busy(&self) -> bool {
        self.in_flight.is_some() || self.wanted.is_some()
    }

    /// The voxel-space point under the pointer in a 3D view, as last picked.
    pub fn hovered(&self) -> Option<[f64; 3]> {
        self.hovered
    }

    /// Forgets the hovered point (the pointer left the 3D views).
    pub fn clear_hover(&mut self) {
        self.hovered = None;
    }

    /// Takes the GPU's answer once it is there: for a click, the cursor moves to the point,
    /// or with the Ruler tool the point ends (or starts) a ruler in `view`.
    /// `scale` takes the renderer's voxel space to the view's.
    pub fn poll(&mut self, gpu: &AppGpu, view: &mut ViewState, tool: Tool, scale: [f64; 3]) {
        let Some(outcome) = self.probe.poll(&gpu.context) else {
            return;
        };
        let Some(request) = self.in_flight.take() else {
            return;
        };
        let point = outcome
            .hit
            .map(|hit| std::array::from_fn(|a| f64::from(hit.point[a]) * scale[a]));
        self.hovered = point;
        let (PickPurpose::Click, Some(point)) = (request.purpose, point) else {
            return;
        };
        match tool {
            Tool::Navigate => view.cursor = point,
            Tool::Ruler => match self.ruler_start.take() {
                Some(from) => view.rulers.push(Ruler { from, to: point }),
                None => self.ruler_start = Some(point),
            },
        }
    }

    /// Probes the pixel a pane's pointer asked for, if the probe is free, as the pane's last
    /// frame (`drawn`, by pane) drew it.
    pub fn record(&mut self, gpu: &AppGpu, scene: &Scene, drawn: &[Option<DrawKey>]) {
        if !self.probe.is_idle() {
            return;
        }
        let Some(request) = self.wanted.take() else {
            return;
        };
        let Some(Some(DrawKey::Volume {
            size,
            camera,
            settings,
            ..
        })) = drawn.get(request.pane).copied()
        else {
            return;
        };
        let pixel = [
            request.pixel[0].min(size[0].saturating_sub(1)),
            request.pixel[1].min(size[1].saturating_sub(1)),
        ];
        let mut encoder =
            gpu.context
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("voxscope::app_pick"),
                });
        // The composite's renderer where it has its own (in memory), else the scene's.
        let renderer = match &scene.composite {
            Some(composite) => composite.renderer(&scene.renderer),
            None => &scene.renderer,
        };
        let probe_request = ProbeRequest {
            size,
            pixel,
            camera: &camera,
            settings: &settings,
        };
        match self
            .probe
            .record(&gpu.context, &mut encoder, renderer, &probe_request)
        {
            Ok(true) => {
                gpu.context.queue.submit([encoder.finish()]);
                self.probe.submitted();
                self.in_flight = Some(request);
            }
            Ok(false) => self.wanted = Some(request),
            Err(error) => eprintln!("voxscope: error: {error}"),
        }
    }

    /// Asks for the point under the pointer of pane `index` (`rect`, its image `target`
    /// pixels): on a click, or when the pointer moved over it.
    pub fn want(
        &mut self,
        response: &egui::Response,
        ui: &Ui,
        index: usize,
        rect: Rect,
        target: [u32; 2],
    ) {
        let Some(pointer) = response.hover_pos() else {
            return;
        };
        let pixel = [
            ((pointer.x - rect.left()) / rect.width().max(1.0) * target[0] as f32) as u32,
            ((pointer.y - rect.top()) / rect.height().max(1.0) * target[1] as f32) as u32,
        ];
        let purpose = if response.clicked() {
            PickPurpose::Click
        } else if ui.input(|i| i.pointer.delta() != egui::Vec2::ZERO) && !response.dragged() {
            PickPurpose::Hover
        } else {
            return;
        };
        // A click is never replaced by a later hover.
        if self.wanted.is_none_or(|w| w.purpose == PickPurpose::Hover) {
            self.wanted = Some(PickRequest {
                pane: index,
                pixel,
                purpose,
            });
        }
    }
}
