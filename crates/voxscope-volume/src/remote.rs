//! Zarr stores behind URLs: `http://` and `https://` servers and `s3://` object storage (AWS,
//! MinIO, Ceph, anything S3-compatible), read as a zarrs [`ReadableStorageTraits`] store, so
//! [`super::ome_zarr::Pyramid`] reads them as it reads a folder. HTTP goes through voxscope's
//! own client over reqwest ([`http`]), S3 through object_store's signing client ([`s3`]); the
//! retries, deadlines, caching and failure bookkeeping here are the same for both.
//!
//! - **URLs** are parsed and checked by voxscope first ([`url`]); one that no request can be
//!   made to is refused in one line. Every URL shown anywhere passes through [`redact_url`]
//!   (no user name, password, query or fragment). A URL's `user:password@` is sent as HTTP
//!   basic authentication, over HTTPS or to this machine only.
//! - **Concurrency**: at most [`RemoteOptions::max_requests`] requests in flight (default
//!   [`DEFAULT_MAX_REQUESTS`]), and one fetch per object and piece at a time: a reader asking
//!   for what is being fetched waits for that fetch. zarrs asks for one chunk at a time per
//!   reading thread, so a region read first fetches all its chunks at once
//!   ([`RemoteStore::prefetch`]), and a streamer starts the fetches of the bricks it will
//!   read next without waiting ([`RemoteStore::fetch_ahead`]), in its order, so that the
//!   link stays full. Sharded arrays are read by byte ranges: the ranges asked of one object
//!   together are coalesced where they are adjacent or nearly so ([`COALESCE_GAP`]), one
//!   request for many inner chunks ([`RemoteStore::prefetch_ranges`]).
//! - **Cache**: fetched bytes stay in RAM up to [`FETCH_CACHE_BYTES`], and so does which
//!   objects are missing. A server that ignores `Range` (answering `200` with the whole
//!   object) is read all the same: the whole object is kept and cut, and once the store knows
//!   the server does so it asks for whole objects.
//! - **Time bounds** ([`Timing`]): connecting 5 s; one request, its whole body included,
//!   20 s; one operation (an object with its retries) 10 s while the store is opened and 30 s
//!   afterwards. 5xx answers, 408, 429, resets, timeouts and cut bodies are retried with
//!   exponential backoff (or after what `Retry-After` asks, up to 20 s). A server that lets a
//!   request time out without answering anything is taken to be silent: every request fails at
//!   once for 5 s, so that a dead server costs one timeout, not one per object.
//! - **Failures are remembered** per object ([`remembered`]): within a while, asking again
//!   answers with the same failure without a request; permanent ones (401, 403, a body larger
//!   than the object may be) for the store's life. While most recent operations failed after
//!   their retries (a dead level), an operation retries twice, not eight times.
//! - **Bodies** without `Content-Length` (chunked, or ended by closing the connection) are
//!   read, each within the size its object may have ([`RemoteStore::bound_objects`]: a
//!   level's chunks register theirs; metadata 16 MiB).
//! - **Errors** say the cause first and whole (`HTTP 500 Internal Server Error (after 9
//!   tries)`, `connection refused`, `host not found (DNS)`, `no answer within 10 s`, `access
//!   denied (HTTP 403)`, `the bucket 'b' does not exist`); callers name the object. No secret
//!   (password, query, AWS secret key or session token, the endpoint's password) appears.
//! - **Credentials** for `s3://`: the standard AWS variables, else the profile of
//!   `~/.aws/credentials` and `~/.aws/config`, else web identity / container credentials
//!   where their variables are set, else anonymous (unsigned) requests.
//!
//! Store calls are synchronous (zarrs's store traits are): each blocks its reading thread on a
//! small process-wide tokio runtime; a panic inside is caught and becomes that read's error.

use std::collections::HashMap;
use std::future::Future;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use futures::FutureExt;
use futures::future::{BoxFuture, Shared};
use tokio::sync::Semaphore;
use zarrs::storage::byte_range::{ByteRange, ByteRangeIterator};
use zarrs::storage::{
    Bytes, MaybeBytes, MaybeBytesIterator, ReadableStorageTraits, StorageError, StoreKey,
};

