//! Zarr stores behind URLs: `http://` and `https://` servers and `s3://` object storage (AWS,
//! MinIO, Ceph, anything S3-compatible), read through `object_store`'s clients as a zarrs
//! [`ReadableStorageTraits`] store, so [`super::ome_zarr::Pyramid`] reads them as it reads a
//! folder.
//!
//! - **Concurrency**: at most [`RemoteOptions::max_requests`] requests in flight (default
//!   [`DEFAULT_MAX_REQUESTS`]). zarrs asks for one chunk at a time per reading thread, so a
//!   region read first fetches all its chunks at once ([`RemoteStore::prefetch`]). Sharded
//!   arrays are read by byte ranges (the shard index, then only the inner chunks a region
//!   needs), all of one shard's ranges in flight together.
//! - **Cache**: fetched bytes stay in RAM up to [`FETCH_CACHE_BYTES`] (a padded brick reads
//!   the edges of its neighbours' chunks; zarrs reads a shard's index for every region), and
//!   so does which objects are missing (a store's skipped chunks).
//! - **Opening in a few round trips**: the metadata documents of each step of a hierarchy (the
//!   root's, then every level's) are fetched together ([`RemoteStore::prefetch_documents`]),
//!   and what that learned answers the reader's size checks and reads.
//! - **Time bounds**: connecting takes at most [`CONNECT_TIMEOUT`], one request at most
//!   [`REQUEST_TIMEOUT`]; 5xx answers, 429, resets, timeouts and cut bodies are retried with
//!   exponential backoff ([`MAX_RETRIES`]); one store operation with its retries ends within
//!   [`OPEN_DEADLINE`] while the store is opened (a URL that does not answer fails in that
//!   time) and [`READ_DEADLINE`] afterwards.
//! - **Errors** are one line naming the object's URL and what went wrong (HTTP 403 access
//!   denied, 401 unauthenticated, no answer); a missing object is a missing key (Zarr: the fill
//!   value, or "not a Zarr store" at the root). User names, passwords and query strings of a
//!   URL, and the AWS secrets from the environment, never appear in a message.
//! - **Credentials** for `s3://`: the standard AWS variables (`AWS_ACCESS_KEY_ID`,
//!   `AWS_SECRET_ACCESS_KEY`, `AWS_SESSION_TOKEN`, `AWS_REGION`/`AWS_DEFAULT_REGION`,
//!   `AWS_ENDPOINT_URL`, …), else the profile (`AWS_PROFILE`, default `default`) of
//!   `~/.aws/credentials` and `~/.aws/config` (or `AWS_SHARED_CREDENTIALS_FILE`,
//!   `AWS_CONFIG_FILE`), else web identity / container credentials where their variables are
//!   set, else anonymous (unsigned) requests: public buckets need nothing.
//!
//! Store calls are synchronous (zarrs's store traits are): each blocks its reading thread on a
//! small process-wide tokio runtime. A read nobody waits for any more is not started, so the
//! streaming renderer's queue, which drops bricks the view no longer wants, is what cancels.

use std::collections::HashMap;
use std::future::Future;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

use object_store::aws::AmazonS3Builder;
use object_store::http::HttpBuilder;
use object_store::path::Path as ObjectPath;
use object_store::{
    BackoffConfig, ClientOptions, GetOptions, GetRange, ObjectStore, ObjectStoreExt, RetryConfig,
};
use tokio::sync::Semaphore;
use zarrs::storage::byte_range::{ByteRange, ByteRangeIterator};
use zarrs::storage::{
    Bytes, MaybeBytes, MaybeBytesIterator, ReadableStorageTraits, StorageError, StoreKey,
};

use super::error::{Problem, printable};
use cache::{FetchCache, Piece};
use documents::Known;

mod aws;
mod cache;
mod documents;

/// Requests in flight at once by default: enough to fill a fast link at 50–100 ms of latency
/// with chunks of ~1 MiB, few enough for a small lab server.
pub const DEFAULT_MAX_REQUESTS: usize = 32;

