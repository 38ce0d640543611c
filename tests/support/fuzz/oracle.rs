//! What a case must satisfy: no panic, at most 64× the file's bytes plus 64 MiB allocated
//! (the octree and bricks built from a volume that loads included), at most 2 s, an error
//! that is one readable line naming the file once, and the input files unchanged.

use std::panic::{self, AssertUnwindSafe};
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use voxscope_octree::{BrickLayout, BuildOptions};
use voxscope_volume::{LoadOptions, QuantizedVolume};

use super::alloc;

/// Every file of a case with the bytes it must still hold afterwards.
pub type Inputs = [(std::path::PathBuf, Vec<u8>)];

/// The bounds a case is held to.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Allowed bytes per byte of input…
    pub memory_per_input_byte: usize,
    /// …plus this many.
    pub memory_base: usize,
    /// Wall time of one case.
    pub seconds: f64,
}

impl Limits {
    /// The bounds: 64× the input plus 64 MiB, 2 s.
    pub const DEFAULT: Self = Self {
        memory_per_input_byte: 64,
        memory_base: 64 << 20,
        seconds: 2.0,
    };

    /// The memory bound for `input_bytes` of input.
    pub fn memory_bound(&self, input_bytes: usize) -> usize {
        input_bytes
            .saturating_mul(self.memory_per_input_byte)
            .saturating_add(self.memory_base)
    }
}

/// Why a case failed.
#[derive(Debug, Clone, PartialEq)]
pub enum Failure {
    /// A panic, with its message and location.
    Panic(String),
    /// More bytes were live at once than the bound allows.
    Memory { peak: usize, bound: usize },
    /// The case ran longer than the limit.
    Time { seconds: f64 },
    /// The error message broke a rule (which, and the message).
    Message { rule: &'static str, message: String },
    /// An input file was changed or removed.
    ChangedInput(String),
}

impl Failure {
    /// A short name for grouping: `panic`, `memory`, `time`, `message`, `changed-input`.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Panic(_) => "panic",
            Self::Memory { .. } => "memory",
            Self::Time { .. } => "time",
            Self::Message { .. } => "message",
            Self::ChangedInput(_) => "changed-input",
        }
    }

    /// One line: the kind and what was seen.
    pub fn describe(&self) -> String {
        match self {
            Self::Panic(message) => format!("panic: {message}"),
            Self::Memory { peak, bound } => {
                if *peak == usize::MAX {
                    format!("memory: an allocation was refused at the hard cap (bound {bound})")
                } else {
                    format!("memory: {peak} bytes live at once, bound {bound}")
                }
            }
            Self::Time { seconds } => format!("time: {seconds:.2} s"),
            Self::Message { rule, message } => {
                format!("message {rule}: {}", message.escape_debug())
            }
            Self::ChangedInput(path) => format!("changed input: {path}"),
        }
    }
}

/// What one case did.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// Whether the volume loaded (else the loader refused it).
    pub loaded: bool,
    /// The error, when it did not load.
    pub error: Option<String>,
    /// Most bytes live at once, beyond what was live before.
    pub peak_bytes: usize,
    pub seconds: f64,
    pub failures: Vec<Failure>,
}

/// Set while a case runs: panics then go to [`LAST_PANIC`] instead of stderr.
static IN_CASE: AtomicBool = AtomicBool::new(false);
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// Routes panics inside cases to [`LAST_PANIC`]; others to the default hook. Call once.
pub fn install_panic_hook() {
    let default = panic::take_hook();
    panic::set_hook(Box::new(move |info| {
        if IN_CASE.load(Ordering::Relaxed) {
            let location = info
                .location()
                .map(|l| format!(" at {}:{}", l.file(), l.line()))
                .unwrap_or_default();
            let payload = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(no message)".into());
            if let Ok(mut last) = LAST_PANIC.lock() {
                last.get_or_insert(format!("{payload}{location}"));
            }
        } else {
            default(info);
        }
    }));
}

/// Opens `target` (a file, or a folder) as the app and `info` would: load, then quantize and
/// build the octree and bricks. The load error's text, or `None`.
fn exercise(target: &str) -> Result<(), String> {
    let volume =
        voxscope_volume::load(target, &LoadOptions::default()).map_err(|e| e.to_string())?;
    let quantized = QuantizedVolume::new(&volume);
    drop(volume);
    // The build may refuse a volume (too deep, too many nodes); that is an answer too.
    if let Ok(octree) = voxscope_octree::build(&quantized, BuildOptions::default()) {
        let _bricks = BrickLayout::new(&octree, &quantized, 32, 2048);
    }
    Ok(())
}