use super::error::{Problem, escape};
use cache::{FetchCache, Piece};
use documents::Known;
use fault::{Failure, Health};
use held::HeldPieces;
use http::{Answer, HttpTransport};
pub use open_error::OpenError;
use s3::S3Transport;
pub use url::UrlError;
use url::{Scheme, StoreUrl};

mod aws;
mod cache;
mod documents;
mod open_error;
pub(crate) use documents::NODE_DOCUMENTS;
mod fault;
mod fetch;
mod held;
mod http;
mod remembered;
mod s3;
mod url;

use fetch::Fetched;

pub use fault::Timing;
pub use held::HeldFetches;
pub use url::{redact_url, resolve_url};

/// Requests in flight at once by default: enough to fill a fast link at 50–100 ms of latency
/// with chunks of ~1 MiB, few enough for a small lab server.
pub const DEFAULT_MAX_REQUESTS: usize = 32;

/// Byte ranges of one object asked for together are fetched as one request where the gap
/// between them is at most this: a request costs a round trip, a few KiB of gap far less.
pub const COALESCE_GAP: u64 = 64 << 10;

/// The most bytes one coalesced request asks for: larger runs are split, so that they still
/// travel in parallel.
pub const MAX_COALESCED_BYTES: u64 = 8 << 20;

/// The most requests in flight that `--max-requests` accepts.
pub const MAX_MAX_REQUESTS: usize = 1024;

/// The largest object (a whole chunk or shard) read in one piece, unless its level registered
/// a smaller bound ([`RemoteStore::bound_objects`]).
pub const MAX_OBJECT_BYTES: u64 = 2 << 30;

/// Fetched bytes (whole chunks, inner-chunk ranges, shard indexes) kept in RAM, at most:
/// a padded brick reads the edges of its neighbours' chunks, and zarrs reads a shard's index
/// again for every region in the shard, so without it most bytes would cross the network
/// several times. Objects are taken not to change while a store is open.
pub const FETCH_CACHE_BYTES: u64 = 256 << 20;

/// How a remote store is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RemoteOptions {
    /// Requests in flight at once, at most (1 to [`MAX_MAX_REQUESTS`]).
    pub max_requests: usize,
    /// The time bounds.
    pub timing: Timing,
}

impl Default for RemoteOptions {
    fn default() -> Self {
        Self {
            max_requests: DEFAULT_MAX_REQUESTS,
            timing: Timing::default(),
        }
    }
}

/// Whether `spec` names a remote store (`http://`, `https://`, `s3://`) rather than a path or
/// a `synthetic:` spec: the app uses it to tell a URL from a file in its recent list.
pub fn is_url(spec: &str) -> bool {
    url::scheme_of(spec).is_some()
}

/// Checks `spec` as a store's URL without contacting anything: `Err` is the one line that
/// says why no request could be made to it (the app's Open URL window shows it as it is
/// typed).
pub fn check_url(spec: &str) -> Result<(), UrlError> {
    StoreUrl::parse(spec).map(|_| ())
}

/// Counters of one remote store, for the app's panel and benchmarks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RemoteStats {
    /// Requests answered (each range of a shard is one).
    pub requests: u64,
    /// Requests in flight now.
    pub in_flight: u64,
    /// The most requests that were in flight at once.
    pub peak_in_flight: u64,
    /// Bytes received (bodies).
    pub bytes: u64,
    /// Operations that failed after their retries (a missing object is no failure; an answer
    /// from the remembered failures is not counted again).
    pub errors: u64,
}

#[derive(Default)]
struct Counters {
    requests: AtomicU64,
    in_flight: AtomicU64,
    peak_in_flight: AtomicU64,
    bytes: AtomicU64,
    errors: AtomicU64,
}

/// Where requests go.
enum Transport {
    Http(HttpTransport),
    S3(S3Transport),
}

