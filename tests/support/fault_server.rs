//! A fault-injecting HTTP/1.1 server on 127.0.0.1 for the network tests and the network fuzz
//! (tests/net_faults.rs, crates/voxscope-stream/tests/net_fuzz.rs): it serves the files under a
//! folder (GET with
//! `Range`, HEAD) and, as a seeded [`FaultPlan`] says, answers 500, 503 with `Retry-After`,
//! 401 without the right basic authentication, resets the connection, cuts bodies short,
//! announces wrong lengths, waits, never answers (silence), frames bodies with
//! `Content-Length`, chunked or by closing the connection, and ignores `Range` (200 with the
//! whole file, as Python's `http.server` does). Which fault a request meets is a function of
//! the seed, its path and how many requests for that path came before it, so a plan replays
//! the same per object whatever order concurrent requests arrive in. It counts what it saw
//! (per path: requests, the most in flight at once, when each arrived; the `Authorization`
//! headers). Stopped when dropped: every connection it holds, silent ones included, closes.

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How bodies are delimited.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Framing {
    /// `Content-Length`, connection kept alive.
    Length,
    /// `Transfer-Encoding: chunked`, pieces of random sizes.
    Chunked,
    /// No length: the body ends when the connection closes.
    Close,
    /// Each answer one of the three, at random.
    Mixed,
}

/// What goes wrong. [`FaultPlan::default`] is a fast, faultless server.
#[derive(Debug, Clone)]
pub struct FaultPlan {
    pub seed: u64,
    /// Chance per request of each fault (while the path has met fewer than
    /// [`Self::faults_per_path`] faults).
    pub error_500: f64,
    pub error_503: f64,
    /// Each request closed unanswered.
    pub reset: f64,
    /// A body cut at a random point, then the connection closed.
    pub truncate: f64,
    /// `Content-Length` announcing more bytes than sent or fewer (then the connection closes).
    pub wrong_length: f64,
    /// Never answered (held open until the server stops or [`Self::silence_for`] passes).
    pub silence: f64,
    /// What a 503's `Retry-After` asks, in seconds.
    pub retry_after_s: u64,
    /// Faults one path meets at most; then it is answered right (`u32::MAX`: no end).
    pub faults_per_path: u32,
    /// Up to this long before each answer (uniformly at random).
    pub latency: Duration,
    pub framing: Framing,
    /// Ranged GETs answered 200 with the whole file.
    pub ignore_range: bool,
    /// Paths ending with one of these: always answered 500.
    pub always_500: Vec<String>,
    /// Paths for which this is true are never answered.
    pub silent: Option<fn(&str) -> bool>,
    /// After this many requests in all, nothing more is answered (a server that died).
    pub dies_after: Option<u64>,
    /// How long a silent request is held before its connection closes.
    pub silence_for: Duration,
    /// The basic authentication every request must carry (`user`, `password`): else 401.
    pub require_auth: Option<(String, String)>,
}

impl Default for FaultPlan {
    fn default() -> Self {
        Self {
            seed: 0,
            error_500: 0.0,
            error_503: 0.0,
            reset: 0.0,
            truncate: 0.0,
            wrong_length: 0.0,
            silence: 0.0,
            retry_after_s: 0,
            faults_per_path: u32::MAX,
            latency: Duration::ZERO,
            framing: Framing::Length,
            ignore_range: false,
            always_500: Vec::new(),
            silent: None,
            dies_after: None,
            silence_for: Duration::from_secs(3600),
            require_auth: None,
        }
    }
}

/// What the server saw of one path.
#[derive(Debug, Clone, Default)]
pub struct PathStats {
    pub requests: u64,
    /// Requests answered with a fault.
    pub faults: u32,
    pub in_flight: u64,
    pub peak_in_flight: u64,
    /// When each request arrived.
    pub arrivals: Vec<Instant>,
}

/// What the server saw.
#[derive(Debug, Default)]
pub struct FaultCounters {
    pub requests: AtomicU64,
    pub faults: AtomicU64,
    pub paths: Mutex<HashMap<String, PathStats>>,
    /// Every request's `Authorization` header (`None`: it had none).
    pub authorization: Mutex<Vec<Option<String>>>,
}

impl FaultCounters {
    /// What the server saw of `path` (as requested, without the query).
    pub fn path(&self, path: &str) -> PathStats {
        self.paths
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get(path)
            .cloned()
            .unwrap_or_default()
    }

