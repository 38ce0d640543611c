//! One request for an object of an `s3://BUCKET/PATH` store, through object_store's S3 client
//! (it signs requests; its own retries are off: [`super::RemoteStore`] retries, with the same
//! deadlines and backoff as for HTTP). Its errors are put in words without the endpoint's URL
//! or any secret; a missing bucket is told from a missing object.

use std::sync::Arc;
use std::time::Duration;

use object_store::aws::{AmazonS3Builder, AmazonS3ConfigKey};
use object_store::path::Path as ObjectPath;
use object_store::{
    BackoffConfig, ClientOptions, GetOptions, GetRange, ObjectStore, ObjectStoreExt, RetryConfig,
};
use zarrs::storage::Bytes;

use super::aws;
use super::cache::Piece;
use super::fault::Failure;
use super::http::Answer;
use super::open_error::OpenError;
use super::url::{StoreUrl, parse_endpoint, redact_text};

/// An S3 bucket's store under a prefix.
pub(crate) struct S3Transport {
    store: Arc<dyn ObjectStore>,
    bucket: String,
    /// The object path of the Zarr root inside the bucket.
    prefix: String,
    /// Strings never shown (the secret key, the session token, the endpoint's password).
    secrets: Vec<String>,
}

impl S3Transport {
    /// A client for `url` with credentials, region and endpoint from the environment and the
    /// AWS files ([`aws::Credentials`]), the connect timeout `connect` and the request timeout
    /// `request`.
    pub(crate) fn new(
        url: &StoreUrl,
        connect: Duration,
        request: Duration,
        max_requests: usize,
    ) -> Result<Self, OpenError> {
        let bucket = url.url.host_str().unwrap_or_default().to_owned();
        let prefix = url.url.path().trim_matches('/').to_owned();
        let credentials = aws::Credentials::find();
        let mut secrets = credentials.secrets();
        let mut builder =
            credentials.apply(builder_from_env().with_bucket_name(&bucket).with_retry(
                RetryConfig {
                    backoff: BackoffConfig::default(),
                    max_retries: 0,
                    retry_timeout: request,
                },
            ));
        let mut http_endpoint = false;
        if let Some(given) = credentials.endpoint() {
            // object_store pastes the endpoint into each request's URL as it is: it panics on
            // one the `http` crate rejects (a space, a CR from an env file) and puts a query
            // into the path. It is trimmed and checked here, and handed over as parsed.
            let (endpoint, checked) =
                parse_endpoint(&given.value).map_err(|error| OpenError::S3Endpoint {
                    given_by: given.source.clone(),
                    error,
                })?;
            if let Some((user, password)) = checked.credentials() {
                secrets.push(user);
                secrets.extend(password);
            }
            http_endpoint = checked.url.scheme() == "http";
            builder = builder
                .with_config(AmazonS3ConfigKey::Endpoint, &endpoint)
                .with_config(AmazonS3ConfigKey::S3Endpoint, endpoint);
        }
        let client = ClientOptions::new()
            .with_connect_timeout(connect)
            .with_timeout(request)
            .with_pool_max_idle_per_host(max_requests)
            .with_allow_http(http_endpoint);
        let store = builder
            .with_client_options(client)
            .build()
            .map_err(|e| OpenError::S3Client(redact_text(&one_line(&e), &secrets)))?;
        secrets.retain(|s| s.len() >= 3);
        Ok(Self {
            store: Arc::new(store),
            bucket,
            prefix,
            secrets,
        })
    }

    /// Strings no message may show.
    pub(crate) fn secrets(&self) -> &[String] {
        &self.secrets
    }

    fn location(&self, key: &str) -> ObjectPath {
        if self.prefix.is_empty() {
            ObjectPath::from(key)
        } else {
            ObjectPath::from(format!("{}/{key}", self.prefix))
        }
    }

