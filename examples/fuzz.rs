//! Long fuzz campaigns against every loader, in-process, on stable Rust.
//!
//! ```sh
//! cargo run --release --example fuzz -- --cases 100000 --seed 1 --jobs 16
//! cargo run --release --example fuzz -- --format nrrd --cases 2000
//! cargo run --release --example fuzz -- --format dicom --case 1234 --seed 1 --save found/
//! ```
//!
//! `cargo build --profile fuzz --example fuzz` builds it at release speed with overflow checks
//! in voxscope's code (target/fuzz/examples/fuzz), so an overflowing size computation is a
//! reported panic rather than a silent wrap.
//!
//! Each of `--jobs` worker processes (this program again, with `--worker`) runs every `jobs`-th
//! case of each format under the counting allocator; the parent counts, kills a worker whose
//! case runs past 20 s (reported as a hang) and restarts it after a crash, and prints the
//! cases per format and per seed with every failure and how to reproduce it. A case fails on
//! a panic, more than 64× its input plus 64 MiB live at once, more than 2 s, an error message
//! that breaks the rules (tests/support/fuzz/oracle.rs), or a changed input file. `--save DIR`
//! keeps each failing case as a folder for tests/data/fuzz/. Exit status 1 when any failed.

#[path = "../tests/support/fuzz/mod.rs"]
mod fuzz;

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use fuzz::oracle::Limits;
use fuzz::{Kind, seeds};

#[global_allocator]
static ALLOCATOR: fuzz::alloc::CountingAllocator = fuzz::alloc::CountingAllocator;

/// A case running this long is hung: its worker is killed.
const HANG_SECONDS: f64 = 20.0;

const USAGE: &str = "usage: fuzz [--cases N (per format, default 1000)] [--seed S (default 1)] \
[--format nifti|nrrd|tiff|dicom|vti|mrc]... [--jobs J (default 1)] [--save DIR] \
[--seed-file PATH]... [--case N (one case, with --format)] [--hard-cap-mib M (default 4096)] \
[--stop-after SECONDS (then report what was done)]";

#[derive(Debug, Clone)]
struct Options {
    cases: u64,
    seed: u64,
    kinds: Vec<Kind>,
    jobs: usize,
    save: Option<PathBuf>,
    seed_files: Vec<PathBuf>,
    single_case: Option<u64>,
    hard_cap_mib: usize,
    stop_after: Option<f64>,
    /// Internal: this process is worker `k` of `jobs`, resuming after (format, case).
    worker: Option<usize>,
    resume: Option<(Kind, u64)>,
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut options = Options {
        cases: 1000,
        seed: 1,
        kinds: Vec::new(),
        jobs: 1,
        save: None,
        seed_files: Vec::new(),
        single_case: None,
        hard_cap_mib: 4096,
        stop_after: None,
        worker: None,
        resume: None,
    };
    let mut args = args.iter();
    while let Some(flag) = args.next() {
        let mut value = || {
            args.next()
                .cloned()
                .ok_or_else(|| format!("{flag} needs a value"))
        };
        let number = |text: String| -> Result<u64, String> {
            text.parse()
                .map_err(|_| format!("{flag}: '{text}' is not a number"))
        };
        match flag.as_str() {
            "--cases" => options.cases = number(value()?)?,
            "--seed" => options.seed = number(value()?)?,
            "--jobs" => options.jobs = number(value()?)?.max(1) as usize,
            "--case" => options.single_case = Some(number(value()?)?),
            "--hard-cap-mib" => options.hard_cap_mib = number(value()?)? as usize,
            "--stop-after" => options.stop_after = Some(number(value()?)? as f64),
            "--save" => options.save = Some(PathBuf::from(value()?)),
            "--seed-file" => options.seed_files.push(PathBuf::from(value()?)),
            "--format" => {
                let name = value()?;
                options.kinds.push(
                    Kind::from_name(&name).ok_or_else(|| format!("unknown format '{name}'"))?,
                );
            }
            "--worker" => options.worker = Some(number(value()?)? as usize),
            "--resume" => {
                let text = value()?;
                let (kind, case) = text.split_once(':').ok_or("--resume FORMAT:CASE")?;
                options.resume = Some((
                    Kind::from_name(kind).ok_or("--resume: unknown format")?,
                    number(case.to_owned())?,
                ));
            }
            "--help" | "-h" => return Err(USAGE.into()),
            other => return Err(format!("unknown option '{other}'\n{USAGE}")),
        }
    }
    if options.kinds.is_empty() {
        options.kinds = Kind::ALL.to_vec();
    }
    Ok(options)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let options = match parse(&args) {
        Ok(options) => options,
        Err(message) => {
            eprintln!("{message}");
            std::process::exit(2);
        }
    };
    fuzz::oracle::install_panic_hook();
    let seed_files: Vec<&Path> = options.seed_files.iter().map(PathBuf::as_path).collect();
    let seeds = seeds::all(&seed_files);
    if let Some(worker) = options.worker {
        fuzz::alloc::set_hard_cap(options.hard_cap_mib << 20);
        return run_worker(&options, &seeds, worker);
    }
    if let Some(case) = options.single_case {
        return run_single(&options, &seeds, case);
    }
    std::process::exit(supervise(&options, &seeds, &args));
}