/// The most requests in flight that `--max-requests` accepts.
pub const MAX_MAX_REQUESTS: usize = 1024;

/// Time to establish a connection (TCP and TLS).
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// Time for one request, from sending it to the last byte of its answer.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(30);

/// Retries of one request (5xx, 429, connection resets, timeouts, cut bodies), with
/// exponential backoff from 50 ms up to 2 s.
pub const MAX_RETRIES: usize = 8;

/// How long one store operation (its retries included) may take while the store is opened:
/// a URL that does not answer fails within this time.
pub const OPEN_DEADLINE: Duration = Duration::from_secs(10);

/// How long one store operation (its retries included) may take once the store is open.
pub const READ_DEADLINE: Duration = Duration::from_secs(120);

/// The largest object (a whole chunk or shard) read in one piece: a server's length is
/// checked against it before the bytes are collected.
const MAX_OBJECT_BYTES: u64 = 2 << 30;

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
}

impl Default for RemoteOptions {
    fn default() -> Self {
        Self {
            max_requests: DEFAULT_MAX_REQUESTS,
        }
    }
}

/// Whether `spec` names a remote store (`http://`, `https://`, `s3://`) rather than a path or
/// a `synthetic:` spec: the app uses it to tell a URL from a file in its recent list.
pub fn is_url(spec: &str) -> bool {
    scheme_of(spec).is_some()
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scheme {
    Http,
    S3,
}

fn scheme_of(spec: &str) -> Option<Scheme> {
    let lower = spec.trim_start().to_ascii_lowercase();
    if lower.starts_with("http://") || lower.starts_with("https://") {
        Some(Scheme::Http)
    } else if lower.starts_with("s3://") {
        Some(Scheme::S3)
    } else {
        None
    }
}

/// `url` without its user name, password, query and fragment: what messages may show.
pub fn display_url(url: &str) -> String {
    match url::Url::parse(url.trim()) {
        Ok(mut parsed) => {
            // Setting these cannot fail on URLs with a host, the only ones accepted.
            let _ = parsed.set_username("");
            let _ = parsed.set_password(None);
            parsed.set_query(None);
            parsed.set_fragment(None);
            parsed.to_string().trim_end_matches('/').to_owned()
        }
        Err(_) => printable(url.split(['?', '#']).next().unwrap_or_default()),
    }
}

/// Counters of one remote store, for the app's panel and benchmarks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RemoteStats {
    /// Requests answered (each range of a shard is one).
    pub requests: u64,
    /// Requests in flight now.
    pub in_flight: u64,
    /// Bytes received (bodies).
    pub bytes: u64,
    /// Operations that failed after their retries (a missing object is no failure).
    pub errors: u64,
}

#[derive(Default)]
struct Counters {
    requests: AtomicU64,
    in_flight: AtomicU64,
    bytes: AtomicU64,
    errors: AtomicU64,
}

/// A Zarr store at a URL, read through `object_store` (see the module's documentation).
pub struct RemoteStore {
    store: Arc<dyn ObjectStore>,
    /// The object path of the Zarr root inside `store` (empty for HTTP: the URL is the root).
    prefix: String,
    /// The URL as messages show it.
    shown: String,
    limit: Arc<Semaphore>,
    opened: AtomicBool,
    counters: Counters,
    cache: Mutex<FetchCache>,
    /// What document batches learned besides bytes ([`Self::prefetch_documents`]).
    known: Mutex<HashMap<String, Known>>,
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
    static RUNTIME: OnceLock<Result<tokio::runtime::Runtime, String>> = OnceLock::new();
    RUNTIME
        .get_or_init(|| {
            tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .thread_name("voxscope-net")
                .enable_all()
                .build()
                .map_err(|e| format!("cannot start the network runtime: {e}"))
        })
        .as_ref()
        .map_err(Clone::clone)
}

