//! One HTTP request for an object of a store at an `http://` or `https://` URL, over reqwest:
//! a whole object or a byte range, the body read piece by piece within a bound (so a body
//! without `Content-Length`, chunked or ended by closing the connection, is read, and none
//! is read past what the object may hold), the answer checked (a `206`'s `Content-Range`,
//! its length), and every failure put in words. Retries are the caller's
//! ([`super::RemoteStore`]).
//!
//! A server that ignores `Range` answers `200` with the whole object: a valid answer, handed
//! back as such for the caller to slice and keep. The URL's user name and password are sent
//! as HTTP basic authentication (over HTTPS, or over HTTP to this machine only); its query is
//! sent with every request (a token some servers read).

use std::time::Duration;

use reqwest::StatusCode;
use reqwest::header::{ACCEPT_ENCODING, CONTENT_RANGE, RETRY_AFTER};
use zarrs::storage::Bytes;

use super::cache::Piece;
use super::fault::{Failure, parse_retry_after, seconds};
use super::open_error::OpenError;
use super::url::StoreUrl;

/// What a request found.
#[derive(Clone)]
pub(crate) enum Answer {
    /// No such object (404, 410).
    Missing,
    /// The bytes asked for; `whole`: the whole object, though a piece was asked for (the
    /// server ignored `Range`).
    Body { bytes: Bytes, whole: bool },
}

/// An HTTP server's store.
pub(crate) struct HttpTransport {
    client: reqwest::Client,
    /// The store's root, without user name and password.
    base: url::Url,
    credentials: Option<(String, Option<String>)>,
}

impl HttpTransport {
    /// A client for `url` (checked: [`StoreUrl::parse`]) with the connect timeout `connect`
    /// and up to `max_requests` kept-alive connections.
    pub(crate) fn new(
        url: &StoreUrl,
        connect: Duration,
        max_requests: usize,
    ) -> Result<Self, OpenError> {
        let credentials = url.credentials();
        if credentials.is_some() && url.url.scheme() == "http" && !url.is_loopback() {
            return Err(OpenError::PasswordOverHttp);
        }
        let mut base = url.url.clone();
        let _ = base.set_username("");
        let _ = base.set_password(None);
        base.set_fragment(None);
        let client = reqwest::Client::builder()
            .connect_timeout(connect)
            .pool_max_idle_per_host(max_requests)
            .redirect(reqwest::redirect::Policy::limited(5))
            .build()
            .map_err(|e| OpenError::HttpClient(one_line(&e)))?;
        Ok(Self {
            client,
            base,
            credentials,
        })
    }

    /// The URL of `key`: the root's path and the key's segments, the root's query kept.
    fn object_url(&self, key: &str) -> Result<url::Url, Failure> {
        let mut url = self.base.clone();
        {
            let mut segments = url.path_segments_mut().map_err(|_| {
                Failure::permanent("the URL cannot have a path (it is no store's root)")
            })?;
            segments.pop_if_empty();
            segments.extend(key.split('/'));
        }
        Ok(url)
    }

    fn request(
        &self,
        method: reqwest::Method,
        key: &str,
    ) -> Result<reqwest::RequestBuilder, Failure> {
        let mut request = self
            .client
            .request(method, self.object_url(key)?)
            // The bytes as stored: a chunk's length is checked against what it must hold.
            .header(ACCEPT_ENCODING, "identity");
        if let Some((user, password)) = &self.credentials {
            request = request.basic_auth(user, password.as_ref());
        }
        Ok(request)
    }

    /// `piece` of the object `key`, reading at most `bound` bytes of body.
    pub(crate) async fn get(&self, key: &str, piece: Piece, bound: u64) -> Result<Answer, Failure> {
        let mut request = self.request(reqwest::Method::GET, key)?;
        if let Some(range) = piece.header() {
            request = request.header(reqwest::header::RANGE, range);
        }
        let mut response = request.send().await.map_err(|e| sending_failure(&e))?;
        let status = response.status();
        if let Some(failure) = status_failure(status, &response) {
            return failure;
        }
        let whole = status == StatusCode::OK;
        let expected = if whole {
            None
        } else if status == StatusCode::PARTIAL_CONTENT {
            Some(check_content_range(&response, piece)?)
        } else {
            return Err(Failure::permanent(format!(
                "HTTP {} answered a GET",
                describe_status(status)
            )));
        };
        let bytes = read_body(&mut response, bound).await?;
        if let Some(expected) = expected
            && bytes.len() as u64 != expected
        {
            return Err(Failure::transient(
                format!(
                    "{} bytes arrived of the {expected} the answer's Content-Range announced",
                    bytes.len()
                ),
                true,
            ));
        }
        Ok(Answer::Body {
            bytes,
            whole: whole && piece != Piece::Whole,
        })
    }