fn seeds_of(seeds: &[seeds::Seed], kind: Kind) -> Vec<&seeds::Seed> {
    seeds.iter().filter(|s| s.kind == kind).collect()
}

/// One case, verbosely.
fn run_single(options: &Options, seeds: &[seeds::Seed], index: u64) {
    let work = tempfile::tempdir().expect("a temporary folder");
    for &kind in &options.kinds {
        let case = fuzz::make_case(&seeds_of(seeds, kind), kind, options.seed, index);
        let outcome = fuzz::run_case(&case, &work.path().join("case"), &Limits::DEFAULT);
        println!(
            "{} case {index} (seed '{}'): {}, {} bytes peak, {:.3} s",
            kind.name(),
            case.seed_name,
            outcome.error.as_deref().unwrap_or("loaded"),
            outcome.peak_bytes,
            outcome.seconds
        );
        for line in &case.mutations {
            println!("  {line}");
        }
        for failure in &outcome.failures {
            println!("  FAILED {}", failure.describe());
        }
        if let Some(dir) = &options.save {
            let folder = dir.join(format!("{}-s{}-c{index}", kind.name(), options.seed));
            fuzz::save_case(&case, &folder, "saved by --case").expect("save the case");
            println!("  saved to {}", folder.display());
        }
        println!("  fingerprint {:016x}", fuzz::fingerprint(&case));
    }
}

/// A worker: every `jobs`-th case number, of each format in turn (so that a campaign stopped
/// early has as many cases of each format), one line per event on stdout.
fn run_worker(options: &Options, seeds: &[seeds::Seed], worker: usize) {
    let work = tempfile::tempdir().expect("a temporary folder");
    let mut out = std::io::stdout().lock();
    let of_kind: Vec<(Kind, Vec<&seeds::Seed>)> = options
        .kinds
        .iter()
        .map(|&kind| (kind, seeds_of(seeds, kind)))
        .collect();
    let mut index = worker as u64;
    while index < options.cases {
        for (kind, kind_seeds) in &of_kind {
            let kind = *kind;
            let resumed = options.resume.is_some_and(|(resume_kind, resume_case)| {
                (index, kind) <= (resume_case, resume_kind)
            });
            if resumed {
                continue;
            }
            // Flushed before the case runs: if it crashes, the parent knows which.
            writeln!(out, "start {} {index}", kind.name()).expect("stdout");
            out.flush().expect("stdout");
            let case = fuzz::make_case(kind_seeds, kind, options.seed, index);
            let outcome = fuzz::run_case(&case, &work.path().join("case"), &Limits::DEFAULT);
            for failure in &outcome.failures {
                writeln!(
                    out,
                    "fail {} {index} {}",
                    kind.name(),
                    failure.describe().replace('\n', " ")
                )
                .expect("stdout");
            }
            writeln!(
                out,
                "done {} {index} {} {} {}",
                kind.name(),
                outcome.loaded as u8,
                outcome.peak_bytes,
                (outcome.seconds * 1e6) as u64
            )
            .expect("stdout");
        }
        index += options.jobs as u64;
    }
    writeln!(out, "end").expect("stdout");
}