impl RemoteStore {
    /// Opens the store at `url` (`http://`, `https://` or `s3://BUCKET/PATH`); contacts nothing
    /// yet. The error is one line (a URL that cannot be parsed, an unknown scheme).
    pub fn open(url: &str, options: RemoteOptions) -> Result<Arc<Self>, Problem> {
        install_crypto_provider();
        let url = url.trim();
        let parsed = url::Url::parse(url).map_err(|e| format!("is not a valid URL: {e}"))?;
        let max_requests = options.max_requests.clamp(1, MAX_MAX_REQUESTS);
        let mut secrets: Vec<String> = [parsed.password().unwrap_or_default(), parsed.username()]
            .into_iter()
            .filter(|s| s.len() >= 3)
            .map(str::to_owned)
            .collect();
        let client = ClientOptions::new()
            .with_connect_timeout(CONNECT_TIMEOUT)
            .with_timeout(REQUEST_TIMEOUT)
            .with_pool_max_idle_per_host(max_requests);
        let retry = RetryConfig {
            backoff: BackoffConfig {
                init_backoff: Duration::from_millis(50),
                max_backoff: Duration::from_secs(2),
                base: 2.0,
            },
            max_retries: MAX_RETRIES,
            retry_timeout: READ_DEADLINE,
        };
        let (store, prefix): (Arc<dyn ObjectStore>, String) = match scheme_of(url) {
            Some(Scheme::Http) => {
                let base = url.trim_end_matches('/');
                let store = HttpBuilder::new()
                    .with_url(base)
                    .with_client_options(client.with_allow_http(true))
                    .with_retry(retry)
                    .build()
                    .map_err(|e| format!("cannot read over HTTP: {}", one_line(&e, &secrets)))?;
                (Arc::new(store), String::new())
            }
            Some(Scheme::S3) => {
                let bucket = parsed
                    .host_str()
                    .filter(|b| !b.is_empty())
                    .ok_or("names no bucket (s3://BUCKET/PATH)")?
                    .to_owned();
                let prefix = parsed.path().trim_matches('/').to_owned();
                let credentials = aws::Credentials::find();
                secrets.extend(credentials.secrets());
                let builder = credentials.apply(
                    AmazonS3Builder::from_env()
                        .with_bucket_name(&bucket)
                        .with_retry(retry),
                );
                let http_endpoint = builder
                    .get_config_value(&object_store::aws::AmazonS3ConfigKey::Endpoint)
                    .is_some_and(|e| e.to_ascii_lowercase().starts_with("http://"));
                let store = builder
                    .with_client_options(client.with_allow_http(http_endpoint))
                    .build()
                    .map_err(|e| format!("cannot read from S3: {}", one_line(&e, &secrets)))?;
                (Arc::new(store), prefix)
            }
            None => {
                return Err(format!(
                    "has the scheme '{}:'; remote stores are http://, https:// or s3://",
                    printable(parsed.scheme())
                ));
            }
        };
        Ok(Arc::new(Self {
            store,
            prefix,
            shown: display_url(url),
            limit: Arc::new(Semaphore::new(max_requests)),
            opened: AtomicBool::new(false),
            counters: Counters::default(),
            cache: Mutex::new(FetchCache::default()),
            known: Mutex::default(),
            secrets,
        }))
    }

    /// The URL as messages show it (no user name, password or query).
    pub fn url(&self) -> &str {
        &self.shown
    }

    /// Marks the store open: operations may take [`READ_DEADLINE`] from now on, not
    /// [`OPEN_DEADLINE`].
    pub fn mark_opened(&self) {
        self.opened.store(true, Ordering::Relaxed);
        self.forget_failures();
    }

    /// The counters so far.
    pub fn stats(&self) -> RemoteStats {
        let c = &self.counters;
        RemoteStats {
            requests: c.requests.load(Ordering::Relaxed),
            in_flight: c.in_flight.load(Ordering::Relaxed),
            bytes: c.bytes.load(Ordering::Relaxed),
            errors: c.errors.load(Ordering::Relaxed),
        }
    }

