//! Where `voxscope movie` and the app's Movie panel write their frames, chosen by the
//! output's extension: an animated GIF,
//! an animated WebP (lossless frames), an animated PNG, a folder of numbered PNGs, or an MP4
//! (H.264) made by `ffmpeg` from raw RGBA frames piped to it.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

use image::RgbaImage;

/// The kinds of movie file `movie` writes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MovieFormat {
    Gif,
    Webp,
    /// Animated PNG.
    Apng,
    /// Numbered PNGs (`frame_00000.png`, …) in a folder.
    Folder,
    /// H.264 through this `ffmpeg`.
    Mp4 {
        ffmpeg: PathBuf,
    },
}

impl MovieFormat {
    /// The format `output`'s extension names (no extension, or an existing folder: a folder).
    /// An MP4 needs `ffmpeg` on the PATH; without it the error says how to get it.
    pub fn of(output: &Path) -> Result<Self, String> {
        if output.is_dir() {
            return Ok(Self::Folder);
        }
        let extension = output
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match extension.as_deref() {
            None => Ok(Self::Folder),
            Some("gif") => Ok(Self::Gif),
            Some("webp") => Ok(Self::Webp),
            Some("png" | "apng") => Ok(Self::Apng),
            Some("mp4") => find_on_path("ffmpeg")
                .map(|ffmpeg| Self::Mp4 { ffmpeg })
                .ok_or_else(|| {
                    format!(
                        "{}: MP4 needs ffmpeg, which is not on the PATH (install it: `apt install ffmpeg`, `brew install ffmpeg`, or https://ffmpeg.org/download.html); or write .gif, .webp, .png or a folder",
                        output.display()
                    )
                }),
            Some(other) => Err(format!(
                "{}: '.{other}' is not a movie format voxscope writes (.gif, .webp, .png (animated), .mp4, or a folder for numbered PNGs)",
                output.display()
            )),
        }
    }

    /// Starts writing a movie of `frames` frames of `width`×`height` at `fps` to `output`.
    pub fn create(
        &self,
        output: &Path,
        size: (u32, u32),
        fps: f64,
        frames: usize,
    ) -> Result<Box<dyn MovieWriter>, String> {
        let cannot = |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", output.display());
        let file = || {
            File::create(output)
                .map(BufWriter::new)
                .map_err(|e| cannot(&e))
        };
        let (width, height) = size;
        Ok(match self {
            Self::Gif => {
                let (w, h) = (u16::try_from(width), u16::try_from(height));
                let (Ok(w), Ok(h)) = (w, h) else {
                    return Err(format!(
                        "{}: a GIF is at most 65535 pixels a side",
                        output.display()
                    ));
                };
                let mut encoder = gif::Encoder::new(file()?, w, h, &[]).map_err(|e| cannot(&e))?;
                encoder
                    .set_repeat(gif::Repeat::Infinite)
                    .map_err(|e| cannot(&e))?;
                Box::new(GifWriter {
                    encoder,
                    // GIF delays are in hundredths of a second.
                    delay: (100.0 / fps).round().clamp(1.0, u16::MAX as f64) as u16,
                    size: (w, h),
                    path: output.to_owned(),
                })
            }
            Self::Webp => Box::new(WebpWriter::new(output, size, fps)?),
            Self::Apng => {
                let mut encoder = png::Encoder::new(file()?, width, height);
                encoder.set_color(png::ColorType::Rgba);
                encoder.set_depth(png::BitDepth::Eight);
                encoder
                    .set_animated(frames as u32, 0)
                    .map_err(|e| cannot(&e))?;
                let (numerator, denominator) = frame_delay(fps);
                encoder
                    .set_frame_delay(numerator, denominator)
                    .map_err(|e| cannot(&e))?;
                let writer = encoder.write_header().map_err(|e| cannot(&e))?;
                Box::new(ApngWriter {
                    writer: Some(writer),
                    path: output.to_owned(),
                })
            }
            Self::Folder => {
                let made = !output.exists();
                std::fs::create_dir_all(output).map_err(|e| cannot(&e))?;
                Box::new(FolderWriter {
                    folder: output.to_owned(),
                    next: 0,
                    made,
                })
            }
            Self::Mp4 { ffmpeg } => Box::new(Mp4Writer::start(ffmpeg, output, size, fps)?),
        })
    }
}

