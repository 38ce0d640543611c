//! Wheel notches, counted once each. On X11, winit 0.30 reports a wheel that arrives as mouse
//! buttons 4–7 (xdotool, VNC and xpra, evdev's wheel emulation) twice, on the button's press
//! and on its release (winit issue 1606, fixed upstream by PR 4386 after 0.30.13), while a
//! wheel that arrives as scroll-valuator motion (libinput) comes once. Both are whole-line
//! events of ±1, and the two of a pair may land in consecutive frames (which on a slow device
//! are far apart), so no frame tells them apart. Their count does: a doubling wheel's events
//! come in pairs, so at rest (a frame without one between, and [`REST`] since the last) their
//! running count is even; once it is found odd, the wheel reports each notch once. Until then
//! the counter takes the first event of each pair as the notch (at once, whichever frame the
//! second lands in). Fractional lines (high-resolution wheels) and point deltas (touchpads) add
//! up to whole notches instead.

use egui::{Event, MouseWheelUnit};

/// Points of a pixel-precise scroll (a touchpad's) that make one notch.
const POINTS_PER_NOTCH: f32 = 50.0;

/// A pause after which a doubling wheel has delivered both events of every notch.
pub const REST: f64 = 0.25;

/// What is known of the wheel between frames.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WheelNotches {
    /// The wheel was found to report each notch once.
    single_events: bool,
    /// Whole-line events so far.
    events: u64,
    /// When the last whole-line event came: egui's frame number and input time (seconds).
    last_event: Option<(u64, f64)>,
    /// Notches of fractional and point deltas not yet stepped, signed.
    remainder: f32,
}

impl WheelNotches {
    /// The notches of vertical wheel movement in `events` (those of frame number `frame`, at
    /// input time `time` in seconds), positive away from the user (up), those with the command
    /// key (zoom) left out.
    pub fn count(&mut self, events: &[Event], frame: u64, time: f64) -> i32 {
        let mut notches = 0i32;
        for event in events {
            let Event::MouseWheel {
                unit,
                delta,
                modifiers,
                ..
            } = event
            else {
                continue;
            };
            if modifiers.command || delta.y == 0.0 {
                continue;
            }
            match unit {
                MouseWheelUnit::Line | MouseWheelUnit::Page if delta.y.abs() == 1.0 => {
                    let rested = self.last_event.is_none_or(|(last_frame, last_time)| {
                        frame >= last_frame + 2 && time - last_time >= REST
                    });
                    if rested && self.events % 2 == 1 {
                        self.single_events = true;
                    }
                    if self.single_events || self.events.is_multiple_of(2) {
                        notches += delta.y as i32;
                    }
                    self.events += 1;
                    self.last_event = Some((frame, time));
                }
                MouseWheelUnit::Line | MouseWheelUnit::Page => self.remainder += delta.y,
                MouseWheelUnit::Point => self.remainder += delta.y / POINTS_PER_NOTCH,
            }
        }
        let fractional = self.remainder.trunc();
        self.remainder -= fractional;
        notches + fractional as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wheel(unit: MouseWheelUnit, y: f32) -> Event {
        Event::MouseWheel {
            unit,
            delta: egui::vec2(0.0, y),
            phase: egui::TouchPhase::Move,
            source: egui::MouseWheelSource::Unknown,
            modifiers: egui::Modifiers::NONE,
        }
    }

    #[test]
    fn a_notch_reported_on_press_and_release_is_one_step_in_one_frame_or_two() {
        let mut notches = WheelNotches::default();
        let up = || wheel(MouseWheelUnit::Line, 1.0);
        let down = || wheel(MouseWheelUnit::Line, -1.0);
        assert_eq!(notches.count(&[up(), up()], 1, 0.0), 1);
        assert_eq!(notches.count(&[down(), down()], 5, 1.0), -1);
        // The press in one frame, the release in the next, half a second later (a slow frame).
        assert_eq!(notches.count(&[down()], 9, 2.0), -1);
        assert_eq!(notches.count(&[down()], 10, 2.5), 0);
        assert_eq!(notches.count(&[up(), up(), up(), up()], 14, 3.0), 2);
        assert_eq!(notches.count(&[], 15, 4.0), 0);
    }

    #[test]
    fn a_wheel_that_reports_once_counts_every_event_once_found_odd_at_rest() {
        let mut notches = WheelNotches::default();
        let up = || wheel(MouseWheelUnit::Line, 1.0);
        assert_eq!(notches.count(&[up()], 1, 0.0), 1);
        // After a pause the count is odd: no doubling wheel leaves it so.
        assert_eq!(notches.count(&[up()], 5, 1.0), 1);
        assert_eq!(notches.count(&[up(), up()], 6, 1.01), 2);
        assert_eq!(notches.count(&[up()], 7, 1.02), 1);
    }

    #[test]
    fn fractions_and_points_add_up_to_notches_and_zoom_is_not_a_notch() {
        let mut notches = WheelNotches::default();
        let eighth = wheel(MouseWheelUnit::Line, 0.125);
        assert_eq!(notches.count(&vec![eighth.clone(); 7], 1, 0.0), 0);
        assert_eq!(notches.count(&[eighth], 2, 0.1), 1);
        assert_eq!(
            notches.count(&[wheel(MouseWheelUnit::Point, -120.0)], 3, 0.2),
            -2
        );
        let zoom = Event::MouseWheel {
            unit: MouseWheelUnit::Line,
            delta: egui::vec2(0.0, 1.0),
            phase: egui::TouchPhase::Move,
            source: egui::MouseWheelSource::Unknown,
            modifiers: egui::Modifiers::COMMAND,
        };
        assert_eq!(notches.count(&[zoom], 4, 0.3), 0);
    }
}