impl Transport {
    async fn get(&self, key: &str, piece: Piece, bound: u64) -> Result<Answer, Failure> {
        match self {
            Self::Http(http) => http.get(key, piece, bound).await,
            Self::S3(s3) => s3.get(key, piece, bound).await,
        }
    }

    async fn head(&self, key: &str) -> Result<Option<Option<u64>>, Failure> {
        match self {
            Self::Http(http) => http.head(key).await,
            Self::S3(s3) => s3.head(key).await,
        }
    }
}

/// Whether the server honours `Range`, as far as the store has seen.
const RANGES_UNKNOWN: u8 = 0;
const RANGES_HONOURED: u8 = 1;
const RANGES_IGNORED: u8 = 2;

/// A fetch in flight that every reader of the same object and piece waits for.
type Flight = Shared<BoxFuture<'static, Result<Answer, Failure>>>;

/// A Zarr store at a URL (see the module's documentation).
pub struct RemoteStore {
    inner: Arc<Inner>,
}

struct Inner {
    transport: Transport,
    /// The URL as messages show it.
    shown: String,
    timing: Timing,
    limit: Arc<Semaphore>,
    /// Fetches started by [`RemoteStore::fetch_ahead`] and not yet ended, and the most that
    /// may be (twice the request limit: one round trip's requests in flight, the next
    /// round's waiting for a permit).
    ahead: Arc<AtomicUsize>,
    max_ahead: usize,
    opened: AtomicBool,
    counters: Counters,
    cache: Mutex<FetchCache>,
    /// What batch fetches hold for the reads after them ([`RemoteStore::prefetch`]).
    held: Arc<Mutex<HeldPieces>>,
    /// What document batches learned besides bytes ([`RemoteStore::prefetch_documents`]).
    known: Mutex<HashMap<String, Known>>,
    remembered: remembered::Remembered,
    health: Health,
    flights: Mutex<HashMap<(String, Piece), Flight>>,
    ranges: AtomicU8,
    /// The most bytes an object under each key prefix may have (longest prefix wins).
    bounds: Mutex<Vec<(String, u64)>>,
    /// Strings that must never appear in a message (passwords, AWS secrets).
    secrets: Vec<String>,
}

/// reqwest is built without a TLS crypto provider of its own: ring's is installed once, before
/// the first client is built (an error only says that one is installed already).
fn install_crypto_provider() {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let _ = rustls::crypto::ring::default_provider().install_default();
    });
}

fn runtime() -> Result<&'static tokio::runtime::Runtime, Problem> {
    static RUNTIME: OnceLock<std::io::Result<tokio::runtime::Runtime>> = OnceLock::new();
    RUNTIME
        .get_or_init(|| {
            tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .thread_name("voxscope-net")
                .enable_all()
                .build()
        })
        .as_ref()
        .map_err(|e| format!("cannot start the network runtime: {e}"))
}

/// Runs `future` to its end on the network runtime from a synchronous caller; a panic inside
/// becomes an error (a library's bug costs that read, not the process).
fn block_on<T>(future: impl Future<Output = Result<T, Failure>>) -> Result<T, Failure> {
    let runtime = runtime().map_err(Failure::permanent)?;
    match std::panic::catch_unwind(AssertUnwindSafe(|| runtime.block_on(future))) {
        Ok(result) => result,
        Err(panic) => {
            let text = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(Failure::permanent(format!(
                "the network client failed ({})",
                escape(&text)
            )))
        }
    }
}