/// Counts of one seed.
#[derive(Default)]
struct SeedTally {
    cases: u64,
    loaded: u64,
    peak_bytes: usize,
    max_seconds: f64,
}

/// A failure as the parent keeps it.
struct Found {
    kind: Kind,
    index: u64,
    what: String,
}

enum Event {
    Line(usize, String),
    Exited(usize),
}

/// What the workers reported, counted by the parent.
#[derive(Default)]
struct Counts {
    tallies: BTreeMap<(Kind, usize), SeedTally>,
    found: Vec<Found>,
    /// Cases done, of every format.
    done: u64,
    /// Workers that ended (done with their cases, or failed outside one).
    finished: usize,
}

/// The last lines a worker wrote to stderr (what a crash report quotes).
type StderrTail = std::sync::Arc<std::sync::Mutex<Vec<String>>>;

/// The worker processes as the parent sees them: each one's process, the case it runs and
/// since when, and the tail of its stderr.
struct Workers<'a> {
    /// This program's arguments, which each worker is started with.
    args: &'a [String],
    sender: mpsc::Sender<Event>,
    children: Vec<Option<Child>>,
    running: Vec<Option<(Kind, u64, Instant)>>,
    stderr_tails: Vec<StderrTail>,
}

impl<'a> Workers<'a> {
    /// Starts `jobs` workers, which send their lines and exits to `sender`.
    fn start(jobs: usize, args: &'a [String], sender: mpsc::Sender<Event>) -> Self {
        let mut children: Vec<Option<Child>> = Vec::new();
        let mut stderr_tails: Vec<StderrTail> = Vec::new();
        for worker in 0..jobs {
            stderr_tails.push(Default::default());
            children.push(Some(spawn(
                args,
                worker,
                None,
                &sender,
                &stderr_tails[worker],
            )));
        }
        Workers {
            args,
            sender,
            children,
            running: vec![None; jobs],
            stderr_tails,
        }
    }

    /// Counts a line of `worker`'s: a case started, failed or done (with its figures).
    fn take_line(&mut self, worker: usize, line: &str, seeds: &[seeds::Seed], counts: &mut Counts) {
        let parts: Vec<&str> = line.splitn(4, ' ').collect();
        let kind = parts.get(1).and_then(|k| Kind::from_name(k));
        let index = parts.get(2).and_then(|i| i.parse::<u64>().ok());
        match (parts[0], kind, index) {
            ("start", Some(kind), Some(index)) => {
                self.running[worker] = Some((kind, index, Instant::now()))
            }
            ("fail", Some(kind), Some(index)) => counts.found.push(Found {
                kind,
                index,
                what: parts.get(3).unwrap_or(&"").to_string(),
            }),
            ("done", Some(kind), Some(index)) => {
                self.running[worker] = None;
                counts.done += 1;
                let fields: Vec<&str> = parts.get(3).unwrap_or(&"").split(' ').collect();
                let seed_count = seeds_of(seeds, kind).len() as u64;
                let tally = counts
                    .tallies
                    .entry((kind, (index % seed_count) as usize))
                    .or_default();
                tally.cases += 1;
                tally.loaded += (fields.first() == Some(&"1")) as u64;
                let peak: usize = fields.get(1).and_then(|p| p.parse().ok()).unwrap_or(0);
                tally.peak_bytes = tally.peak_bytes.max(peak);
                let micros: f64 = fields.get(2).and_then(|m| m.parse().ok()).unwrap_or(0.0);
                tally.max_seconds = tally.max_seconds.max(micros / 1e6);
            }
            _ => {}
        }
    }

