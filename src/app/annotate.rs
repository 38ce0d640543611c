//! Drawing the rulers and the axes gizmo into a saved screenshot: lines, end points, their
//! lengths and the axes' names in a small built-in pixel font (digits, a point, a space, the
//! letters of units and of the axes), so a PNG carries its measurements without a font
//! renderer.

use image::{Rgba, RgbaImage};

/// Glyphs 3 pixels wide and 5 high, one row per `u8` (the low 3 bits, left to right).
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b111, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b010, 0b010, 0b010],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
        ' ' => [0; 5],
        'm' => [0b000, 0b000, 0b111, 0b111, 0b101],
        'u' => [0b000, 0b000, 0b101, 0b101, 0b111],
        'n' => [0b000, 0b000, 0b110, 0b101, 0b101],
        'c' => [0b000, 0b000, 0b111, 0b100, 0b111],
        'µ' => [0b000, 0b101, 0b101, 0b111, 0b100],
        'Å' => [0b010, 0b000, 0b111, 0b101, 0b101],
        // The axes gizmo's names.
        'x' => [0b000, 0b000, 0b101, 0b010, 0b101],
        'y' => [0b000, 0b101, 0b111, 0b001, 0b110],
        'z' => [0b000, 0b111, 0b011, 0b110, 0b111],
        'R' => [0b110, 0b101, 0b110, 0b101, 0b101],
        'A' => [0b010, 0b101, 0b111, 0b101, 0b101],
        'S' => [0b111, 0b100, 0b111, 0b001, 0b111],
        _ => return None,
    })
}

/// Sets pixel (`x`, `y`) to `color` where it lies inside `image`.
fn put(image: &mut RgbaImage, x: i64, y: i64, color: Rgba<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < image.width() && (y as u32) < image.height() {
        image.put_pixel(x as u32, y as u32, color);
    }
}

/// A line from `a` to `b` (pixel positions) `width` pixels wide.
pub fn line(image: &mut RgbaImage, a: [f32; 2], b: [f32; 2], width: f32, color: Rgba<u8>) {
    let length = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
    let steps = (length * 2.0).ceil().max(1.0) as usize;
    let radius = (width / 2.0).max(0.5);
    for i in 0..=steps {
        let t = i as f32 / steps as f32;
        let center = [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];
        disc(image, center, radius, color);
    }
}

/// Darkens the pixels within `radius` of `center` to `keep` (0…1) of their color: the
/// gizmo's backdrop, as the window draws it.
pub fn shade_disc(image: &mut RgbaImage, center: [f32; 2], radius: f32, keep: f32) {
    let reach = radius.ceil() as i64;
    let (cx, cy) = (center[0].floor() as i64, center[1].floor() as i64);
    for dy in -reach..=reach {
        for dx in -reach..=reach {
            let (x, y) = (cx + dx, cy + dy);
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let inside = (px - center[0]).powi(2) + (py - center[1]).powi(2) <= radius * radius;
            if inside
                && x >= 0
                && y >= 0
                && (x as u32) < image.width()
                && (y as u32) < image.height()
            {
                let pixel = image.get_pixel_mut(x as u32, y as u32);
                for channel in &mut pixel.0[..3] {
                    *channel = (*channel as f32 * keep).round() as u8;
                }
            }
        }
    }
}

/// The width and height in pixels of `text` drawn at `scale` (without its box).
pub fn text_size(text: &str, scale: u32) -> [f32; 2] {
    let count = text.chars().filter(|&c| glyph(c).is_some()).count() as f32;
    let scale = scale.max(1) as f32;
    [(count * 4.0 - 1.0).max(0.0) * scale, 5.0 * scale]
}

/// A filled disc of `radius` pixels around `center`.
pub fn disc(image: &mut RgbaImage, center: [f32; 2], radius: f32, color: Rgba<u8>) {
    let reach = radius.ceil() as i64;
    let (cx, cy) = (center[0].floor() as i64, center[1].floor() as i64);
    for dy in -reach..=reach {
        for dx in -reach..=reach {
            let (px, py) = ((cx + dx) as f32 + 0.5, (cy + dy) as f32 + 0.5);
            if (px - center[0]).powi(2) + (py - center[1]).powi(2) <= radius * radius {
                put(image, cx + dx, cy + dy, color);
            }
        }
    }
}

/// `text` with its top-left corner at `at`, each font pixel `scale` pixels, on a dark box so it
/// reads on any image. Characters the font lacks are left out.
pub fn text(image: &mut RgbaImage, at: [f32; 2], text: &str, scale: u32, color: Rgba<u8>) {
    let glyphs: Vec<[u8; 5]> = text.chars().filter_map(glyph).collect();
    let scale = scale.max(1) as i64;
    let (x0, y0) = (at[0].round() as i64, at[1].round() as i64);
    let width = glyphs.len() as i64 * 4 * scale + scale;
    let background = Rgba([0, 0, 0, 200]);
    for y in y0 - scale..y0 + 6 * scale {
        for x in x0 - scale..x0 + width {
            put(image, x, y, background);
        }
    }
    for (index, rows) in glyphs.iter().enumerate() {
        let left = x0 + index as i64 * 4 * scale;
        for (row, bits) in rows.iter().enumerate() {
            for column in 0..3 {
                if bits & (0b100 >> column) != 0 {
                    for sy in 0..scale {
                        for sx in 0..scale {
                            put(
                                image,
                                left + column * scale + sx,
                                y0 + row as i64 * scale + sy,
                                color,
                            );
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_and_its_length_are_drawn_inside_the_image_only() {
        let mut image = RgbaImage::from_pixel(40, 20, Rgba([0, 0, 0, 255]));
        let white = Rgba([255, 255, 255, 255]);
        line(&mut image, [-10.0, 10.0], [50.0, 10.0], 2.0, white);
        assert_eq!(*image.get_pixel(20, 10), white);
        assert_eq!(*image.get_pixel(20, 2), Rgba([0, 0, 0, 255]));
        text(&mut image, [2.0, 2.0], "1.5 mm", 1, white);
        // '1' is 010 in its top row: its middle column is lit.
        assert_eq!(*image.get_pixel(3, 2), white);
        assert_eq!(*image.get_pixel(2, 2), Rgba([0, 0, 0, 200]));
    }
}