    /// Fetches `keys` (whole objects: unsharded chunks) all at once, up to the request limit,
    /// into the fetch cache that [`ReadableStorageTraits::get`] reads first; missing objects
    /// are remembered as missing. Failures are left for `get` to meet (and report) again.
    pub fn prefetch(&self, keys: &[StoreKey]) {
        let wanted: Vec<&StoreKey> = match self.cache.lock() {
            Ok(cache) => keys
                .iter()
                .filter(|key| {
                    cache.get(key.as_str(), Piece::Whole).is_none()
                        && !cache.is_missing(key.as_str())
                })
                .collect(),
            Err(_) => return,
        };
        if wanted.len() < 2 {
            return;
        }
        let Ok(runtime) = runtime() else { return };
        let fetches = wanted
            .iter()
            .map(|key| async move { self.fetch(key, None).await.ok().flatten() });
        let deadline = self.deadline();
        // The fetches fill the cache themselves.
        let _ = runtime.block_on(async {
            tokio::time::timeout(deadline, futures::future::join_all(fetches)).await
        });
    }

    fn deadline(&self) -> Duration {
        if self.opened.load(Ordering::Relaxed) {
            READ_DEADLINE
        } else {
            OPEN_DEADLINE
        }
    }

    fn location(&self, key: &StoreKey) -> ObjectPath {
        if self.prefix.is_empty() {
            ObjectPath::from(key.as_str())
        } else {
            ObjectPath::from(format!("{}/{}", self.prefix, key.as_str()))
        }
    }

    /// The URL of `key` as messages show it.
    fn key_url(&self, key: &StoreKey) -> String {
        format!("{}/{}", self.shown, key.as_str())
    }

    /// Runs `operation` on the runtime within the deadline; the error names `key`'s URL.
    fn block_on<T>(
        &self,
        key: &StoreKey,
        operation: impl Future<Output = Result<T, object_store::Error>>,
    ) -> Result<T, StorageError> {
        let deadline = self.deadline();
        let result = runtime()
            .map_err(StorageError::Other)?
            .block_on(async { tokio::time::timeout(deadline, operation).await });
        match result {
            Ok(Ok(value)) => Ok(value),
            Ok(Err(error)) => {
                self.counters.errors.fetch_add(1, Ordering::Relaxed);
                Err(StorageError::Other(format!(
                    "{}: {}",
                    self.key_url(key),
                    self.describe(&error)
                )))
            }
            Err(_) => {
                self.counters.errors.fetch_add(1, Ordering::Relaxed);
                Err(StorageError::Other(format!(
                    "{}: no answer within {} s",
                    self.key_url(key),
                    deadline.as_secs()
                )))
            }
        }
    }

    /// One line for an error: the HTTP status's meaning where it is a refusal, else the
    /// client's message with every secret blanked out.
    fn describe(&self, error: &object_store::Error) -> String {
        match error {
            object_store::Error::PermissionDenied { .. } => "access denied (HTTP 403)".to_owned(),
            object_store::Error::Unauthenticated { .. } => {
                "not authenticated (HTTP 401)".to_owned()
            }
            other => one_line(other, &self.secrets),
        }
    }

