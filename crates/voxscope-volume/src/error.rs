//! The one error type of loading: which source failed and why, in one line; and the helpers
//! that keep what a file holds readable inside a message (escaped, shortened, numbers short).

use std::fmt;

use super::{MAX_AXIS, MAX_VOXELS, format_dims};

/// Why a volume could not be loaded. Displays as one line, `SOURCE: PROBLEM`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LoadError {
    /// The file path or volume spec the user gave.
    pub source: String,
    /// What is wrong with it, as one sentence without a trailing period.
    pub problem: String,
    /// What kind of failure it is, for callers that branch on it (a reader retries a fetch,
    /// not a chunk that does not decode).
    pub kind: LoadErrorKind,
    /// The cause alone, where it is one that many reads may share (`HTTP 500 Internal Server
    /// Error (after 9 tries)`, `connection refused`): what a summary of many failures groups
    /// by. `None`: the problem is its own cause.
    pub cause: Option<String>,
}

/// What kind of failure a [`LoadError`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LoadErrorKind {
    /// The file or store is not what it claims, not supported, or asked for what it does not
    /// hold: another try reads the same.
    #[default]
    Invalid,
    /// The bytes could not be fetched (the disk or the network failed): another try may
    /// succeed.
    Fetch,
    /// The bytes arrived but do not decode (a damaged or truncated chunk).
    Decode,
    /// No format recognized the file (by extension or first bytes): the command line can
    /// still read it as raw voxels of a given layout, which it then says.
    Unrecognized,
}

/// A problem longer than this is cut: the loaders shorten what they quote from a file, and
/// this catches anything a library passed on at length.
const MAX_PROBLEM_CHARS: usize = 1000;

impl LoadError {
    /// An error about `source` (a path or a spec) with a one-line `problem`.
    pub fn new(source: impl fmt::Display, problem: impl Into<String>) -> Self {
        let problem: String = problem.into();
        // Errors must stay on one line and print no control characters, whatever a nested
        // error or the file held.
        let problem = escape(&problem.replace(['\n', '\r'], " "));
        let problem = shorten(&problem, MAX_PROBLEM_CHARS);
        Self {
            source: escape(&source.to_string()),
            problem,
            kind: LoadErrorKind::Invalid,
            cause: None,
        }
    }

    /// The same error, of `kind`.
    pub fn with_kind(self, kind: LoadErrorKind) -> Self {
        Self { kind, ..self }
    }

    /// The same error, with its shared `cause` ([`Self::cause`]).
    pub fn with_cause(self, cause: Option<String>) -> Self {
        Self {
            cause: cause
                .map(|c| shorten(&escape(&c.replace(['\n', '\r'], " ")), MAX_PROBLEM_CHARS)),
            ..self
        }
    }

    /// The cause a summary groups this error by: [`Self::cause`], else the whole problem.
    pub fn cause(&self) -> &str {
        self.cause.as_deref().unwrap_or(&self.problem)
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.source, self.problem)
    }
}

impl std::error::Error for LoadError {}

/// Why an option's text that the volume layer parses (`--window`, `--compression`) was
/// refused: displays as the one line the command line and the Python module show after the
/// value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OptionError {
    /// A window without its `:`.
    #[error("window '{0}' is not LOW:HIGH")]
    WindowNotLowHigh(String),
    /// One bound of a window is not a finite number.
    #[error("window bound '{0}' is not a number")]
    WindowBound(String),
    /// A window whose high bound is not above its low one.
    #[error("window '{0}' has HIGH <= LOW")]
    WindowReversed(String),
    /// A compression that is none of those `convert --compression` takes (`known`, listed).
    #[error("compression '{name}' is not one of {known}")]
    UnknownCompression { name: String, known: String },
    /// A raw layout whose dimensions are not `XxYxZ`.
    #[error("raw layout '{layout}': '{dims}' is not XxYxZ")]
    RawDims { layout: String, dims: String },
    /// A raw layout without its voxel type.
    #[error("raw layout '{0}' lacks :TYPE (u8, i16, f32, …)")]
    RawNoType(String),
    /// A raw layout's voxel type that voxscope does not read.
    #[error(
        "raw layout '{layout}': unknown voxel type '{name}' (u8, i8, u16, i16, u32, i32, f32, f64)"
    )]
    RawType { layout: String, name: String },
    /// A raw layout's byte order other than `le` or `be`.
    #[error("raw layout '{layout}': byte order '{order}' is not le or be")]
    RawOrder { layout: String, order: String },
    /// A raw layout of more than three parts.
    #[error("raw layout '{0}' has too many parts")]
    RawParts(String),
}

/// Why dimensions cannot hold a volume: a zero extent, or more voxels than voxscope reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum DimsError {
    #[error("dimensions {} contain a zero extent", format_dims(*.0))]
    ZeroExtent([usize; 3]),
    #[error("dimensions {} exceed the limit of {MAX_AXIS} voxels per axis", format_dims(*.0))]
    AxisTooLong([usize; 3]),
    #[error("dimensions {} exceed the limit of {MAX_VOXELS} voxels", format_dims(*.0))]
    TooManyVoxels([usize; 3]),
}