/// A movie file being written, frame by frame.
pub trait MovieWriter {
    /// Appends one frame (all of one size, opaque).
    fn add(&mut self, frame: &RgbaImage) -> Result<(), String>;
    /// Ends the file.
    fn finish(self: Box<Self>) -> Result<(), String>;
    /// Stops without a movie (cancelled, or a frame failed): removes what was written, the
    /// file, or the frames written into the folder and the folder where this writer made it,
    /// so that nothing half-written is left.
    fn abandon(self: Box<Self>);
}

/// Removes a movie file left unfinished (a file that is not there is no error).
fn remove_unfinished(path: &Path) {
    let _ = std::fs::remove_file(path);
}

/// The folder's name for frame `index`.
pub fn frame_file_name(index: usize) -> String {
    format!("frame_{index:05}.png")
}

/// `1 / fps` as a fraction of u16s (the APNG frame delay).
fn frame_delay(fps: f64) -> (u16, u16) {
    if (fps - fps.round()).abs() < 1e-9 && (1.0..=u16::MAX as f64).contains(&fps) {
        (1, fps.round() as u16)
    } else {
        (
            ((1000.0 / fps).round().clamp(1.0, u16::MAX as f64)) as u16,
            1000,
        )
    }
}

fn find_on_path(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(program))
        .find(|candidate| candidate.is_file())
}

struct GifWriter {
    encoder: gif::Encoder<BufWriter<File>>,
    delay: u16,
    size: (u16, u16),
    path: PathBuf,
}

impl MovieWriter for GifWriter {
    fn add(&mut self, frame: &RgbaImage) -> Result<(), String> {
        let mut pixels = frame.as_raw().clone();
        // NeuQuant at speed 10: a palette per frame, good for smooth volume shading.
        let mut gif_frame = gif::Frame::from_rgba_speed(self.size.0, self.size.1, &mut pixels, 10);
        gif_frame.delay = self.delay;
        self.encoder
            .write_frame(&gif_frame)
            .map_err(|e| format!("cannot write {}: {e}", self.path.display()))
    }

    fn finish(self: Box<Self>) -> Result<(), String> {
        let cannot =
            |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", self.path.display());
        let mut file = self.encoder.into_inner().map_err(|e| cannot(&e))?;
        file.flush().map_err(|e| cannot(&e))
    }

    fn abandon(self: Box<Self>) {
        let path = self.path.clone();
        drop(self);
        remove_unfinished(&path);
    }
}

struct ApngWriter {
    writer: Option<png::Writer<BufWriter<File>>>,
    path: PathBuf,
}

impl MovieWriter for ApngWriter {
    fn add(&mut self, frame: &RgbaImage) -> Result<(), String> {
        let writer = self.writer.as_mut().expect("the writer lives until finish");
        writer
            .write_image_data(frame.as_raw())
            .map_err(|e| format!("cannot write {}: {e}", self.path.display()))
    }

    fn finish(mut self: Box<Self>) -> Result<(), String> {
        let writer = self.writer.take().expect("finish is called once");
        writer
            .finish()
            .map_err(|e| format!("cannot write {}: {e}", self.path.display()))
    }

    fn abandon(self: Box<Self>) {
        let path = self.path.clone();
        drop(self);
        remove_unfinished(&path);
    }
}

struct FolderWriter {
    folder: PathBuf,
    next: usize,
    /// The folder was made for this movie (an abandoned one removes it when empty).
    made: bool,
}