impl RemoteStore {
    /// Opens the store at `url` (`http://`, `https://` or `s3://BUCKET/PATH`); contacts nothing
    /// yet. The error is one line without secrets (a URL that cannot be parsed or that no
    /// request can be made to, an unknown scheme, a password for plain HTTP elsewhere).
    pub fn open(url: &str, options: RemoteOptions) -> Result<Arc<Self>, OpenError> {
        install_crypto_provider();
        let parsed = StoreUrl::parse(url)?;
        let max_requests = options.max_requests.clamp(1, MAX_MAX_REQUESTS);
        let timing = options.timing;
        let mut secrets: Vec<String> = parsed
            .credentials()
            .map(|(user, password)| [Some(user), password].into_iter().flatten().collect())
            .unwrap_or_default();
        if let Some(query) = parsed.url.query() {
            secrets.extend(
                query
                    .split('&')
                    .filter_map(|p| p.split_once('='))
                    .map(|(_, v)| v.to_owned()),
            );
        }
        let transport = match parsed.scheme {
            Scheme::Http => {
                Transport::Http(HttpTransport::new(&parsed, timing.connect, max_requests)?)
            }
            Scheme::S3 => {
                let s3 = S3Transport::new(&parsed, timing.connect, timing.request, max_requests)?;
                secrets.extend(s3.secrets().iter().cloned());
                Transport::S3(s3)
            }
        };
        secrets.retain(|s| s.len() >= 3);
        Ok(Arc::new(Self {
            inner: Arc::new(Inner {
                transport,
                shown: parsed.shown,
                timing,
                limit: Arc::new(Semaphore::new(max_requests)),
                ahead: Arc::default(),
                max_ahead: 2 * max_requests,
                opened: AtomicBool::new(false),
                counters: Counters::default(),
                cache: Mutex::new(FetchCache::default()),
                held: Arc::default(),
                known: Mutex::default(),
                remembered: remembered::Remembered::default(),
                health: Health::default(),
                flights: Mutex::default(),
                ranges: AtomicU8::new(RANGES_UNKNOWN),
                bounds: Mutex::default(),
                secrets,
            }),
        }))
    }

    /// The URL as messages show it (no user name, password or query).
    pub fn url(&self) -> &str {
        &self.inner.shown
    }

    /// Marks the store open: operations may take [`Timing::read_deadline`] from now on, not
    /// [`Timing::open_deadline`]; transient failures met while opening are forgotten.
    pub fn mark_opened(&self) {
        self.inner.opened.store(true, Ordering::Relaxed);
        self.forget_failures();
        self.inner.remembered.forget_transient();
    }

    /// Keeps at most `bytes` of fetched bytes in RAM from now on ([`FETCH_CACHE_BYTES`] until
    /// this is called): the streamer's share of its RAM budget.
    pub fn set_cache_bytes(&self, bytes: u64) {
        if let Ok(mut cache) = self.inner.cache.lock() {
            cache.set_capacity(bytes);
        }
    }

    /// Bytes of fetched objects kept in RAM now: the fetch cache's, and what batch fetches
    /// hold beyond it for the reads after them ([`Self::prefetch`]). About: a held piece
    /// cut from a larger answer keeps all of that answer alive, and counts its own bytes.
    pub fn cached_bytes(&self) -> u64 {
        let (Ok(cache), Ok(held)) = (self.inner.cache.lock(), self.inner.held.lock()) else {
            return 0;
        };
        cache.bytes() + held.bytes_besides(|key, piece| cache.piece(key, piece).is_some())
    }

    /// The counters so far.
    pub fn stats(&self) -> RemoteStats {
        let c = &self.inner.counters;
        RemoteStats {
            requests: c.requests.load(Ordering::Relaxed),
            in_flight: c.in_flight.load(Ordering::Relaxed),
            peak_in_flight: c.peak_in_flight.load(Ordering::Relaxed),
            bytes: c.bytes.load(Ordering::Relaxed),
            errors: c.errors.load(Ordering::Relaxed),
        }
    }

    /// Objects whose keys start with `prefix` (a level's path and `/`) hold at most
    /// `max_bytes`: a body that grows past that is cut off and refused (a chunk of that level
    /// cannot be larger), whether or not the server announced its length.
    pub fn bound_objects(&self, prefix: &str, max_bytes: u64) {
        if let Ok(mut bounds) = self.inner.bounds.lock() {
            bounds.retain(|(p, _)| p != prefix);
            bounds.push((prefix.to_owned(), max_bytes));
        }
    }