    /// The most requests of one path that were in flight at once.
    pub fn peak_per_path(&self) -> u64 {
        self.paths
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .values()
            .map(|p| p.peak_in_flight)
            .max()
            .unwrap_or(0)
    }
}

/// A running server; stops when dropped.
pub struct FaultServer {
    port: u16,
    stop: Arc<AtomicBool>,
    pub counters: Arc<FaultCounters>,
    thread: Option<JoinHandle<()>>,
    connections: Arc<Mutex<Vec<TcpStream>>>,
}

impl FaultServer {
    /// Serves the files under `root` on a free port of 127.0.0.1 as `plan` says.
    pub fn start(root: &Path, plan: FaultPlan) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind 127.0.0.1");
        let port = listener.local_addr().expect("local address").port();
        let stop = Arc::new(AtomicBool::new(false));
        let counters = Arc::new(FaultCounters::default());
        let connections: Arc<Mutex<Vec<TcpStream>>> = Arc::default();
        let root = root.to_path_buf();
        let plan = Arc::new(plan);
        let thread = {
            let (stop, counters, connections) =
                (stop.clone(), counters.clone(), connections.clone());
            std::thread::spawn(move || {
                for stream in listener.incoming() {
                    if stop.load(Ordering::SeqCst) {
                        break;
                    }
                    let Ok(stream) = stream else { continue };
                    if let Ok(copy) = stream.try_clone() {
                        connections
                            .lock()
                            .unwrap_or_else(|p| p.into_inner())
                            .push(copy);
                    }
                    let (root, counters, plan, stop) =
                        (root.clone(), counters.clone(), plan.clone(), stop.clone());
                    std::thread::spawn(move || serve(stream, &root, &plan, &counters, &stop));
                }
            })
        };
        Self {
            port,
            stop,
            counters,
            thread: Some(thread),
            connections,
        }
    }

    /// `http://127.0.0.1:PORT/PATH`.
    pub fn url(&self, path: &str) -> String {
        format!("http://127.0.0.1:{}/{path}", self.port)
    }

    /// The port it listens on.
    pub fn port(&self) -> u16 {
        self.port
    }
}

impl Drop for FaultServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wakes the accept loop so that it sees the flag.
        let _ = TcpStream::connect(("127.0.0.1", self.port));
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        // Every connection closes, silent ones too (their threads see the flag).
        for connection in self
            .connections
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .drain(..)
        {
            let _ = connection.shutdown(Shutdown::Both);
        }
    }
}

/// SplitMix64: the seeded choices.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (`n` > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }

    /// True with chance `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && (self.next() >> 11) as f64 / (1u64 << 53) as f64 <= p
    }
}