impl MovieWriter for FolderWriter {
    fn add(&mut self, frame: &RgbaImage) -> Result<(), String> {
        let path = self.folder.join(frame_file_name(self.next));
        self.next += 1;
        frame
            .save(&path)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    fn finish(self: Box<Self>) -> Result<(), String> {
        Ok(())
    }

    fn abandon(self: Box<Self>) {
        for index in 0..self.next {
            remove_unfinished(&self.folder.join(frame_file_name(index)));
        }
        if self.made {
            // Only where nothing else was put there meanwhile.
            let _ = std::fs::remove_dir(&self.folder);
        }
    }
}

/// An animated WebP: a `VP8X` header, an `ANIM` chunk and an `ANMF` chunk per frame, each
/// holding the `VP8L` (lossless) bitstream image-webp encodes for the frame. The RIFF size is
/// written at the end.
struct WebpWriter {
    file: BufWriter<File>,
    size: (u32, u32),
    duration_ms: u32,
    path: PathBuf,
}

fn riff_chunk(out: &mut impl Write, name: &[u8; 4], data: &[u8]) -> std::io::Result<()> {
    out.write_all(name)?;
    out.write_all(&(data.len() as u32).to_le_bytes())?;
    out.write_all(data)?;
    if data.len() % 2 == 1 {
        out.write_all(&[0])?;
    }
    Ok(())
}

fn u24(value: u32) -> [u8; 3] {
    let [a, b, c, _] = value.to_le_bytes();
    [a, b, c]
}

impl WebpWriter {
    fn new(path: &Path, size: (u32, u32), fps: f64) -> Result<Self, String> {
        let cannot = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
        if size.0 > 1 << 14 || size.1 > 1 << 14 {
            return Err(format!(
                "{}: a WebP is at most 16384 pixels a side",
                path.display()
            ));
        }
        let mut file = BufWriter::new(File::create(path).map_err(cannot)?);
        let mut header = Vec::new();
        header.extend_from_slice(b"RIFF");
        header.extend_from_slice(&0u32.to_le_bytes()); // the file's size, written at the end
        header.extend_from_slice(b"WEBP");
        let mut vp8x = vec![0x02 | 0x10, 0, 0, 0]; // animation, alpha
        vp8x.extend_from_slice(&u24(size.0 - 1));
        vp8x.extend_from_slice(&u24(size.1 - 1));
        riff_chunk(&mut header, b"VP8X", &vp8x).map_err(cannot)?;
        // Background black, looping forever.
        riff_chunk(&mut header, b"ANIM", &[0, 0, 0, 255, 0, 0]).map_err(cannot)?;
        file.write_all(&header).map_err(cannot)?;
        Ok(Self {
            file,
            size,
            duration_ms: (1000.0 / fps).round().clamp(1.0, (1 << 24) as f64 - 1.0) as u32,
            path: path.to_owned(),
        })
    }
}

impl MovieWriter for WebpWriter {
    fn add(&mut self, frame: &RgbaImage) -> Result<(), String> {
        let cannot =
            |e: &dyn std::fmt::Display| format!("cannot write {}: {e}", self.path.display());
        let mut still = Vec::new();
        image_webp::WebPEncoder::new(&mut still)
            .encode(
                frame.as_raw(),
                self.size.0,
                self.size.1,
                image_webp::ColorType::Rgba8,
            )
            .map_err(|e| cannot(&e))?;
        // A still without metadata is RIFF, size, WEBP, then its one VP8L chunk.
        let bitstream = still
            .get(12..)
            .filter(|chunk| chunk.starts_with(b"VP8L"))
            .ok_or_else(|| cannot(&"the WebP encoder wrote no VP8L chunk"))?;
        let mut anmf = Vec::with_capacity(16 + bitstream.len());
        anmf.extend_from_slice(&u24(0)); // x / 2
        anmf.extend_from_slice(&u24(0)); // y / 2
        anmf.extend_from_slice(&u24(self.size.0 - 1));
        anmf.extend_from_slice(&u24(self.size.1 - 1));
        anmf.extend_from_slice(&u24(self.duration_ms));
        anmf.push(0x02); // do not blend: each frame replaces the last
        anmf.extend_from_slice(bitstream);
        riff_chunk(&mut self.file, b"ANMF", &anmf).map_err(|e| cannot(&e))
    }