    /// The size of the object `key` by a `HEAD` request: `Ok(None)` if there is none,
    /// `Ok(Some(None))` if the server does not say (no `Content-Length`).
    pub(crate) async fn head(&self, key: &str) -> Result<Option<Option<u64>>, Failure> {
        let response = self
            .request(reqwest::Method::HEAD, key)?
            .send()
            .await
            .map_err(|e| sending_failure(&e))?;
        let status = response.status();
        if let Some(failure) = status_failure(status, &response) {
            return match failure {
                Ok(Answer::Missing) => Ok(None),
                Ok(Answer::Body { .. }) => unreachable!("a status failure has no body"),
                Err(failure) => Err(failure),
            };
        }
        let length = response
            .headers()
            .get(reqwest::header::CONTENT_LENGTH)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.trim().parse::<u64>().ok());
        Ok(Some(length))
    }
}

/// What a status other than 200 and 206 means: `Some(Ok(Missing))` for 404 and 410,
/// `Some(Err)` for every other failure, `None` to read the body.
fn status_failure(
    status: StatusCode,
    response: &reqwest::Response,
) -> Option<Result<Answer, Failure>> {
    if status == StatusCode::OK || status == StatusCode::PARTIAL_CONTENT {
        return None;
    }
    if status == StatusCode::NOT_FOUND || status == StatusCode::GONE {
        return Some(Ok(Answer::Missing));
    }
    let failure = match status {
        StatusCode::UNAUTHORIZED => Failure::permanent("not authenticated (HTTP 401)"),
        StatusCode::FORBIDDEN => Failure::denied(),
        StatusCode::REQUEST_TIMEOUT | StatusCode::TOO_MANY_REQUESTS => retried(status, response),
        s if s.is_server_error() => retried(status, response),
        s => Failure::permanent(format!("HTTP {}", describe_status(s))),
    };
    Some(Err(failure))
}

/// A 408, 429 or 5xx: retried, after what `Retry-After` asks where it says.
fn retried(status: StatusCode, response: &reqwest::Response) -> Failure {
    let retry_after = response
        .headers()
        .get(RETRY_AFTER)
        .and_then(|v| v.to_str().ok())
        .and_then(parse_retry_after);
    let mut failure = Failure::transient(format!("HTTP {}", describe_status(status)), true);
    if let Some(wait) = retry_after {
        failure.cause = format!("{} (Retry-After: {} s)", failure.cause, seconds(wait));
    }
    failure.retry_after = retry_after;
    failure
}

/// `500 Internal Server Error`.
fn describe_status(status: StatusCode) -> String {
    match status.canonical_reason() {
        Some(reason) => format!("{} {reason}", status.as_u16()),
        None => status.as_u16().to_string(),
    }
}

/// A `206`'s `Content-Range` (`bytes START-END/TOTAL`) must be the range asked for; the
/// length of that range.
fn check_content_range(response: &reqwest::Response, piece: Piece) -> Result<u64, Failure> {
    let wrong = |what: &str| {
        Failure::transient(
            format!("the server answered another range than asked for ({what})"),
            true,
        )
    };
    let header = response
        .headers()
        .get(CONTENT_RANGE)
        .and_then(|v| v.to_str().ok())
        .ok_or_else(|| wrong("no Content-Range"))?;
    let spec = header
        .trim()
        .strip_prefix("bytes ")
        .ok_or_else(|| wrong(header))?;
    let (span, total) = spec.split_once('/').ok_or_else(|| wrong(header))?;
    let (start, end) = span.split_once('-').ok_or_else(|| wrong(header))?;
    let (Ok(start), Ok(end)) = (start.trim().parse::<u64>(), end.trim().parse::<u64>()) else {
        return Err(wrong(header));
    };
    let total = total.trim().parse::<u64>().ok();
    if end < start {
        return Err(wrong(header));
    }
    let fits = match piece {
        Piece::Whole => start == 0,
        Piece::Range(a, b) => {
            start == a && (end + 1 == b || total.is_some_and(|t| end + 1 == t && t < b))
        }
        Piece::From(a) => start == a && total.is_none_or(|t| end + 1 == t),
        Piece::Suffix(n) => total.is_none_or(|t| end + 1 == t && start == t.saturating_sub(n)),
    };
    if !fits {
        return Err(wrong(header));
    }
    Ok(end - start + 1)
}

