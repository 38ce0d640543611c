//! The frames of a movie: a turntable (a full turn about the vertical axis) or a path through
//! keyframe views. The camera moves on its orbit (azimuth, elevation, distance: never a straight
//! line through the volume), along a Catmull-Rom spline through the keyframes; what is
//! continuous in the rest of a view (the window, the opacity curve's points, the threshold,
//! the density, shading's weights, the clip box and plane, the level) is interpolated with a
//! smoothstep per segment, and what is not (the colormap, the mode, shading on or off, a clip
//! that appears) switches at the segment's midpoint.

use voxscope_octree::{Clip, ClipPlane, ControlPoint, OpacityCurve, OpacityMode, TransferFunction};
use voxscope_render::{Camera, RenderSettings, Shading};
use voxscope_volume::ValueWindow;

use crate::ChannelState;

/// What one frame draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shot {
    pub camera: Camera,
    pub settings: RenderSettings,
    pub transfer: TransferFunction,
}

/// `frames` shots of a full turn about the vertical axis, starting at `shot`'s azimuth (the
/// last one a step short of the first, so that the movie loops).
pub fn turntable(shot: &Shot, frames: usize) -> Vec<Shot> {
    (0..frames)
        .map(|frame| {
            let mut turned = *shot;
            turned.camera.azimuth_deg =
                shot.camera.azimuth_deg + 360.0 * frame as f64 / frames as f64;
            turned
        })
        .collect()
}

/// The shots through `keys`: `frames_per_segment` from each key towards the next, then the
/// last key itself, so that the movie starts at the first view and ends at the last exactly.
pub fn keyframe_path(keys: &[Shot], frames_per_segment: usize) -> Vec<Shot> {
    let Some(last) = keys.last() else {
        return Vec::new();
    };
    // Azimuths unwrapped, each within half a turn of the one before: the short way round.
    let mut azimuths: Vec<f64> = Vec::with_capacity(keys.len());
    for key in keys {
        let azimuth = key.camera.azimuth_deg;
        let unwrapped = match azimuths.last() {
            Some(&before) => before + (azimuth - before + 180.0).rem_euclid(360.0) - 180.0,
            None => azimuth,
        };
        azimuths.push(unwrapped);
    }
    let mut shots = Vec::with_capacity((keys.len() - 1) * frames_per_segment + 1);
    for segment in 0..keys.len() - 1 {
        let at = |i: isize| -> usize { i.clamp(0, keys.len() as isize - 1) as usize };
        let index = [
            at(segment as isize - 1),
            segment,
            segment + 1,
            at(segment as isize + 2),
        ];
        for frame in 0..frames_per_segment {
            let t = frame as f64 / frames_per_segment as f64;
            if frame == 0 {
                shots.push(keys[segment]);
                continue;
            }
            let spline = |value: &dyn Fn(usize) -> f64| catmull_rom(index.map(value), t);
            let camera = Camera {
                azimuth_deg: spline(&|k| azimuths[k]),
                elevation_deg: spline(&|k| keys[k].camera.elevation_deg),
                // Distance on a log scale: zooming in reads as even.
                distance: spline(&|k| keys[k].camera.distance.ln()).exp(),
                fov_y_deg: spline(&|k| keys[k].camera.fov_y_deg),
                pan: [0, 1, 2].map(|axis| spline(&|k| keys[k].camera.pan[axis])),
            };
            let (a, b) = (&keys[segment], &keys[segment + 1]);
            let s = smoothstep(t);
            shots.push(Shot {
                camera,
                settings: settings_between(&a.settings, &b.settings, s),
                transfer: transfer_between(&a.transfer, &b.transfer, s),
            });
        }
    }
    shots.push(*last);
    shots
}

/// The composite's channels for each shot of [`keyframe_path`] through keys whose channels are
/// `keys`: each channel's window and transfer function interpolated as the keys' own, its
/// color blended, its visibility switched at the segment's midpoint; keys of different channel
/// counts switch there whole.
pub fn keyframe_channels(
    keys: &[Vec<ChannelState>],
    frames_per_segment: usize,
) -> Vec<Vec<ChannelState>> {
    let Some(last) = keys.last() else {
        return Vec::new();
    };
    let mut frames = Vec::with_capacity((keys.len() - 1) * frames_per_segment + 1);
    for pair in keys.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        for frame in 0..frames_per_segment {
            let s = smoothstep(frame as f64 / frames_per_segment as f64);
            frames.push(if frame == 0 {
                a.clone()
            } else if a.len() == b.len() {
                a.iter()
                    .zip(b)
                    .map(|(x, y)| ChannelState {
                        name: x.name.clone(),
                        color: std::array::from_fn(|c| {
                            lerp(x.color[c] as f64, y.color[c] as f64, s).round() as u8
                        }),
                        visible: switch(x.visible, y.visible, s),
                        transfer: transfer_between(&x.transfer, &y.transfer, s),
                    })
                    .collect()
            } else {
                switch(a, b, s).clone()
            });
        }
    }
    frames.push(last.clone());
    frames
}