    /// `worker` exited: done, or died inside a case (reported as a crash; the worker starts
    /// again after that case), or failed outside a case (said, and not started again). Returns
    /// true for the last.
    fn exited(&mut self, worker: usize, counts: &mut Counts) -> bool {
        let status = self.children[worker].as_mut().and_then(|c| c.wait().ok());
        match self.running[worker].take() {
            None if status.is_some_and(|s| s.success()) => counts.finished += 1,
            crashed => {
                // Died inside a case (or before its first): report and go on after it.
                let tail = self.stderr_tails[worker]
                    .lock()
                    .map(|t| t.join(" | "))
                    .unwrap_or_default();
                let resume = crashed.map(|(kind, index, _)| {
                    counts.found.push(Found {
                        kind,
                        index,
                        what: format!("crash: worker exited with {status:?}: {tail}"),
                    });
                    (kind, index)
                });
                if crashed.is_none() {
                    eprintln!("worker {worker} failed outside a case ({status:?}): {tail}");
                    counts.finished += 1;
                    return true;
                }
                self.children[worker] = Some(spawn(
                    self.args,
                    worker,
                    resume,
                    &self.sender,
                    &self.stderr_tails[worker],
                ));
            }
        }
        false
    }

    /// Kills the workers whose case runs past [`HANG_SECONDS`], reporting it as a hang.
    fn kill_hung(&mut self, found: &mut Vec<Found>) {
        for (worker, running) in self.running.iter().enumerate() {
            if let Some((kind, index, since)) = *running
                && since.elapsed().as_secs_f64() > HANG_SECONDS
            {
                found.push(Found {
                    kind,
                    index,
                    what: format!("hang: still running after {HANG_SECONDS} s, killed"),
                });
                if let Some(child) = self.children[worker].as_mut() {
                    let _ = child.kill();
                }
                // The exit event restarts it after this case.
            }
        }
    }