/// The body, piece by piece, refusing more than `bound` bytes (whether or not a
/// `Content-Length` announced them).
async fn read_body(response: &mut reqwest::Response, bound: u64) -> Result<Bytes, Failure> {
    let announced = response.content_length();
    if let Some(length) = announced
        && length > bound
    {
        return Err(Failure::too_large(length, bound, true));
    }
    let mut body = Vec::with_capacity(announced.unwrap_or(0).min(bound).min(64 << 20) as usize);
    loop {
        match response.chunk().await {
            Ok(Some(piece)) => {
                if body.len() as u64 + piece.len() as u64 > bound {
                    return Err(Failure::too_large(
                        body.len() as u64 + piece.len() as u64,
                        bound,
                        false,
                    ));
                }
                body.extend_from_slice(&piece);
            }
            Ok(None) => break,
            Err(error) => {
                let of = announced.map_or(String::new(), |n| format!(" of {n}"));
                return Err(Failure::transient(
                    format!(
                        "the body broke off after {}{of} bytes: {}",
                        body.len(),
                        describe_error(&error)
                    ),
                    true,
                ));
            }
        }
    }
    if let Some(length) = announced
        && body.len() as u64 != length
    {
        return Err(Failure::transient(
            format!("{} bytes arrived of the {length} announced", body.len()),
            true,
        ));
    }
    Ok(Bytes::from(body))
}

/// A request that got no answer: refused, the host unknown, a reset, a TLS failure.
fn sending_failure(error: &reqwest::Error) -> Failure {
    Failure::transient(describe_error(error), false)
}

/// The words for a client error: the cause first (`connection refused`, `host not found`),
/// then the client's own message.
fn describe_error(error: &reqwest::Error) -> String {
    let mut source: Option<&(dyn std::error::Error + 'static)> = Some(error);
    let mut chain = Vec::new();
    let mut kind = None;
    while let Some(current) = source {
        if let Some(io) = current.downcast_ref::<std::io::Error>() {
            kind = kind.or(match io.kind() {
                std::io::ErrorKind::ConnectionRefused => Some("connection refused"),
                std::io::ErrorKind::ConnectionReset => Some("connection reset"),
                std::io::ErrorKind::ConnectionAborted => Some("connection aborted"),
                std::io::ErrorKind::TimedOut => Some("timed out"),
                std::io::ErrorKind::UnexpectedEof => Some("the connection closed early"),
                _ => None,
            });
        }
        let text = current.to_string();
        if text.contains("dns error") || text.contains("failed to lookup address") {
            kind = kind.or(Some("host not found (DNS)"));
        }
        chain.push(text);
        source = current.source();
    }
    if kind.is_none() && error.is_connect() {
        kind = Some("cannot connect");
    }
    // The innermost message is usually the most precise; the URL is never part of it
    // (reqwest's own message names the URL; it is left out).
    let detail = chain.last().map(String::as_str).unwrap_or_default();
    let detail = one_line_str(detail);
    match kind {
        Some(kind) if !detail.is_empty() && !detail.eq_ignore_ascii_case(kind) => {
            format!("{kind} ({detail})")
        }
        Some(kind) => kind.to_owned(),
        None => detail,
    }
}

fn one_line(error: &dyn std::fmt::Display) -> String {
    one_line_str(&error.to_string())
}

fn one_line_str(text: &str) -> String {
    let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
    super::url::redact_text(&text, &[])
}

impl Piece {
    /// The `Range` header asking for this piece (`None` for the whole object).
    fn header(self) -> Option<String> {
        match self {
            Piece::Whole => None,
            Piece::Range(a, b) => Some(format!("bytes={a}-{}", b.saturating_sub(1))),
            Piece::From(a) => Some(format!("bytes={a}-")),
            Piece::Suffix(n) => Some(format!("bytes=-{n}")),
        }
    }
}