    /// The last failure of the object `key`, if it failed (remembered or not any more): its
    /// cause alone (`HTTP 500 Internal Server Error`, shared by objects failing the same way)
    /// and the cause with its tries (`… (after 9 tries)`), what a message naming the chunk says.
    pub fn failure_of(&self, key: &str) -> Option<(String, String)> {
        let failure = self.inner.remembered.last(key)?;
        let secrets = &self.inner.secrets;
        Some((
            url::redact_text(&failure.cause, secrets),
            url::redact_text(&failure.describe(), secrets),
        ))
    }

    /// Fetches `keys` (whole objects: unsharded chunks) all at once, up to the request limit,
    /// into the fetch cache that [`ReadableStorageTraits::get`] reads first; missing objects
    /// are remembered as missing, failed ones as failed. What it fetched, and what of `keys`
    /// the cache kept or a batch held already, stays readable while the answer lives,
    /// whatever the cache drops meanwhile ([`HeldFetches`]). One object to fetch is left to
    /// its read.
    pub fn prefetch(&self, keys: &[StoreKey]) -> HeldFetches {
        let inner = &self.inner;
        let mut held = HeldFetches::default();
        let mut wanted: Vec<String> = Vec::new();
        match (inner.cache.lock(), inner.held.lock()) {
            (Ok(mut cache), Ok(mut held_now)) => {
                for key in keys.iter().map(|key| key.as_str()) {
                    // Held for its read from now on: what was fetched ahead of it is used.
                    cache.mark_read(key);
                    let kept = cache
                        .get(key, Piece::Whole)
                        .or_else(|| held_now.piece(key, Piece::Whole)?.ok());
                    match kept {
                        Some(bytes) => {
                            held.hold_locked(&mut held_now, &inner.held, key, Piece::Whole, &bytes)
                        }
                        None if !cache.is_missing(key) => wanted.push(key.to_owned()),
                        None => {}
                    }
                }
            }
            _ => return held,
        }
        if wanted.len() < 2 {
            return held;
        }
        let reads = wanted
            .iter()
            .map(|key| inner.clone().read(key.clone(), Piece::Whole, None));
        let answers =
            block_on(async { Ok(futures::future::join_all(reads).await) }).unwrap_or_default();
        for (key, answer) in wanted.iter().zip(answers) {
            if let Ok(Some(bytes)) = answer {
                held.hold(&inner.held, key, Piece::Whole, &bytes);
            }
        }
        held
    }

    /// Whether [`Self::fetch_ahead`] has room for another fetch now (cheap: a caller asks
    /// before it works out keys).
    pub fn can_fetch_ahead(&self) -> bool {
        // Before any object's size is known, what `fetch_ahead` is given decides.
        self.inner.ahead_room(1) > 0
    }