/// A loader's problem text ([`Problem`]) from dimensions that cannot hold a volume: the
/// loaders name the source when they turn a problem into a [`LoadError`].
impl From<DimsError> for Problem {
    fn from(error: DimsError) -> Self {
        error.to_string()
    }
}

/// Short form used inside loaders: `Err(problem)` with the source added by the caller.
pub(crate) type Problem = String;

/// How many characters of a value from a file a message quotes.
const QUOTED_CHARS: usize = 60;

/// How many characters of a name or label from a file are shown (an MRC label is 80).
const PRINTABLE_CHARS: usize = 100;

/// `text` with control and other invisible characters written as escapes (`\x1b`,
/// `\u{202e}`), so a message cannot move the terminal's cursor or change its colors.
pub(crate) fn escape(text: &str) -> String {
    let mut escaped = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() || is_invisible(c) {
            if (c as u32) < 0x80 {
                escaped.push_str(&format!("\\x{:02x}", c as u32));
            } else {
                escaped.push_str(&format!("\\u{{{:x}}}", c as u32));
            }
        } else {
            escaped.push(c);
        }
    }
    escaped
}

/// Format characters that change how text is shown (bidirectional overrides, zero widths).
fn is_invisible(c: char) -> bool {
    matches!(c, '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' | '\u{feff}')
}

/// `text` cut after `max` characters, saying how many more there were.
fn shorten(text: &str, max: usize) -> String {
    let count = text.chars().count();
    if count <= max {
        return text.to_owned();
    }
    let kept: String = text.chars().take(max).collect();
    format!("{kept}… ({} more characters)", count - max)
}

/// A value from a file as a message quotes it: `'value'`, escaped, at most 60 characters,
/// digit runs of more than 20 cut.
pub(crate) fn quoted(text: &str) -> String {
    format!(
        "'{}'",
        shorten(&shorten_digits(&escape(text)), QUOTED_CHARS)
    )
}

/// A value from a file shown without quotes (metadata, names): escaped, at most 100
/// characters, digit runs of more than 20 cut.
pub(crate) fn printable(text: &str) -> String {
    shorten(&shorten_digits(&escape(text)), PRINTABLE_CHARS)
}

/// Runs of more than 20 digits (no integer type has more) cut to their first 16 and a count:
/// `1844674407370955… (21 digits)`.
fn shorten_digits(text: &str) -> String {
    const MAX_DIGITS: usize = 20;
    const KEPT_DIGITS: usize = 16;
    let mut out = String::with_capacity(text.len());
    let mut run = String::new();
    let flush = |run: &mut String, out: &mut String| {
        if run.len() > MAX_DIGITS {
            out.push_str(&run[..KEPT_DIGITS]);
            out.push_str(&format!("… ({} digits)", run.len()));
        } else {
            out.push_str(run);
        }
        run.clear();
    };
    for c in text.chars() {
        if c.is_ascii_digit() {
            run.push(c);
        } else {
            flush(&mut run, &mut out);
            out.push(c);
        }
    }
    flush(&mut run, &mut out);
    out
}

/// The first items of a list and how many more: `8, 8, 8, 8 … 97996 more`.
pub(crate) fn short_list<T: fmt::Display>(items: &[T]) -> String {
    const SHOWN: usize = 4;
    let shown: Vec<String> = items.iter().take(SHOWN).map(|i| i.to_string()).collect();
    if items.len() > SHOWN {
        format!("{} … {} more", shown.join(", "), items.len() - SHOWN)
    } else {
        shown.join(", ")
    }
}

/// A number as a message shows it: plain when it is short (`0.5`, `1024`), in scientific
/// notation when plain would take many digits (`3.4028235e38`, not 39 digits).
pub(crate) fn number(value: f64) -> String {
    let magnitude = value.abs();
    if value == 0.0 || !value.is_finite() || (1e-4..1e15).contains(&magnitude) {
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_escape_shorten_and_stay_on_one_line() {
        let error = LoadError::new("a.nrrd", "type '\u{1b}[31mred' is bad\nreally");
        assert_eq!(
            error.to_string(),
            "a.nrrd: type '\\x1b[31mred' is bad really"
        );
        assert_eq!(
            quoted(&"x".repeat(100)),
            format!("'{}… (40 more characters)'", "x".repeat(60))
        );
        assert_eq!(printable("right\u{202e}left"), "right\\u{202e}left");
        assert_eq!(printable(&"l".repeat(80)), "l".repeat(80));
        let long = LoadError::new("f", "y".repeat(5000));
        assert!(
            long.problem.chars().count() < 1100 && long.problem.ends_with("(4000 more characters)")
        );
    }

    #[test]
    fn lists_and_numbers_stay_short() {
        assert_eq!(short_list(&[1, 2, 3]), "1, 2, 3");
        assert_eq!(short_list(&[8; 98000]), "8, 8, 8, 8 … 97996 more");
        assert_eq!(
            quoted("318446744073709551615"),
            "'3184467440737095… (21 digits)'"
        );
        assert_eq!(quoted("18446744073709551615"), "'18446744073709551615'");
        assert_eq!(number(0.5), "0.5");
        assert_eq!(number(1024.0), "1024");
        assert_eq!(number(f32::MAX as f64), "3.4028234663852886e38");
        assert_eq!(number(1e-40), "1e-40");
        assert_eq!(number(f64::NAN), "NaN");
    }
}