/// Runs one case on files already on disk: `target` is what is opened, `inputs` every file
/// of the case (checked unchanged afterwards).
pub fn check(target: &Path, inputs: &Inputs, limits: &Limits) -> Outcome {
    check_with(target, inputs, limits, exercise)
}

/// [`check`] with another way to open the target (`run` gets its path as text and returns the
/// error message): what the test of the oracle itself uses.
pub fn check_with(
    target: &Path,
    inputs: &Inputs,
    limits: &Limits,
    run: impl FnOnce(&str) -> Result<(), String>,
) -> Outcome {
    let input_bytes: usize = inputs.iter().map(|(_, b)| b.len()).sum();
    let bound = limits.memory_bound(input_bytes);
    let spec = target.display().to_string();
    if let Ok(mut last) = LAST_PANIC.lock() {
        *last = None;
    }
    IN_CASE.store(true, Ordering::Relaxed);
    let baseline = alloc::begin_case();
    let started = Instant::now();
    let result = panic::catch_unwind(AssertUnwindSafe(|| run(&spec)));
    let seconds = started.elapsed().as_secs_f64();
    let peak_bytes = alloc::peak_since(baseline);
    IN_CASE.store(false, Ordering::Relaxed);

    let mut failures = Vec::new();
    let (loaded, error) = match result {
        Ok(Ok(())) => (true, None),
        Ok(Err(message)) => {
            if let Some(rule) = message_rule_broken(&message, &spec, target) {
                failures.push(Failure::Message {
                    rule,
                    message: message.clone(),
                });
            }
            (false, Some(message))
        }
        Err(_) => {
            let message = LAST_PANIC
                .lock()
                .ok()
                .and_then(|mut last| last.take())
                .unwrap_or_else(|| "(unknown)".into());
            failures.push(Failure::Panic(message));
            (false, None)
        }
    };
    if peak_bytes > bound {
        failures.push(Failure::Memory {
            peak: peak_bytes,
            bound,
        });
    }
    if seconds > limits.seconds {
        failures.push(Failure::Time { seconds });
    }
    for (path, bytes) in inputs {
        if std::fs::read(path).ok().as_deref() != Some(&bytes[..]) {
            failures.push(Failure::ChangedInput(path.display().to_string()));
        }
    }
    Outcome {
        loaded,
        error,
        peak_bytes,
        seconds,
        failures,
    }
}

/// Texts of libraries that say nothing of what pointed where (the list).
const CONTEXTLESS: [&str; 5] = [
    "failed to fill whole buffer",
    "decoder limits exceeded",
    "Invalid argument",
    "Could not read data set token",
    "os error",
];

/// Signs of Rust's debug formatting in a message.
const DEBUG_TEXT: [&str; 6] = ["Some(", "None)", "Ok(", "Err(", " { ", "\\\""];

/// The rule an error message breaks, if any: one line, starting with the file, the file named
/// once, no control characters, not too long, no 300-digit numbers, no long lists, no debug
/// formatting, no library text without context.
pub fn message_rule_broken(message: &str, spec: &str, target: &Path) -> Option<&'static str> {
    let Some(problem) = message.strip_prefix(&format!("{spec}: ")) else {
        return Some("does not start with the file");
    };
    if message.contains(['\n', '\r']) {
        return Some("is not one line");
    }
    if message.chars().any(char::is_control) {
        return Some("holds control characters");
    }
    if problem.chars().count() > 400 {
        return Some("is longer than 400 characters");
    }
    let longest_number = problem
        .split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0);
    if longest_number > 20 {
        return Some("holds a number of more than 20 digits");
    }
    if problem.split(',').count() > 16 {
        return Some("lists more than 16 items");
    }
    if DEBUG_TEXT.iter().any(|text| problem.contains(text)) {
        return Some("shows debug formatting");
    }
    if CONTEXTLESS.iter().any(|text| problem.contains(text)) {
        return Some("passes on a library's text without context");
    }
    // Values quoted from the file ('...') may hold anything, the file's own name too.
    let unquoted: String = problem.split('\'').step_by(2).collect();
    if target.is_file()
        && let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned())
        && unquoted.contains(&name)
    {
        return Some("names the file twice");
    }
    None
}