    fn finish(mut self: Box<Self>) -> Result<(), String> {
        let path = self.path.clone();
        let cannot = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
        self.file.flush().map_err(cannot)?;
        let mut file = self.file.into_inner().map_err(|e| cannot(e.into_error()))?;
        let length = file.stream_position().map_err(cannot)?;
        let riff_size = u32::try_from(length - 8)
            .map_err(|_| format!("{}: more than 4 GiB is too long for a WebP", path.display()))?;
        file.seek(SeekFrom::Start(4)).map_err(cannot)?;
        file.write_all(&riff_size.to_le_bytes()).map_err(cannot)?;
        file.flush().map_err(cannot)
    }

    fn abandon(self: Box<Self>) {
        let path = self.path.clone();
        drop(self);
        remove_unfinished(&path);
    }
}

/// `ffmpeg` reading raw RGBA frames on its standard input.
struct Mp4Writer {
    child: Child,
    input: Option<ChildStdin>,
    path: PathBuf,
}

impl Mp4Writer {
    fn start(ffmpeg: &Path, output: &Path, size: (u32, u32), fps: f64) -> Result<Self, String> {
        let mut child = Command::new(ffmpeg)
            .args([
                "-y",
                "-loglevel",
                "error",
                "-f",
                "rawvideo",
                "-pix_fmt",
                "rgba",
            ])
            .args(["-s", &format!("{}x{}", size.0, size.1)])
            .args(["-r", &format!("{fps}"), "-i", "-"])
            // H.264 in 4:2:0 (what players play) needs even sides.
            .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
            .args([
                "-c:v",
                "libx264",
                "-pix_fmt",
                "yuv420p",
                "-movflags",
                "+faststart",
            ])
            .arg(output)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| {
                format!(
                    "{}: cannot start {}: {e}",
                    output.display(),
                    ffmpeg.display()
                )
            })?;
        let input = child.stdin.take();
        Ok(Self {
            child,
            input,
            path: output.to_owned(),
        })
    }

    /// ffmpeg's own last line (why it stopped), once it ended: its input is closed first.
    fn failure(&mut self) -> String {
        drop(self.input.take());
        let _ = self.child.wait();
        let mut said = String::new();
        if let Some(mut stderr) = self.child.stderr.take() {
            let _ = std::io::Read::read_to_string(&mut stderr, &mut said);
        }
        let last = said.trim().lines().last().unwrap_or("it gave no reason");
        format!("{}: ffmpeg failed: {last}", self.path.display())
    }
}

impl MovieWriter for Mp4Writer {
    fn add(&mut self, frame: &RgbaImage) -> Result<(), String> {
        let input = self.input.as_mut().expect("the pipe lives until finish");
        match input.write_all(frame.as_raw()) {
            Ok(()) => Ok(()),
            // ffmpeg stopped reading: what it said is the reason.
            Err(_) => Err(self.failure()),
        }
    }

    fn finish(mut self: Box<Self>) -> Result<(), String> {
        drop(self.input.take());
        match self.child.wait() {
            Ok(status) if status.success() => Ok(()),
            _ => Err(self.failure()),
        }
    }

    fn abandon(mut self: Box<Self>) {
        // Killed before its input closes: a closed input would start ffmpeg's finishing.
        let _ = self.child.kill();
        drop(self.input.take());
        let _ = self.child.wait();
        remove_unfinished(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions_pick_the_format() {
        assert_eq!(MovieFormat::of(Path::new("a.gif")), Ok(MovieFormat::Gif));
        assert_eq!(MovieFormat::of(Path::new("a.WebP")), Ok(MovieFormat::Webp));
        assert_eq!(MovieFormat::of(Path::new("a.png")), Ok(MovieFormat::Apng));
        assert_eq!(
            MovieFormat::of(Path::new("frames")),
            Ok(MovieFormat::Folder)
        );
        let error = MovieFormat::of(Path::new("a.avi")).expect_err("not a format");
        assert!(error.contains(".gif, .webp"), "{error}");
        assert_eq!(frame_delay(30.0), (1, 30));
        assert_eq!(frame_delay(12.5), (80, 1000));
    }
}