fn hash(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

struct Request {
    method: String,
    path: String,
    range: Option<String>,
    authorization: Option<String>,
}

fn read_request(reader: &mut BufReader<TcpStream>) -> Option<Request> {
    let mut line = String::new();
    if reader.read_line(&mut line).ok()? == 0 {
        return None;
    }
    let mut parts = line.split_whitespace();
    let method = parts.next()?.to_owned();
    let target = parts.next()?.to_owned();
    let path = target.split('?').next().unwrap_or_default().to_owned();
    let (mut range, mut authorization) = (None, None);
    loop {
        let mut header = String::new();
        if reader.read_line(&mut header).ok()? == 0 {
            return None;
        }
        let header = header.trim_end();
        if header.is_empty() {
            break;
        }
        if let Some((name, value)) = header.split_once(':') {
            let name = name.trim();
            if name.eq_ignore_ascii_case("range") {
                range = Some(value.trim().to_owned());
            } else if name.eq_ignore_ascii_case("authorization") {
                authorization = Some(value.trim().to_owned());
            }
        }
    }
    Some(Request {
        method,
        path,
        range,
        authorization,
    })
}

/// `bytes=A-B`, `bytes=A-`, `bytes=-N` of a body of `len` bytes, as a half-open range.
fn parse_range(text: &str, len: u64) -> Option<(u64, u64)> {
    let spec = text.strip_prefix("bytes=")?;
    let (a, b) = spec.split_once('-')?;
    let (start, end) = if a.is_empty() {
        let n: u64 = b.parse().ok()?;
        (len.saturating_sub(n), len)
    } else {
        let start: u64 = a.parse().ok()?;
        let end = if b.is_empty() {
            len
        } else {
            (b.parse::<u64>().ok()? + 1).min(len)
        };
        (start, end)
    };
    (start < end).then_some((start, end))
}

fn serve(
    stream: TcpStream,
    root: &Path,
    plan: &FaultPlan,
    counters: &FaultCounters,
    stop: &AtomicBool,
) {
    let Ok(reader_stream) = stream.try_clone() else {
        return;
    };
    let mut reader = BufReader::new(reader_stream);
    let mut out = stream;
    while let Some(request) = read_request(&mut reader) {
        if stop.load(Ordering::SeqCst) {
            return;
        }
        let n = {
            let mut paths = counters.paths.lock().unwrap_or_else(|p| p.into_inner());
            let stats = paths.entry(request.path.clone()).or_default();
            stats.requests += 1;
            stats.in_flight += 1;
            stats.peak_in_flight = stats.peak_in_flight.max(stats.in_flight);
            stats.arrivals.push(Instant::now());
            stats.requests
        };
        counters
            .authorization
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(request.authorization.clone());
        let total = counters.requests.fetch_add(1, Ordering::SeqCst) + 1;
        let keep_open = answer(&mut out, &request, root, plan, counters, stop, n, total);
        if let Some(stats) = counters
            .paths
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get_mut(&request.path)
        {
            stats.in_flight -= 1;
        }
        if !keep_open {
            let _ = out.shutdown(Shutdown::Both);
            return;
        }
    }
}

/// Holds the connection without answering, until the server stops or `plan.silence_for`.
fn hold(plan: &FaultPlan, stop: &AtomicBool) {
    let started = Instant::now();
    while !stop.load(Ordering::SeqCst) && started.elapsed() < plan.silence_for {
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// The fault this request meets, if any.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fault {
    Error500,
    Error503,
    Reset,
    Truncate,
    LongLength,
    ShortLength,
    Silence,
}

fn fault_for(plan: &FaultPlan, rng: &mut Rng, faults_so_far: u32) -> Option<Fault> {
    if faults_so_far >= plan.faults_per_path {
        return None;
    }
    let choices = [
        (plan.error_500, Fault::Error500),
        (plan.error_503, Fault::Error503),
        (plan.reset, Fault::Reset),
        (plan.truncate, Fault::Truncate),
        (plan.wrong_length / 2.0, Fault::LongLength),
        (plan.wrong_length / 2.0, Fault::ShortLength),
        (plan.silence, Fault::Silence),
    ];
    choices
        .into_iter()
        .find(|&(p, _)| rng.chance(p))
        .map(|(_, fault)| fault)
}

/// Answers one request; whether the connection stays open.
#[allow(clippy::too_many_arguments)]
fn answer(
    out: &mut TcpStream,
    request: &Request,
    root: &Path,
    plan: &FaultPlan,
    counters: &FaultCounters,
    stop: &AtomicBool,
    n: u64,
    total: u64,
) -> bool {
    let mut rng = Rng::new(plan.seed ^ hash(&request.path) ^ n.wrapping_mul(0x2545_F491_4F6C_DD1D));
    if plan.dies_after.is_some_and(|limit| total > limit)
        || plan.silent.is_some_and(|silent| silent(&request.path))
    {
        hold(plan, stop);
        return false;
    }
    if plan
        .always_500
        .iter()
        .any(|p| request.path.ends_with(p.as_str()))
    {
        let _ = write!(
            out,
            "HTTP/1.1 500 Internal Server Error\r\nContent-Length: 4\r\n\r\ndead"
        );
        return true;
    }
    if let Some((user, password)) = &plan.require_auth {
        let expected = format!(
            "Basic {}",
            base64_encode(format!("{user}:{password}").as_bytes())
        );
        if request.authorization.as_deref() != Some(expected.as_str()) {
            let _ = write!(
                out,
                "HTTP/1.1 401 Unauthorized\r\nWWW-Authenticate: Basic realm=\"test\"\r\nContent-Length: 0\r\n\r\n"
            );
            return true;
        }
    }
    let faults_so_far = counters.path(&request.path).faults;
    let fault = fault_for(plan, &mut rng, faults_so_far);
    if fault.is_some() {
        counters.faults.fetch_add(1, Ordering::SeqCst);
        if let Some(stats) = counters
            .paths
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get_mut(&request.path)
        {
            stats.faults += 1;
        }
    }
    if !plan.latency.is_zero() {
        std::thread::sleep(Duration::from_micros(
            rng.below(plan.latency.as_micros() as u64 + 1),
        ));
    }
    match fault {
        Some(Fault::Silence) => {
            hold(plan, stop);
            return false;
        }
        Some(Fault::Reset) => return false,
        Some(Fault::Error500) => {
            let _ = write!(
                out,
                "HTTP/1.1 500 Internal Server Error\r\nContent-Length: 8\r\n\r\ninjected"
            );
            return true;
        }
        Some(Fault::Error503) => {
            let _ = write!(
                out,
                "HTTP/1.1 503 Service Unavailable\r\nRetry-After: {}\r\nContent-Length: 4\r\n\r\nbusy",
                plan.retry_after_s
            );
            return true;
        }
        _ => {}
    }
    let relative = request.path.trim_start_matches('/');
    let file: PathBuf = root.join(relative);
    let escapes = relative.split('/').any(|part| part == "..");
    let data = if escapes || !file.is_file() {
        None
    } else {
        std::fs::read(&file).ok()
    };
    let Some(data) = data else {
        let _ = write!(out, "HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\n\r\n");
        return true;
    };
    let len = data.len() as u64;
    let ranged = request.range.as_deref().filter(|_| !plan.ignore_range);
    let (status, start, end) = match ranged {
        Some(range) => match parse_range(range, len) {
            Some((start, end)) => ("206 Partial Content", start, end),
            None => {
                let _ = write!(
                    out,
                    "HTTP/1.1 416 Range Not Satisfiable\r\nContent-Range: bytes */{len}\r\nContent-Length: 0\r\n\r\n"
                );
                return true;
            }
        },
        None => ("200 OK", 0, len),
    };
    let body = &data[start as usize..end as usize];
    let framing = match plan.framing {
        Framing::Mixed => {
            [Framing::Length, Framing::Chunked, Framing::Close][rng.below(3) as usize]
        }
        framing => framing,
    };
    let mut head = format!("HTTP/1.1 {status}\r\nAccept-Ranges: bytes\r\n");
    if status.starts_with("206") {
        head.push_str(&format!(
            "Content-Range: bytes {start}-{}/{len}\r\n",
            end - 1
        ));
    }
    // A wrong length: announced with Content-Length whatever the framing.
    let announced = match fault {
        Some(Fault::LongLength) => Some(body.len() as u64 + 1 + rng.below(100)),
        Some(Fault::ShortLength) if !body.is_empty() => Some(rng.below(body.len() as u64)),
        _ => None,
    };
    let framing = if announced.is_some() {
        Framing::Length
    } else {
        framing
    };
    match framing {
        Framing::Length => head.push_str(&format!(
            "Content-Length: {}\r\n",
            announced.unwrap_or(body.len() as u64)
        )),
        Framing::Chunked => head.push_str("Transfer-Encoding: chunked\r\n"),
        Framing::Close | Framing::Mixed => head.push_str("Connection: close\r\n"),
    }
    head.push_str("\r\n");
    if out.write_all(head.as_bytes()).is_err() {
        return false;
    }
    if request.method == "HEAD" {
        return framing != Framing::Close;
    }
    let cut = match fault {
        Some(Fault::Truncate) if !body.is_empty() => Some(rng.below(body.len() as u64) as usize),
        _ => None,
    };
    let sent = &body[..cut.unwrap_or(body.len())];
    let written = match framing {
        Framing::Chunked => {
            let mut result = Ok(());
            let mut rest = sent;
            while !rest.is_empty() && result.is_ok() {
                let take = (1 + rng.below(4096) as usize).min(rest.len());
                result = write!(out, "{take:x}\r\n")
                    .and_then(|_| out.write_all(&rest[..take]))
                    .and_then(|_| out.write_all(b"\r\n"));
                rest = &rest[take..];
            }
            if cut.is_none() {
                result = result.and_then(|_| out.write_all(b"0\r\n\r\n"));
            }
            result
        }
        _ => out.write_all(sent),
    };
    if written.is_err() || cut.is_some() || announced.is_some() {
        return false;
    }
    framing != Framing::Close
}

/// Standard base64 (the `Authorization: Basic` header's encoding).
pub fn base64_encode(bytes: &[u8]) -> String {
    const TABLE: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(TABLE[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}