    /// Kills every worker and waits for it.
    fn stop(&mut self) {
        for child in self.children.iter_mut().flatten() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// The parent: starts the workers, counts, watches for hangs and crashes, reports.
fn supervise(options: &Options, seeds: &[seeds::Seed], args: &[String]) -> i32 {
    let started = Instant::now();
    let (sender, events) = mpsc::channel();
    let mut workers = Workers::start(options.jobs, args, sender);
    let mut counts = Counts::default();
    let mut last_progress = Instant::now();
    let total = options.cases * options.kinds.len() as u64;
    while counts.finished < options.jobs {
        match events.recv_timeout(Duration::from_millis(500)) {
            Ok(Event::Line(worker, line)) => workers.take_line(worker, &line, seeds, &mut counts),
            Ok(Event::Exited(worker)) => {
                if workers.exited(worker, &mut counts) {
                    continue;
                }
            }
            Err(_) => {}
        }
        workers.kill_hung(&mut counts.found);
        if options
            .stop_after
            .is_some_and(|limit| started.elapsed().as_secs_f64() > limit)
        {
            eprintln!(
                "stopping after {:.0} s as asked",
                started.elapsed().as_secs_f64()
            );
            workers.stop();
            break;
        }
        if last_progress.elapsed() > Duration::from_secs(30) {
            eprintln!(
                "{} of {total} cases, {} failures, {:.0} s",
                counts.done,
                counts.found.len(),
                started.elapsed().as_secs_f64()
            );
            last_progress = Instant::now();
        }
    }
    report(
        options,
        seeds,
        &counts.tallies,
        &counts.found,
        started.elapsed().as_secs_f64(),
    );
    if let Some(dir) = &options.save {
        save_failures(options, seeds, &counts.found, dir);
    }
    if counts.found.is_empty() { 0 } else { 1 }
}

/// Keeps each failing case as a folder in `dir` (for tests/data/fuzz/), named by its format,
/// the kind of failure, the campaign seed and the case.
fn save_failures(options: &Options, seeds: &[seeds::Seed], found: &[Found], dir: &Path) {
    for failure in found {
        let case = fuzz::make_case(
            &seeds_of(seeds, failure.kind),
            failure.kind,
            options.seed,
            failure.index,
        );
        let folder = dir.join(format!(
            "{}-{}-s{}-c{}",
            failure.kind.name(),
            failure
                .what
                .split(':')
                .next()
                .unwrap_or("failure")
                .replace(' ', "-"),
            options.seed,
            failure.index
        ));
        if let Err(error) = fuzz::save_case(&case, &folder, &failure.what) {
            eprintln!("cannot save {}: {error}", folder.display());
        }
    }
}

fn spawn(
    args: &[String],
    worker: usize,
    resume: Option<(Kind, u64)>,
    sender: &mpsc::Sender<Event>,
    stderr_tail: &std::sync::Arc<std::sync::Mutex<Vec<String>>>,
) -> Child {
    let mut command = Command::new(std::env::current_exe().expect("this program"));
    command.args(args).args(["--worker", &worker.to_string()]);
    if let Some((kind, case)) = resume {
        command.args(["--resume", &format!("{}:{case}", kind.name())]);
    }
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start a worker");
    let stdout = child.stdout.take().expect("piped");
    let lines = sender.clone();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if lines.send(Event::Line(worker, line)).is_err() {
                return;
            }
        }
        let _ = lines.send(Event::Exited(worker));
    });
    let stderr = child.stderr.take().expect("piped");
    let tail = stderr_tail.clone();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if let Ok(mut tail) = tail.lock() {
                tail.push(line);
                let excess = tail.len().saturating_sub(8);
                tail.drain(..excess);
            }
        }
    });
    child
}

fn report(
    options: &Options,
    seeds: &[seeds::Seed],
    tallies: &BTreeMap<(Kind, usize), SeedTally>,
    found: &[Found],
    seconds: f64,
) {
    println!(
        "fuzz: campaign seed {}, {} cases per format, {} jobs, {seconds:.0} s",
        options.seed, options.cases, options.jobs
    );
    println!(
        "{:<8} {:>9} {:>9} {:>9}  seed (cases, loaded, peak MiB, max ms)",
        "format", "cases", "loaded", "failures"
    );
    for &kind in &options.kinds {
        let of_kind = seeds_of(seeds, kind);
        let cases: u64 = (0..of_kind.len())
            .map(|s| tallies.get(&(kind, s)).map_or(0, |t| t.cases))
            .sum();
        let loaded: u64 = (0..of_kind.len())
            .map(|s| tallies.get(&(kind, s)).map_or(0, |t| t.loaded))
            .sum();
        let failures = found.iter().filter(|f| f.kind == kind).count();
        println!("{:<8} {cases:>9} {loaded:>9} {failures:>9}", kind.name());
        for (number, seed) in of_kind.iter().enumerate() {
            if let Some(tally) = tallies.get(&(kind, number)) {
                println!(
                    "{:<38} {}: {}, {}, {:.1}, {:.0}",
                    "",
                    seed.name,
                    tally.cases,
                    tally.loaded,
                    tally.peak_bytes as f64 / (1 << 20) as f64,
                    tally.max_seconds * 1e3
                );
            }
        }
    }
    for failure in found {
        println!(
            "FAILED {} case {}: {}  (reproduce: --format {} --case {} --seed {})",
            failure.kind.name(),
            failure.index,
            failure.what,
            failure.kind.name(),
            failure.index,
            options.seed
        );
    }
    println!("{} failures", found.len());
}