    /// Starts fetching `keys` (whole objects: unsharded chunks) in this order, the first
    /// soonest, and returns without waiting: what a streamer will read next, asked for while
    /// its loaders still decode what came before. Objects kept, known missing, remembered as
    /// failed or being fetched are skipped; at most twice the request limit of these fetches
    /// are under way at once (one round trip's in flight, the next waiting for a permit in
    /// this order), and only while these and what was fetched ahead and not read yet fit in
    /// half the fetch cache (a small cache dropped what was fetched ahead before its read,
    /// which fetched it again); the rest is left for a later call. A reader of a key fetched
    /// ahead waits for that fetch. Returns how many of `keys`, from the first, are fetched, being fetched or
    /// settled (missing, failed): those need not be asked for again.
    pub fn fetch_ahead(&self, keys: &[StoreKey]) -> usize {
        let inner = &self.inner;
        let Some(first) = keys.first() else { return 0 };
        let bound = inner.bound(first.as_str());
        let Ok(runtime) = runtime() else { return 0 };
        let mut wanted: Vec<String> = Vec::new();
        let mut handled = 0;
        {
            let (Ok(mut cache), Ok(flights), Ok(held)) =
                (inner.cache.lock(), inner.flights.lock(), inner.held.lock())
            else {
                return 0;
            };
            // The room, and the fetches counted in it, under the cache's lock: loaders calling
            // at once share it.
            let room = inner.ahead_room_locked(&mut cache, bound);
            if room == 0 {
                return 0;
            }
            for key in keys {
                let key = key.as_str();
                let busy = cache.get(key, Piece::Whole).is_some()
                    || held.piece(key, Piece::Whole).is_some()
                    || cache.is_missing(key)
                    || flights.contains_key(&(key.to_owned(), Piece::Whole))
                    || wanted.iter().any(|w| w == key);
                if !busy {
                    if wanted.len() == room {
                        break;
                    }
                    wanted.push(key.to_owned());
                }
                handled += 1;
            }
            inner.ahead.fetch_add(wanted.len(), Ordering::Relaxed);
        }
        let counted = wanted.len();
        wanted.retain(|key| inner.remembered.get(key).is_none());
        inner
            .ahead
            .fetch_sub(counted - wanted.len(), Ordering::Relaxed);
        if wanted.is_empty() {
            return handled;
        }
        // The flights are made here, in order, so that a reader asking for one of them from
        // now on waits for it; `join_all` polls them in this order, so they queue for the
        // request limit in this order.
        let flights: Vec<_> = wanted
            .into_iter()
            .map(|key| {
                let (flight, ahead) = (
                    inner.flight(&key, Piece::Whole, None, Fetched::Ahead),
                    inner.ahead.clone(),
                );
                async move {
                    let _ = flight.await;
                    ahead.fetch_sub(1, Ordering::Relaxed);
                }
            })
            .collect();
        runtime.spawn(futures::future::join_all(flights));
        handled
    }

    /// Fetches the byte ranges `ranges` of each object (a shard's inner chunks) into the fetch
    /// cache, every object's at once and each object's ranges coalesced ([`coalesce`]), and
    /// returns when they are in: a sharded region read then finds its inner chunks kept, one
    /// request for the adjacent ones instead of one each. They stay readable while the
    /// answer lives, as [`Self::prefetch`]'s do. Failures are remembered as a read's are; what
    /// they cost shows when the region is read.
    pub fn prefetch_ranges(&self, ranges: &[(StoreKey, Vec<ByteRange>)]) -> HeldFetches {
        let mut held = HeldFetches::default();
        self.get_ranges(ranges, &mut held);
        held
    }

    /// The byte ranges `ranges` of each object, fetched as [`Self::prefetch_ranges`] does
    /// and held by `held`: per object its pieces in order, or `None` where the object is
    /// missing or could not be fetched (remembered as a read's failure is).
    pub fn get_ranges(
        &self,
        ranges: &[(StoreKey, Vec<ByteRange>)],
        held: &mut HeldFetches,
    ) -> Vec<Option<Vec<Bytes>>> {
        let reads = ranges.iter().map(|(key, ranges)| {
            let pieces = ranges.iter().map(|&r| Piece::of(r)).collect();
            self.inner
                .clone()
                .read_many(key.as_str().to_owned(), pieces)
        });
        let answers =
            block_on(async { Ok(futures::future::join_all(reads).await) }).unwrap_or_default();
        let mut answers: Vec<Option<Vec<Bytes>>> = answers
            .into_iter()
            .map(|answer| answer.ok()?.into_iter().collect())
            .collect();
        answers.resize(ranges.len(), None);
        for ((key, ranges), pieces) in ranges.iter().zip(&answers) {
            for (&range, bytes) in ranges.iter().zip(pieces.iter().flatten()) {
                held.hold(&self.inner.held, key.as_str(), Piece::of(range), bytes);
            }
        }
        answers
    }
}