    /// One request: the object at `key`, or the range of it; `None` if there is no object.
    async fn fetch(
        &self,
        key: &StoreKey,
        range: Option<GetRange>,
    ) -> Result<Option<Bytes>, object_store::Error> {
        let piece = Piece::of(range.as_ref());
        if let Ok(cache) = self.cache.lock() {
            if cache.is_missing(key.as_str()) {
                return Ok(None);
            }
            if let Some(bytes) = cache.get(key.as_str(), piece) {
                return Ok(Some(bytes));
            }
        }
        let location = self.location(key);
        let _permit = self
            .limit
            .acquire()
            .await
            .map_err(|e| generic(e.to_string()))?;
        self.counters.in_flight.fetch_add(1, Ordering::Relaxed);
        let result = self.fetch_unlimited(&location, range).await;
        self.counters.in_flight.fetch_sub(1, Ordering::Relaxed);
        self.counters.requests.fetch_add(1, Ordering::Relaxed);
        match result {
            Ok(bytes) => {
                self.counters
                    .bytes
                    .fetch_add(bytes.len() as u64, Ordering::Relaxed);
                if let Ok(mut cache) = self.cache.lock() {
                    cache.insert(key.as_str(), piece, &bytes);
                }
                Ok(Some(bytes))
            }
            Err(object_store::Error::NotFound { .. }) => {
                if let Ok(mut cache) = self.cache.lock() {
                    cache.insert_missing(key.as_str());
                }
                Ok(None)
            }
            Err(error) => Err(error),
        }
    }

    async fn fetch_unlimited(
        &self,
        location: &ObjectPath,
        range: Option<GetRange>,
    ) -> Result<Bytes, object_store::Error> {
        let options = GetOptions {
            range,
            ..GetOptions::default()
        };
        let result = self.store.get_opts(location, options).await?;
        let Range { start, end } = result.range;
        let length = end.saturating_sub(start);
        if length > MAX_OBJECT_BYTES {
            return Err(generic(format!(
                "the object is {length} bytes; more than {MAX_OBJECT_BYTES} are not read in one piece"
            )));
        }
        let bytes = result.bytes().await?;
        if bytes.len() as u64 != length {
            return Err(generic(format!(
                "{} bytes arrived of the {length} announced",
                bytes.len()
            )));
        }
        Ok(bytes)
    }
}

fn generic(message: String) -> object_store::Error {
    object_store::Error::Generic {
        store: "voxscope",
        source: message.into(),
    }
}

/// `error` on one line, with each of `secrets` replaced by `***`, at most 300 characters.
fn one_line(error: &dyn std::fmt::Display, secrets: &[String]) -> String {
    let mut text = error.to_string();
    for secret in secrets {
        text = text.replace(secret.as_str(), "***");
    }
    let text = printable(&text.split_whitespace().collect::<Vec<_>>().join(" "));
    match text.char_indices().nth(300) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text,
    }
}

fn to_get_range(range: ByteRange) -> GetRange {
    match range {
        ByteRange::FromStart(offset, Some(length)) => GetRange::Bounded(offset..offset + length),
        ByteRange::FromStart(offset, None) => GetRange::Offset(offset),
        ByteRange::Suffix(length) => GetRange::Suffix(length),
    }
}

impl ReadableStorageTraits for RemoteStore {
    fn get(&self, key: &StoreKey) -> Result<MaybeBytes, StorageError> {
        match self.known(key) {
            Some(Known::Missing) => return Ok(None),
            Some(Known::Failed(message)) => return Err(StorageError::Other(message)),
            Some(Known::TooLarge(_)) | None => {}
        }
        self.block_on(key, self.fetch(key, None))
    }