/// The Catmull-Rom spline through `p[1]` (t = 0) and `p[2]` (t = 1).
fn catmull_rom(p: [f64; 4], t: f64) -> f64 {
    let (t2, t3) = (t * t, t * t * t);
    0.5 * (2.0 * p[1]
        + (p[2] - p[0]) * t
        + (2.0 * p[0] - 5.0 * p[1] + 4.0 * p[2] - p[3]) * t2
        + (3.0 * p[1] - p[0] - 3.0 * p[2] + p[3]) * t3)
}

fn smoothstep(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

fn lerp(a: f64, b: f64, s: f64) -> f64 {
    a + (b - a) * s
}

fn lerp32(a: f32, b: f32, s: f64) -> f32 {
    lerp(a as f64, b as f64, s) as f32
}

/// `a` before the midpoint, `b` from it on.
fn switch<T: Copy>(a: T, b: T, s: f64) -> T {
    if s < 0.5 { a } else { b }
}

fn settings_between(a: &RenderSettings, b: &RenderSettings, s: f64) -> RenderSettings {
    let shading = if a.shading.enabled == b.shading.enabled {
        Shading {
            enabled: a.shading.enabled,
            ambient: lerp32(a.shading.ambient, b.shading.ambient, s),
            diffuse: lerp32(a.shading.diffuse, b.shading.diffuse, s),
            specular: lerp32(a.shading.specular, b.shading.specular, s),
            shininess: lerp32(a.shading.shininess, b.shading.shininess, s),
        }
    } else {
        switch(a.shading, b.shading, s)
    };
    RenderSettings {
        mode: switch(a.mode, b.mode, s),
        max_level: lerp(a.max_level as f64, b.max_level as f64, s).round() as u32,
        pixel_lod: switch(a.pixel_lod, b.pixel_lod, s),
        opacity_correction: switch(a.opacity_correction, b.opacity_correction, s),
        density: lerp32(a.density, b.density, s),
        heatmap: switch(a.heatmap, b.heatmap, s),
        trilinear: switch(a.trilinear, b.trilinear, s),
        shading,
        clip: clip_between(&a.clip, &b.clip, s),
    }
}

fn clip_between(a: &Clip, b: &Clip, s: f64) -> Clip {
    let bounds = match (a.bounds, b.bounds) {
        (Some(a), Some(b)) => Some(std::array::from_fn(|axis| {
            [0, 1].map(|side| lerp32(a[axis][side], b[axis][side], s))
        })),
        (a, b) => switch(a, b, s),
    };
    let plane = match (a.plane, b.plane) {
        (Some(a), Some(b)) => {
            let normal = [0, 1, 2].map(|axis| lerp32(a.normal[axis], b.normal[axis], s));
            // Opposite normals pass through zero: no plane there, so switch instead.
            if normal.iter().map(|n| n * n).sum::<f32>() > 1e-6 {
                Some(ClipPlane {
                    normal,
                    distance: lerp32(a.distance, b.distance, s),
                })
            } else {
                switch(Some(a), Some(b), s)
            }
        }
        (a, b) => switch(a, b, s),
    };
    Clip { bounds, plane }
}

fn transfer_between(a: &TransferFunction, b: &TransferFunction, s: f64) -> TransferFunction {
    let opacity = match (a.opacity, b.opacity) {
        (OpacityMode::Points(ca), OpacityMode::Points(cb))
            if ca.points().len() == cb.points().len() =>
        {
            let points: Vec<ControlPoint> = ca
                .points()
                .iter()
                .zip(cb.points())
                .map(|(pa, pb)| ControlPoint {
                    value: lerp(pa.value, pb.value, s),
                    opacity: lerp32(pa.opacity, pb.opacity, s),
                    color: match (pa.color, pb.color) {
                        (Some(x), Some(y)) => Some(std::array::from_fn(|c| {
                            lerp(x[c] as f64, y[c] as f64, s).round() as u8
                        })),
                        (x, y) => switch(x, y, s),
                    },
                })
                .collect();
            // Sorted points stay sorted when both ends are: the curve is valid.
            OpacityCurve::new(&points).map_or(switch(a.opacity, b.opacity, s), OpacityMode::Points)
        }
        (x, y) => switch(x, y, s),
    };
    TransferFunction {
        opacity,
        window: ValueWindow {
            low: lerp(a.window.low, b.window.low, s),
            high: lerp(a.window.high, b.window.high, s),
        },
        threshold: lerp32(a.threshold, b.threshold, s),
        colormap: switch(a.colormap, b.colormap, s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use voxscope_octree::Colormap;
    use voxscope_render::RenderMode;

    fn shot(azimuth: f64, distance: f64, low: f64) -> Shot {
        Shot {
            camera: Camera {
                azimuth_deg: azimuth,
                distance,
                ..Camera::default()
            },
            settings: RenderSettings {
                mode: RenderMode::Dvr,
                max_level: 6,
                pixel_lod: false,
                opacity_correction: true,
                density: 1.0,
                heatmap: false,
                trilinear: true,
                shading: Shading::default(),
                clip: Clip::NONE,
            },
            transfer: TransferFunction {
                opacity: OpacityMode::Gray,
                window: ValueWindow { low, high: 100.0 },
                threshold: 0.3,
                colormap: Colormap::Grays,
            },
        }
    }

    #[test]
    fn a_turntable_turns_once_from_its_azimuth() {
        let shots = turntable(&shot(30.0, 3.0, 0.0), 12);
        assert_eq!(shots.len(), 12);
        assert_eq!(shots[0], shot(30.0, 3.0, 0.0));
        assert_eq!(shots[3].camera.azimuth_deg, 120.0);
        assert!((shots[11].camera.azimuth_deg - 360.0).abs() < 1e-9);
    }

    #[test]
    fn a_path_starts_and_ends_at_its_keys_and_goes_the_short_way_round() {
        let (a, b) = (shot(350.0, 2.0, 0.0), shot(20.0, 4.0, 50.0));
        let shots = keyframe_path(&[a, b], 10);
        assert_eq!(shots.len(), 11);
        assert_eq!(shots[0], a);
        assert_eq!(shots[10], b);
        for pair in shots.windows(2) {
            let step = pair[1].camera.azimuth_deg - pair[0].camera.azimuth_deg;
            // 350° to 20° is 30° forward (to 380°), not 330° back.
            assert!(step.rem_euclid(360.0) < 10.0, "{step}");
        }
        let middle = shots[5];
        assert!(middle.camera.distance > 2.0 && middle.camera.distance < 4.0);
        assert!(middle.transfer.window.low > 0.0 && middle.transfer.window.low < 50.0);
    }

    #[test]
    fn each_channel_of_a_composite_path_follows_its_own_keys() {
        let channel = |color: [u8; 3], low: f64, visible: bool| ChannelState {
            name: "c".into(),
            color,
            visible,
            transfer: shot(0.0, 3.0, low).transfer,
        };
        let a = vec![
            channel([0, 255, 0], 0.0, true),
            channel([255, 0, 255], 10.0, true),
        ];
        let b = vec![
            channel([0, 255, 0], 40.0, true),
            channel([255, 0, 0], 10.0, false),
        ];
        let frames = keyframe_channels(&[a.clone(), b.clone()], 4);
        assert_eq!(frames.len(), 5);
        assert_eq!(frames[0], a);
        assert_eq!(frames[4], b);
        let middle = &frames[2];
        assert!(middle[0].transfer.window.low > 0.0 && middle[0].transfer.window.low < 40.0);
        assert_eq!(middle[1].transfer.window.low, 10.0);
        assert!(middle[1].color[2] > 0 && middle[1].color[2] < 255);
        assert!(frames[1][1].visible && !frames[3][1].visible);
    }

    #[test]
    fn discrete_settings_switch_at_the_midpoint() {
        let a = shot(0.0, 3.0, 0.0);
        let mut b = a;
        b.settings.mode = RenderMode::Mip;
        b.transfer.colormap = Colormap::Viridis;
        let shots = keyframe_path(&[a, b], 4);
        let modes: Vec<RenderMode> = shots.iter().map(|s| s.settings.mode).collect();
        assert_eq!(
            modes,
            [
                RenderMode::Dvr,
                RenderMode::Dvr,
                RenderMode::Mip,
                RenderMode::Mip,
                RenderMode::Mip
            ]
        );
        assert_eq!(shots[1].transfer.colormap, Colormap::Grays);
        assert_eq!(shots[3].transfer.colormap, Colormap::Viridis);
    }
}