    /// `piece` of the object `key`, at most `bound` bytes.
    pub(crate) async fn get(&self, key: &str, piece: Piece, bound: u64) -> Result<Answer, Failure> {
        let range = match piece {
            Piece::Whole => None,
            Piece::Range(a, b) => Some(GetRange::Bounded(a..b)),
            Piece::From(a) => Some(GetRange::Offset(a)),
            Piece::Suffix(n) => Some(GetRange::Suffix(n)),
        };
        let options = GetOptions {
            range,
            ..GetOptions::default()
        };
        let result = match self.store.get_opts(&self.location(key), options).await {
            Ok(result) => result,
            Err(error) => return self.failure(error).map(|()| Answer::Missing),
        };
        let length = result.range.end.saturating_sub(result.range.start);
        if length > bound {
            return Err(Failure::too_large(length, bound, true));
        }
        let bytes: Bytes = match result.bytes().await {
            Ok(bytes) => bytes,
            Err(error) => {
                return Err(self.failure(error).err().unwrap_or_else(|| {
                    Failure::transient("the object vanished while it was read", true)
                }));
            }
        };
        if bytes.len() as u64 != length {
            return Err(Failure::transient(
                format!("{} bytes arrived of the {length} announced", bytes.len()),
                true,
            ));
        }
        Ok(Answer::Body {
            bytes,
            whole: false,
        })
    }

    /// The size of the object `key`, `None` if there is none.
    pub(crate) async fn head(&self, key: &str) -> Result<Option<Option<u64>>, Failure> {
        match self.store.head(&self.location(key)).await {
            Ok(meta) => Ok(Some(Some(meta.size))),
            Err(error) => self.failure(error).map(|()| None),
        }
    }

    /// `Ok(())` for a missing object; else the failure in words.
    fn failure(&self, error: object_store::Error) -> Result<(), Failure> {
        let full = error.to_string();
        let text = match full.split_once("non-2xx status code: ") {
            // "… - Server returned non-2xx status code: 500 Internal Server Error: <body>"
            Some((_, status)) => format!(
                "HTTP {}",
                status.split(':').next().unwrap_or_default().trim()
            ),
            None => redact_text(&one_line(&error), &self.secrets),
        };
        match error {
            // S3's error code for a bucket that is not there (the answer's XML body).
            object_store::Error::NotFound { .. } if full.contains("<Code>NoSuchBucket</Code>") => {
                Err(Failure::permanent(format!(
                    "the bucket '{}' does not exist",
                    self.bucket
                )))
            }
            object_store::Error::NotFound { .. } => Ok(()),
            object_store::Error::PermissionDenied { .. } => Err(Failure::denied()),
            object_store::Error::Unauthenticated { .. } => {
                Err(Failure::permanent("not authenticated (HTTP 401)"))
            }
            object_store::Error::NotSupported { .. }
            | object_store::Error::InvalidPath { .. }
            | object_store::Error::NotImplemented { .. } => Err(Failure::permanent(text)),
            _ => Err(Failure::transient(text, false)),
        }
    }
}

/// object_store's [`AmazonS3Builder::from_env`] but for the endpoint, which voxscope reads
/// ([`aws::Credentials::endpoint`]) and checks itself: every `AWS_*` variable that names a
/// setting.
fn builder_from_env() -> AmazonS3Builder {
    let mut builder = AmazonS3Builder::new();
    for (name, value) in std::env::vars_os() {
        let (Some(name), Some(value)) = (name.to_str(), value.to_str()) else {
            continue;
        };
        if !name.starts_with("AWS_") {
            continue;
        }
        match name.to_ascii_lowercase().parse::<AmazonS3ConfigKey>() {
            Ok(AmazonS3ConfigKey::Endpoint | AmazonS3ConfigKey::S3Endpoint) | Err(_) => {}
            Ok(key) => builder = builder.with_config(key, value),
        }
    }
    builder
}

/// `error` on one line, at most 300 characters.
fn one_line(error: &dyn std::fmt::Display) -> String {
    let text = error
        .to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    match text.char_indices().nth(300) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text,
    }
}
