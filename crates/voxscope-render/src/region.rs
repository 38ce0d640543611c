//! A part of an image that one pass draws: the whole image, or a band of rows where a frame
//! costs more than a device should be kept busy with at once (the app's frame pacing draws a
//! slow frame band by band, so that its own drawing and input are never stuck behind it).

/// The pixels `[origin, origin + size)` of an image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageRegion {
    pub origin: [u32; 2],
    pub size: [u32; 2],
}

impl ImageRegion {
    /// Every pixel of an image of `width`×`height`.
    pub fn whole(width: u32, height: u32) -> Self {
        Self {
            origin: [0, 0],
            size: [width, height],
        }
    }

    /// Rows `first..first + count` of an image `width` wide (cut to `height` rows).
    pub fn rows(width: u32, height: u32, first: u32, count: u32) -> Self {
        let first = first.min(height);
        Self {
            origin: [0, first],
            size: [width, count.min(height - first)],
        }
    }

    /// Pixels it covers.
    pub fn pixels(&self) -> u64 {
        self.size[0] as u64 * self.size[1] as u64
    }

    /// Whether it is every pixel of a `width`×`height` image.
    pub fn is_whole(&self, width: u32, height: u32) -> bool {
        self.origin == [0, 0] && self.size == [width, height]
    }

    /// `[x0, y0, x1, y1)`, as the shaders' `params.tile` reads it.
    pub(crate) fn bounds(&self) -> [u32; 4] {
        [
            self.origin[0],
            self.origin[1],
            self.origin[0] + self.size[0],
            self.origin[1] + self.size[1],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_of_rows_stop_at_the_image_edge() {
        let band = ImageRegion::rows(640, 480, 448, 64);
        assert_eq!(band.size, [640, 32]);
        assert_eq!(band.bounds(), [0, 448, 640, 480]);
        assert_eq!(band.pixels(), 640 * 32);
        assert!(ImageRegion::whole(640, 480).is_whole(640, 480));
        assert!(!band.is_whole(640, 480));
        assert_eq!(ImageRegion::rows(640, 480, 500, 10).size, [640, 0]);
    }
}