    fn get_partial_many<'a>(
        &'a self,
        key: &StoreKey,
        byte_ranges: ByteRangeIterator<'a>,
    ) -> Result<MaybeBytesIterator<'a>, StorageError> {
        let ranges: Vec<ByteRange> = byte_ranges.collect();
        if ranges.is_empty() {
            return Ok(Some(Box::new(std::iter::empty())));
        }
        // Every range in flight at once (up to the request limit); a missing object is
        // missing for all of them.
        let fetches = ranges
            .iter()
            .map(|range| self.fetch(key, Some(to_get_range(*range))));
        let parts = self.block_on(key, async {
            futures::future::join_all(fetches)
                .await
                .into_iter()
                .collect::<Result<Vec<Option<Bytes>>, _>>()
        })?;
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
        let location = self.location(key);
        let head = async {
            let _permit = self
                .limit
                .acquire()
                .await
                .map_err(|e| generic(e.to_string()))?;
            self.counters.requests.fetch_add(1, Ordering::Relaxed);
            match self.store.head(&location).await {
                Ok(meta) => Ok(Some(meta.size)),
                Err(object_store::Error::NotFound { .. }) => Ok(None),
                Err(error) => Err(error),
            }
        };
        self.block_on(key, head)
    }

    fn supports_get_partial(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

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
    fn shown_urls_carry_no_secrets() {
        assert_eq!(
            display_url("https://alice:hunter22@data.example.org/x.zarr/?token=abc#f"),
            "https://data.example.org/x.zarr"
        );
        assert_eq!(display_url("s3://bucket/path/"), "s3://bucket/path");
    }

    #[test]
    fn messages_blank_out_secrets() {
        let text = one_line(
            &"bad\nsignature for hunter22 at x",
            &["hunter22".to_owned()],
        );
        assert_eq!(text, "bad signature for *** at x");
    }

    #[test]
    fn credentials_come_from_the_environment_then_the_profile_else_none() {
        use object_store::aws::AmazonS3ConfigKey as Key;
        let home = tempfile::tempdir().expect("a temporary folder");
        let aws = home.path().join(".aws");
        std::fs::create_dir_all(&aws).expect("~/.aws");
        std::fs::write(
            aws.join("credentials"),
            "[default]\naws_access_key_id = AKIDEFAULT\naws_secret_access_key = defaultsecret\n\n\
             [lab]\naws_access_key_id=AKILAB\naws_secret_access_key=labsecret\n",
        )
        .expect("credentials");
        std::fs::write(
            aws.join("config"),
            "[profile lab]\nregion = eu-west-3\nendpoint_url = http://127.0.0.1:9000\n",
        )
        .expect("config");
        let found = |vars: &[(&str, &str)], home: Option<PathBuf>| {
            let vars: Vec<(String, String)> = vars
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            aws::Credentials::find_with(
                &move |name: &str| vars.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone()),
                home,
            )
        };
        let home_path = Some(home.path().to_path_buf());
        let lab = found(&[("AWS_PROFILE", "lab")], home_path.clone());
        assert!(!lab.anonymous());
        assert_eq!(lab.setting(Key::AccessKeyId), Some("AKILAB"));
        assert_eq!(lab.setting(Key::Region), Some("eu-west-3"));
        assert_eq!(lab.setting(Key::Endpoint), Some("http://127.0.0.1:9000"));
        assert_eq!(lab.secrets(), vec!["labsecret".to_owned()]);
        let default = found(&[], home_path.clone());
        assert_eq!(default.setting(Key::AccessKeyId), Some("AKIDEFAULT"));
        assert_eq!(default.setting(Key::Region), None);
        // The environment's keys win over the files'; its region and endpoint too.
        let env = found(
            &[
                ("AWS_ACCESS_KEY_ID", "AKIENV"),
                ("AWS_SECRET_ACCESS_KEY", "envsecret"),
                ("AWS_PROFILE", "lab"),
                ("AWS_REGION", "us-west-2"),
            ],
            home_path,
        );
        assert!(!env.anonymous());
        assert_eq!(env.setting(Key::AccessKeyId), None);
        assert_eq!(env.setting(Key::Region), None);
        assert_eq!(env.secrets(), vec!["envsecret".to_owned()]);
        // Nothing anywhere: anonymous.
        assert!(found(&[], None).anonymous());
        let shared = tempfile::NamedTempFile::new().expect("a file");
        let nowhere = found(
            &[(
                "AWS_SHARED_CREDENTIALS_FILE",
                shared.path().to_str().unwrap_or_default(),
            )],
            None,
        );
        assert!(nowhere.anonymous());
    }

    #[test]
    fn an_unknown_scheme_is_one_line() {
        let Err(problem) = RemoteStore::open("ftp://host/x.zarr", RemoteOptions::default()) else {
            panic!("ftp opened");
        };
        assert!(problem.contains("'ftp:'"), "{problem}");
    }
}
