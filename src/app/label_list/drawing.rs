//! The label overlay's drawing job: each layer read and uploaded once, drawn for the view,
//! read back and composed (`draw_overlay`); a label image over a streamed image streams from
//! its own pyramid (`draw_streamed`).

use super::*;

/// Draws the overlay of `key`'s view: every layer of `sources` read (once) and uploaded (once
/// per hidden set and renderer), drawn, read back and composed in order.
pub(super) fn draw_overlay(
    context: &GpuContext,
    cache: &mut OverlayCache,
    sources: &[(String, LayerSource)],
    key: OverlayKey,
) -> Result<DrawnOverlay, String> {
    let [width, height] = key.size;
    let mut premultiplied = vec![0f32; width as usize * height as usize * 4];
    let target = RenderTarget::new(context, width, height);
    let mut layers = Vec::new();
    for ((name, source), (_, hidden, opacity)) in sources.iter().zip(&key.layers) {
        if key.renderer.kind == RendererKind::Stream {
            layers.push(draw_streamed(
                context,
                cache,
                (name, source),
                hidden,
                *opacity,
                &key,
                &target,
                &mut premultiplied,
            )?);
            continue;
        }
        let overlay = match cache.loaded.get(name) {
            Some(overlay) => Arc::clone(overlay),
            None => {
                let (spec, dims) = &key.image;
                let overlay = Arc::new(match source {
                    LayerSource::Image(label) => {
                        let image =
                            Pyramid::open_spec(spec, Default::default(), RemoteOptions::default())
                                .map_err(|e| e.to_string())?;
                        LabelOverlay::open_label_image(
                            &image,
                            spec,
                            label,
                            *dims,
                            RemoteOptions::default(),
                        )
                        .map_err(|e| e.to_string())?
                    }
                    LayerSource::File(path) => {
                        LabelOverlay::open_file(path, *dims).map_err(|e| e.to_string())?
                    }
                });
                cache.loaded.insert(name.clone(), Arc::clone(&overlay));
                overlay
            }
        };
        let upload_key = UploadKey {
            hidden: hidden.clone(),
            renderer: key.renderer,
            max_level: key.settings.max_level,
        };
        if cache
            .uploaded
            .get(name)
            .is_none_or(|(uploaded_for, _)| *uploaded_for != upload_key)
        {
            let uploaded = overlay
                .layer(hidden, *opacity, key.spacing)
                .and_then(|layer| layer.upload(context, key.renderer, key.settings.max_level))
                .map_err(|e| e.to_string())?;
            cache.uploaded.insert(name.clone(), (upload_key, uploaded));
        }
        let (_, uploaded) = cache.uploaded.get_mut(name).expect("inserted above");
        uploaded.opacity = opacity.clamp(0.0, 1.0);
        let slots = uploaded
            .draw_slots(context, &target, &key.camera, &key.settings)
            .map_err(|e| e.to_string())?;
        uploaded.compose(&mut premultiplied, &slots);
        let listed = overlay
            .labels
            .iter()
            .take(LISTED_LABELS)
            .map(|&(value, _)| (value, overlay.color_of(value)))
            .collect();
        layers.push(DrawnLayer {
            name: name.clone(),
            overlay: Some(overlay),
            labels: listed,
        });
    }
    let bytes: Vec<u8> = premultiplied
        .iter()
        .map(|&c| (c * 255.0).round().clamp(0.0, 255.0) as u8)
        .collect();
    Ok(DrawnOverlay {
        image: ColorImage::from_rgba_premultiplied([width as usize, height as usize], &bytes),
        key,
        layers,
    })
}

/// A label image over a streamed image: streamed from its own pyramid (uploaded once per
/// hidden set), each view refined until complete on the job's thread, composed over
/// `premultiplied`. A label file is not drawn over a streamed image.
#[allow(clippy::too_many_arguments)]
fn draw_streamed(
    context: &GpuContext,
    cache: &mut OverlayCache,
    (name, source): (&String, &LayerSource),
    hidden: &[f64],
    opacity: f32,
    key: &OverlayKey,
    target: &RenderTarget,
    premultiplied: &mut [f32],
) -> Result<DrawnLayer, String> {
    let LayerSource::Image(label) = source else {
        return Err(format!(
            "{name}: a label file is not drawn over a streamed volume (label images of the store are)"
        ));
    };
    let upload_key = UploadKey {
        hidden: hidden.to_vec(),
        renderer: key.renderer,
        max_level: key.settings.max_level,
    };
    if cache
        .uploaded
        .get(name)
        .is_none_or(|(uploaded_for, _)| *uploaded_for != upload_key)
    {
        let (spec, _) = &key.image;
        let remote = RemoteOptions::default();
        let image =
            Pyramid::open_spec(spec, Default::default(), remote).map_err(|e| e.to_string())?;
        // The label's share of the image's budgets, as `render --labels` takes it.
        let look = StreamedLabelLook {
            hidden,
            opacity,
            image_options: StreamOptions {
                gpu_memory: key.renderer.gpu_memory,
                ..StreamOptions::default()
            },
            max_wait: STREAMED_LABELS_WAIT,
        };
        let uploaded = open_streamed_label(context, (&image, spec), label, remote, look)
            .map_err(|e| e.to_string())?;
        cache.uploaded.insert(name.clone(), (upload_key, uploaded));
    }
    let (_, uploaded) = cache.uploaded.get_mut(name).expect("inserted above");
    uploaded.opacity = opacity.clamp(0.0, 1.0);
    let slots = uploaded
        .draw_slots(context, target, &key.camera, &key.settings)
        .map_err(|e| e.to_string())?;
    uploaded.compose(premultiplied, &slots);
    Ok(DrawnLayer {
        name: name.clone(),
        overlay: None,
        // Only the colors image-label gives are known without reading every brick.
        labels: label.colors.iter().map(|c| (c.value, c.rgba)).collect(),
    })
}
