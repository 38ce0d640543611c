//! A small HTTP/1.1 file server on 127.0.0.1 for the remote-store tests: GET (with `Range`)
//! and HEAD of the files under a folder, keep-alive, and faults on demand: latency per
//! request, a bandwidth bound, and every Nth request dropped (connection closed unanswered),
//! answered 500, or cut short. Stopped when dropped.

use std::io::{BufRead, BufReader, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What goes wrong, and how slowly. Every field 0 / `None`: a fast, faultless server.
#[derive(Debug, Clone, Copy, Default)]
pub struct Faults {
    /// Added before each answer.
    pub latency: Duration,
    /// Bytes per second of all answers' bodies together, at most (one link's bandwidth).
    pub bandwidth: Option<u64>,
    /// Every Nth request (N > 0) is dropped: the connection closes without an answer.
    pub drop_every: u64,
    /// Every Nth request is answered `500 Internal Server Error`.
    pub error_every: u64,
    /// Every Nth GET's body is cut at half its announced length, then the connection closes.
    pub truncate_every: u64,
    /// Every request is answered `403 Forbidden`.
    pub forbid: bool,
    /// A request for what does not exist is answered `403 Forbidden`, as an S3 bucket that
    /// lets nobody list it answers (no `s3:ListBucket`).
    pub missing_forbidden: bool,
    /// Requests whose path starts with this are answered `403 Forbidden` (a deny policy).
    pub deny_prefix: Option<&'static str>,
}

/// Requests and bytes the server has seen.
#[derive(Debug, Default)]
pub struct ServerCounters {
    pub requests: AtomicU64,
    /// Body bytes sent.
    pub bytes: AtomicU64,
    pub faults: AtomicU64,
    /// Requests being answered now, and the most at once so far.
    pub in_flight: AtomicU64,
    pub peak_in_flight: AtomicU64,
    /// When the shared link is free again (the bandwidth bound's clock).
    link_free_at: Mutex<Option<Instant>>,
    /// When each answered request arrived and was answered, in the order they ended.
    spans: Mutex<Vec<(Instant, Instant)>>,
    /// Each request's path (and `Range` header, if any) in the order they arrived.
    arrivals: Mutex<Vec<(String, Option<String>)>>,
}

impl ServerCounters {
    /// Counts a request that arrives now; its arrival.
    fn began(&self) -> Instant {
        let now = self.in_flight.fetch_add(1, Ordering::SeqCst) + 1;
        self.peak_in_flight.fetch_max(now, Ordering::SeqCst);
        Instant::now()
    }

    /// Counts the end of the request that arrived at `started`.
    fn ended(&self, started: Instant) {
        self.in_flight.fetch_sub(1, Ordering::SeqCst);
        self.spans
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .push((started, Instant::now()));
    }

    /// Every request's path (without the leading `/`) and `Range` header, in the order they
    /// arrived.
    pub fn arrivals(&self) -> Vec<(String, Option<String>)> {
        self.arrivals
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .clone()
    }

    /// Round trips one after another so far: the longest chain of requests each of which
    /// arrived after the one before it had been answered. Requests in flight together are one
    /// round trip; a client that waits for each answer before its next request makes as many
    /// round trips as requests. With latency added to every request, a loaded machine can only
    /// make requests that were concurrent look later (never the reverse), so this is an upper
    /// bound on what the client did, read from what the server saw.
    pub fn sequential_round_trips(&self) -> usize {
        let mut spans = self
            .spans
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .clone();
        spans.sort_by_key(|&(start, _)| start);
        // depth[i]: the longest chain ending with request i.
        let mut depth: Vec<usize> = Vec::with_capacity(spans.len());
        for (i, &(start, _)) in spans.iter().enumerate() {
            let before = (0..i)
                .filter(|&j| spans[j].1 <= start)
                .map(|j| depth[j])
                .max()
                .unwrap_or(0);
            depth.push(before + 1);
        }
        depth.into_iter().max().unwrap_or(0)
    }
}

/// A running server; stops when dropped.
pub struct FileServer {
    port: u16,
    stop: Arc<AtomicBool>,
    pub counters: Arc<ServerCounters>,
    thread: Option<JoinHandle<()>>,
}

impl FileServer {
    /// Serves the files under `root` on a free port of 127.0.0.1.
    pub fn start(root: &Path, faults: Faults) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind 127.0.0.1");
        let port = listener.local_addr().expect("local address").port();
        let stop = Arc::new(AtomicBool::new(false));
        let counters = Arc::new(ServerCounters::default());
        let root = root.to_path_buf();
        let thread = {
            let stop = stop.clone();
            let counters = counters.clone();
            std::thread::spawn(move || {
                for stream in listener.incoming() {
                    if stop.load(Ordering::SeqCst) {
                        break;
                    }
                    let Ok(stream) = stream else { continue };
                    let root = root.clone();
                    let counters = counters.clone();
                    std::thread::spawn(move || serve(stream, &root, faults, &counters));
                }
            })
        };
        Self {
            port,
            stop,
            counters,
            thread: Some(thread),
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

impl Drop for FileServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wakes the accept loop so that it sees the flag.
        let _ = TcpStream::connect(("127.0.0.1", self.port));
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

struct Request {
    method: String,
    path: String,
    range: Option<String>,
}

fn read_request(reader: &mut BufReader<TcpStream>) -> Option<Request> {
    let mut line = String::new();
    if reader.read_line(&mut line).ok()? == 0 {
        return None;
    }
    let mut parts = line.split_whitespace();
    let method = parts.next()?.to_owned();
    let path = parts.next()?.to_owned();
    let mut range = None;
    loop {
        let mut header = String::new();
        if reader.read_line(&mut header).ok()? == 0 {
            return None;
        }
        let header = header.trim_end();
        if header.is_empty() {
            break;
        }
        if let Some((name, value)) = header.split_once(':')
            && name.trim().eq_ignore_ascii_case("range")
        {
            range = Some(value.trim().to_owned());
        }
    }
    Some(Request {
        method,
        path,
        range,
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

fn serve(stream: TcpStream, root: &Path, faults: Faults, counters: &ServerCounters) {
    let Ok(reader_stream) = stream.try_clone() else {
        return;
    };
    let mut reader = BufReader::new(reader_stream);
    let mut out = stream;
    while let Some(request) = read_request(&mut reader) {
        let started = counters.began();
        let keep_open = answer(&mut out, &request, root, faults, counters);
        counters.ended(started);
        if !keep_open {
            return;
        }
    }
}

/// Answers one request; whether the connection stays open.
fn answer(
    out: &mut TcpStream,
    request: &Request,
    root: &Path,
    faults: Faults,
    counters: &ServerCounters,
) -> bool {
    let n = counters.requests.fetch_add(1, Ordering::SeqCst) + 1;
    counters
        .arrivals
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
        .push((
            request.path.trim_start_matches('/').to_owned(),
            request.range.clone(),
        ));
    std::thread::sleep(faults.latency);
    let every = |k: u64| k > 0 && n.is_multiple_of(k);
    if every(faults.drop_every) {
        counters.faults.fetch_add(1, Ordering::SeqCst);
        let _ = out.shutdown(Shutdown::Both);
        return false;
    }
    let denied = faults
        .deny_prefix
        .is_some_and(|prefix| request.path.starts_with(prefix));
    if faults.forbid || denied {
        let _ = write!(out, "HTTP/1.1 403 Forbidden\r\nContent-Length: 0\r\n\r\n");
        return true;
    }
    if every(faults.error_every) {
        counters.faults.fetch_add(1, Ordering::SeqCst);
        let body = "injected failure";
        let _ = write!(
            out,
            "HTTP/1.1 500 Internal Server Error\r\nContent-Length: {}\r\n\r\n{body}",
            body.len()
        );
        return true;
    }
    let relative = request.path.split('?').next().unwrap_or_default();
    let file: PathBuf = root.join(relative.trim_start_matches('/'));
    let escapes = relative.split('/').any(|part| part == "..");
    let data = if escapes || !file.is_file() {
        None
    } else {
        std::fs::read(&file).ok()
    };
    let Some(data) = data else {
        let status = if faults.missing_forbidden {
            "403 Forbidden"
        } else {
            "404 Not Found"
        };
        let _ = write!(out, "HTTP/1.1 {status}\r\nContent-Length: 0\r\n\r\n");
        return true;
    };
    let len = data.len() as u64;
    let etag = format!("\"{len:x}-{}\"", relative.len());
    let (status, start, end) = match request.range.as_deref() {
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
    let mut head = format!(
        "HTTP/1.1 {status}\r\nContent-Length: {}\r\nETag: {etag}\r\nAccept-Ranges: bytes\r\n",
        end - start
    );
    if status.starts_with("206") {
        head.push_str(&format!(
            "Content-Range: bytes {start}-{}/{len}\r\n",
            end - 1
        ));
    }
    head.push_str("\r\n");
    if out.write_all(head.as_bytes()).is_err() {
        return false;
    }
    if request.method == "HEAD" {
        return true;
    }
    let body = &data[start as usize..end as usize];
    let cut = request.method == "GET" && every(faults.truncate_every) && body.len() > 1;
    let body = if cut {
        counters.faults.fetch_add(1, Ordering::SeqCst);
        &body[..body.len() / 2]
    } else {
        body
    };
    if send(out, body, faults.bandwidth, counters).is_err() {
        return false;
    }
    counters
        .bytes
        .fetch_add(body.len() as u64, Ordering::SeqCst);
    if cut {
        let _ = out.shutdown(Shutdown::Both);
        return false;
    }
    true
}

/// Writes `body`; with a `bandwidth`, in 16 KiB pieces, each waiting for its turn on one
/// link shared by all connections.
fn send(
    out: &mut TcpStream,
    body: &[u8],
    bandwidth: Option<u64>,
    counters: &ServerCounters,
) -> std::io::Result<()> {
    let Some(rate) = bandwidth.filter(|&r| r > 0) else {
        return out.write_all(body);
    };
    for piece in body.chunks(16 << 10) {
        let done = {
            let mut free = counters
                .link_free_at
                .lock()
                .unwrap_or_else(|poisoned| poisoned.into_inner());
            let start = free.map_or(Instant::now(), |f| f.max(Instant::now()));
            let done = start + Duration::from_secs_f64(piece.len() as f64 / rate as f64);
            *free = Some(done);
            done
        };
        std::thread::sleep(done.saturating_duration_since(Instant::now()));
        out.write_all(piece)?;
    }
    Ok(())
}

/// The OME-Zarr fixture `name` (under tests/data/ome-zarr) served by a faultless server of its
/// own, and opened from its URL.
pub fn fixture_over_http(name: &str) -> (FileServer, voxscope_volume::ome_zarr::Pyramid) {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/ome-zarr");
    let server = FileServer::start(&fixtures, Faults::default());
    let pyramid = voxscope_volume::ome_zarr::Pyramid::open_url(
        &server.url(name),
        voxscope_volume::ome_zarr::PyramidOptions::default(),
        voxscope_volume::remote::RemoteOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    (server, pyramid)
}