/// The requests that fetch `pieces` of one object: ranges sorted by their start and merged
/// where the gap between them is at most [`COALESCE_GAP`] and the run stays within
/// [`MAX_COALESCED_BYTES`]; other pieces (whole, open-ended, suffixes) alone. Each request
/// with the indices of the pieces it holds.
pub(crate) fn coalesce(pieces: &[Piece]) -> Vec<(Piece, Vec<usize>)> {
    let mut groups: Vec<(Piece, Vec<usize>)> = Vec::new();
    let mut ranges: Vec<(u64, u64, usize)> = Vec::new();
    for (index, &piece) in pieces.iter().enumerate() {
        match piece {
            Piece::Range(start, end) => ranges.push((start, end, index)),
            other => groups.push((other, vec![index])),
        }
    }
    ranges.sort_unstable();
    let mut run: Option<(u64, u64, Vec<usize>)> = None;
    for (start, end, index) in ranges {
        match &mut run {
            Some((first, last, members))
                if start <= last.saturating_add(COALESCE_GAP)
                    && end.max(*last) - *first <= MAX_COALESCED_BYTES =>
            {
                *last = end.max(*last);
                members.push(index);
            }
            _ => {
                if let Some((first, last, members)) = run.take() {
                    groups.push((Piece::Range(first, last), members));
                }
                run = Some((start, end, vec![index]));
            }
        }
    }
    if let Some((first, last, members)) = run {
        groups.push((Piece::Range(first, last), members));
    }
    groups
}

impl ReadableStorageTraits for RemoteStore {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        match self.known(key) {
            Some(Known::Failed(message)) => return Err(StorageError::Other(message)),
            Some(Known::TooLarge(_)) | None => {}
        }
        let read = self
            .inner
            .clone()
            .read(key.as_str().to_owned(), Piece::Whole, None);
        block_on(read).map_err(|f| self.inner.storage_error(f))
    }

    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        let pieces: Vec<Piece> = byte_ranges.map(Piece::of).collect();
        if pieces.is_empty() {
            return Ok(Some(Box::new(std::iter::empty())));
        }
        let inner = &self.inner;
        let parts = block_on(inner.clone().read_many(key.as_str().to_owned(), pieces))
            .map_err(|f| inner.storage_error(f))?;
        // A missing object is missing for every piece.
        if parts.iter().any(Option::is_none) {
            return Ok(None);
        }
        let parts: Vec<Result<Bytes, StorageError>> = parts.into_iter().flatten().map(Ok).collect();
        Ok(Some(Box::new(parts.into_iter())))
    }

    fn size_key(&self, key: &StoreKey) -> Result<Option<u64>, StorageError> {
        if let Some(answer) = self.known_size(key) {
            return answer;
        }
        let inner = &self.inner;
        if let Some(failure) = inner.remembered.get(key.as_str()) {
            return Err(inner.storage_error(failure));
        }
        let head = block_on(inner.retrying(|| inner.transport.head(key.as_str()), |_| 0));
        match head {
            Ok(None) => Ok(None),
            Ok(Some(Some(size))) => Ok(Some(size)),
            // The server does not say: the object itself tells.
            Ok(Some(None)) => block_on(inner.clone().read(
                key.as_str().to_owned(),
                Piece::Whole,
                None,
            ))
            .map(|bytes| bytes.map(|b| b.len() as u64))
            .map_err(|f| inner.storage_error(f)),
            Err(failure) => {
                inner.counters.errors.fetch_add(1, Ordering::Relaxed);
                inner
                    .remembered
                    .remember(key.as_str(), &failure, &inner.timing);
                Err(inner.storage_error(failure))
            }
        }
    }

    fn supports_get_partial(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_are_told_from_paths() {
        assert!(is_url("https://data.example.org/cells.ome.zarr"));
        assert!(is_url("HTTP://host/x.zarr"));
        assert!(is_url("s3://bucket/cells.ome.zarr"));
        assert!(!is_url("cells.ome.zarr"));
        assert!(!is_url("/data/http://x"));
        assert!(!is_url("synthetic:noise:64"));
        assert!(!is_url("C:\\data\\x.zarr"));
    }

    #[test]
    fn an_unknown_scheme_is_one_line() {
        let Err(problem) = RemoteStore::open("ftp://host/x.zarr", RemoteOptions::default()) else {
            panic!("ftp opened");
        };
        assert!(problem.to_string().contains("'ftp:'"), "{problem}");
    }
}
