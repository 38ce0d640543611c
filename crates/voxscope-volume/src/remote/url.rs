//! What a user types as a store's URL, parsed and checked by voxscope before any library sees
//! it, and the one redaction that every URL passes through before it reaches a message, a log,
//! the recent-files list, settings or a view file.
//!
//! Parsing is strict where a dependency would otherwise be handed something it cannot turn
//! into a request (object_store panics on a host the `http` crate rejects, such as `{bad}`):
//! the host must be a DNS name, an IPv4 address or a bracketed IPv6 address; no control
//! characters anywhere; an S3 bucket must be a valid bucket name.

use std::net::IpAddr;

use super::super::error::escape;

/// Why a store's URL (or an S3 endpoint) was refused before any request: displays as the
/// rest of a line that starts with the URL as shown (`URL is not a valid URL: …`), without
/// its secrets.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum UrlError {
    /// A control character (escaped) somewhere in it.
    #[error("is not a valid URL: it holds the control character {0}")]
    ControlCharacter(String),
    /// A scheme (escaped, at most 20 characters) that is not `http`, `https` or `s3`.
    #[error("has the scheme '{0}:'; remote stores are http://, https:// or s3://")]
    UnknownScheme(String),
    /// What the URL parser refused.
    #[error("is not a valid URL: {0}")]
    Unparsed(url::ParseError),
    /// An HTTP URL without a host.
    #[error("is not a valid URL: it names no host")]
    NoHost,
    /// A bracketed host (escaped) that is no IPv6 address.
    #[error("is not a valid URL: the host '{0}' is no IPv6 address")]
    NotIpv6(String),
    /// A host (escaped, at most 80 characters) that is no DNS name or address.
    #[error("is not a valid URL: the host '{0}' is no host name or address")]
    NotHostName(String),
    /// An `s3://` URL without a bucket.
    #[error("names no bucket (s3://BUCKET/PATH)")]
    NoBucket,
    /// A bucket (escaped, at most 80 characters) that is no bucket name.
    #[error("is not a valid URL: '{0}' is no S3 bucket name (letters, digits, '.', '-', '_')")]
    NotBucket(String),
    /// An endpoint with whitespace or a control character inside (`a space`, `the character
    /// \u{d}`).
    #[error("is not a valid URL: it holds {0} inside")]
    Inside(String),
    /// An endpoint (redacted, at most 80 characters) that is not `http(s)://`.
    #[error("is not an http:// or https:// URL ('{0}'): {ENDPOINT_FORM}")]
    EndpointNotHttp(String),
    /// An endpoint with a query.
    #[error("has a query ('?…'): {ENDPOINT_FORM}")]
    EndpointQuery,
    /// An endpoint with a fragment.
    #[error("has a fragment ('#…'): {ENDPOINT_FORM}")]
    EndpointFragment,
}

/// What an S3 endpoint looks like, as a refused one's message says.
const ENDPOINT_FORM: &str = "an endpoint is http(s)://HOST[:PORT][/PATH]";

/// The schemes voxscope reads stores from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scheme {
    /// `http://` or `https://`.
    Http,
    /// `s3://BUCKET/PATH`.
    S3,
}

/// A store's URL, checked: what the transports are built from.
#[derive(Debug, Clone)]
pub(crate) struct StoreUrl {
    pub(crate) scheme: Scheme,
    /// The parsed URL, user name and password included (they are sent, never shown).
    pub(crate) url: url::Url,
    /// The URL as every message shows it ([`redact_url`]).
    pub(crate) shown: String,
}

impl StoreUrl {
    /// Parses `text` as a store's URL, or says in one line (without its secrets) why it is
    /// not one.
    pub(crate) fn parse(text: &str) -> Result<Self, UrlError> {
        let resolved = resolve_url(text.trim());
        let text = resolved.as_str();
        if let Some(c) = text.chars().find(|c| c.is_control()) {
            return Err(UrlError::ControlCharacter(escape(&c.to_string())));
        }
        let scheme = scheme_of(text).ok_or_else(|| {
            let name = text.split(':').next().unwrap_or_default();
            UrlError::UnknownScheme(escape(&name.chars().take(20).collect::<String>()))
        })?;
        let url = url::Url::parse(text).map_err(UrlError::Unparsed)?;
        let host = url.host_str().unwrap_or_default();
        match scheme {
            Scheme::Http => check_host(host)?,
            Scheme::S3 => check_bucket(host)?,
        }
        Ok(Self {
            scheme,
            shown: redact_url(text),
            url,
        })
    }

    /// The user name and password the URL carries, if any (`user:password@`).
    pub(crate) fn credentials(&self) -> Option<(String, Option<String>)> {
        let user = percent_decode(self.url.username());
        let password = self.url.password().map(percent_decode);
        (!user.is_empty() || password.is_some()).then_some((user, password))
    }

    /// Whether the host is this machine (`localhost`, 127.0.0.0/8, `::1`): plain HTTP there
    /// never leaves it, so a password may be sent over it.
    pub(crate) fn is_loopback(&self) -> bool {
        match self.url.host() {
            Some(url::Host::Domain(name)) => name.eq_ignore_ascii_case("localhost"),
            Some(url::Host::Ipv4(ip)) => ip.is_loopback(),
            Some(url::Host::Ipv6(ip)) => ip.is_loopback(),
            None => false,
        }
    }
}

/// An S3 endpoint (`AWS_ENDPOINT_URL` or the like) as object_store is to be given it, and
/// parsed: `http(s)://HOST[:PORT][/PATH]`, whitespace around it trimmed (an env file's CR
/// among it); whitespace inside it, a query or a fragment refused (object_store pastes the
/// endpoint into every request's URL as it is: the `http` crate rejects a space, and a query
/// would end up inside each request's path). What is handed over is the URL as parsed
/// (percent-encoded where it needs to be), with no `/` added.
pub(crate) fn parse_endpoint(text: &str) -> Result<(String, StoreUrl), UrlError> {
    let text = text.trim();
    if let Some(c) = text.chars().find(|c| c.is_whitespace() || c.is_control()) {
        return Err(UrlError::Inside(match c {
            ' ' => "a space".to_owned(),
            c => format!("the character {}", escape(&c.escape_unicode().to_string())),
        }));
    }
    if scheme_of(text) != Some(Scheme::Http) {
        let shown: String = redact_url(text).chars().take(80).collect();
        return Err(UrlError::EndpointNotHttp(shown));
    }
    let url = StoreUrl::parse(text)?;
    if url.url.query().is_some() {
        return Err(UrlError::EndpointQuery);
    }
    if url.url.fragment().is_some() {
        return Err(UrlError::EndpointFragment);
    }
    let parsed = url.url.as_str();
    // The parser writes `http://host` as `http://host/`; object_store takes a path's own `/`.
    let endpoint = if parsed.ends_with('/') && !text.ends_with('/') {
        &parsed[..parsed.len() - 1]
    } else {
        parsed
    };
    Ok((endpoint.to_owned(), url))
}

/// neuroglancer's data source prefixes (`precomputed://`, `n5://`, `zarr://`, `zarr2://`,
/// `zarr3://`, as its URLs and state links carry them) taken off, and Google Cloud Storage's
/// `gs://BUCKET/PATH` as the bucket's public HTTPS endpoint
/// (`https://storage.googleapis.com/BUCKET/PATH`, what neuroglancer reads a public bucket
/// through): the URL voxscope reads. Anything else is returned as it is.
pub fn resolve_url(spec: &str) -> String {
    let mut text = spec.trim();
    for prefix in ["precomputed://", "n5://", "zarr://", "zarr2://", "zarr3://"] {
        // `get`: a name of non-ASCII characters has no byte boundary at the prefix's length.
        if text.len() > prefix.len()
            && text
                .get(..prefix.len())
                .is_some_and(|start| start.eq_ignore_ascii_case(prefix))
        {
            text = &text[prefix.len()..];
            break;
        }
    }
    match (text.get(..5), text.get(5..)) {
        (Some(scheme), Some(rest)) if scheme.eq_ignore_ascii_case("gs://") => {
            format!("https://storage.googleapis.com/{rest}")
        }
        _ => text.to_owned(),
    }
}

/// The scheme `spec` starts with, if voxscope reads stores from it.
pub(crate) fn scheme_of(spec: &str) -> Option<Scheme> {
    let lower = resolve_url(spec).to_ascii_lowercase();
    if lower.starts_with("http://") || lower.starts_with("https://") {
        Some(Scheme::Http)
    } else if lower.starts_with("s3://") {
        Some(Scheme::S3)
    } else {
        None
    }
}

/// A host a request can be made to: a DNS name (letters, digits, `-`, `.`, `_`), an IPv4
/// address or a bracketed IPv6 address.
fn check_host(host: &str) -> Result<(), UrlError> {
    if host.is_empty() {
        return Err(UrlError::NoHost);
    }
    if let Some(inner) = host.strip_prefix('[').and_then(|h| h.strip_suffix(']')) {
        return inner
            .parse::<IpAddr>()
            .map(|_| ())
            .map_err(|_| UrlError::NotIpv6(escape(host)));
    }
    let valid = host.len() <= 253
        && host.split('.').all(|label| {
            !label.is_empty()
                && label.len() <= 63
                && label
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        });
    if valid {
        Ok(())
    } else {
        Err(UrlError::NotHostName(escape(
            &host.chars().take(80).collect::<String>(),
        )))
    }
}

/// An S3 bucket name: 1 to 255 of letters, digits, `.`, `-` and `_` (S3's own rules are
/// stricter; other S3-compatible stores accept these).
fn check_bucket(bucket: &str) -> Result<(), UrlError> {
    if bucket.is_empty() {
        return Err(UrlError::NoBucket);
    }
    let valid = bucket.len() <= 255
        && bucket
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_'));
    if valid {
        Ok(())
    } else {
        Err(UrlError::NotBucket(escape(
            &bucket.chars().take(80).collect::<String>(),
        )))
    }
}

fn percent_decode(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `url` as anything voxscope shows or stores may hold it: without user name, password,
/// query and fragment, the path kept (`https://alice:pw@host/x.zarr/?sig=…` is
/// `https://host/x.zarr`). The one function every URL passes through before it reaches a
/// message, a log, the recent-files list, settings or a view file. Text that does not parse
/// as a URL loses everything from the scheme's `//` to the last `@` before the path, and
/// everything from the first `?` or `#`.
pub fn redact_url(url: &str) -> String {
    let url = url.trim();
    if let Ok(mut parsed) = url::Url::parse(url)
        && parsed.has_host()
    {
        // Setting these cannot fail on URLs with a host.
        let _ = parsed.set_username("");
        let _ = parsed.set_password(None);
        parsed.set_query(None);
        parsed.set_fragment(None);
        return escape(parsed.as_str().trim_end_matches('/'));
    }
    let without_query = url.split(['?', '#']).next().unwrap_or_default();
    let redacted = match without_query.split_once("://") {
        Some((scheme, rest)) => {
            let authority_end = rest.find('/').unwrap_or(rest.len());
            let (authority, path) = rest.split_at(authority_end);
            let host = authority.rsplit_once('@').map_or(authority, |(_, h)| h);
            format!("{scheme}://{host}{path}")
        }
        None => without_query.to_owned(),
    };
    escape(redacted.trim_end_matches('/'))
}

/// `text` with every URL in it ([`redact_url`]) and every one of `secrets` (blanked to `***`)
/// removed: what becomes of a library's message before voxscope shows it.
pub(crate) fn redact_text(text: &str, secrets: &[String]) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find("://") {
        // The scheme: the letters before `://`.
        let scheme_start = rest[..at]
            .rfind(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.')))
            .map_or(0, |i| i + 1);
        let end = rest[at + 3..]
            .find(|c: char| c.is_whitespace() || matches!(c, '"' | '\'' | '<' | '>' | ')' | '`'))
            .map_or(rest.len(), |i| at + 3 + i);
        out.push_str(&rest[..scheme_start]);
        if scheme_start == at {
            // No scheme: `://` inside other text.
            out.push_str("://");
            rest = &rest[at + 3..];
            continue;
        }
        out.push_str(&redact_url(&rest[scheme_start..end]));
        rest = &rest[end..];
    }
    out.push_str(rest);
    for secret in secrets.iter().filter(|s| s.len() >= 3) {
        out = out.replace(secret.as_str(), "***");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neuroglancer_prefixes_and_gs_urls_resolve_to_what_is_read() {
        assert_eq!(
            resolve_url("precomputed://gs://bucket/em/raw"),
            "https://storage.googleapis.com/bucket/em/raw"
        );
        assert_eq!(resolve_url(" n5://s3://b/c.n5"), "s3://b/c.n5");
        assert_eq!(resolve_url("zarr://https://h/x.zarr"), "https://h/x.zarr");
        assert_eq!(resolve_url("https://h/x.zarr"), "https://h/x.zarr");
        assert_eq!(resolve_url("precomputed://"), "precomputed://");
        assert_eq!(scheme_of("precomputed://gs://b/v"), Some(Scheme::Http));
        assert_eq!(scheme_of("gs://b/v"), Some(Scheme::Http));
        assert_eq!(scheme_of("precomputed://relative/path"), None);
        // Paths of non-ASCII names are no URLs, whatever byte a prefix's length falls on.
        for path in ["Imagé.nii", "脑图像数据.nii", "zarr:/é", "gs:/é"] {
            assert_eq!(resolve_url(path), path);
            assert_eq!(scheme_of(path), None);
        }
    }

    #[test]
    fn redaction_keeps_the_path_and_drops_user_password_query_and_fragment() {
        assert_eq!(
            redact_url("https://alice:hunter22@data.example.org/x.zarr/?token=abc#f"),
            "https://data.example.org/x.zarr"
        );
        assert_eq!(redact_url("s3://bucket/path/"), "s3://bucket/path");
        assert_eq!(
            redact_url("http://u:p@{bad}/z.ome.zarr?t=SECRET"),
            "http://{bad}/z.ome.zarr"
        );
        assert_eq!(redact_url("http://u:p@@x/y?z"), "http://x/y");
        assert_eq!(
            redact_text(
                "Error performing GET http://x:9/z/zarr.json?t=SECRETTOK in 2 s, key hunter22",
                &["hunter22".to_owned()]
            ),
            "Error performing GET http://x:9/z/zarr.json in 2 s, key ***"
        );
        assert_eq!(
            redact_text("see <https://a:b@h/p?q=1>", &[]),
            "see <https://h/p>"
        );
    }

    #[test]
    fn an_endpoint_is_trimmed_and_one_with_whitespace_a_query_or_another_scheme_refused() {
        for (given, handed) in [
            ("http://127.0.0.1:9000 ", "http://127.0.0.1:9000"),
            ("\t https://s3.example.org/\r\n", "https://s3.example.org/"),
            ("http://minio:9000/prefix\r", "http://minio:9000/prefix"),
        ] {
            let (endpoint, url) =
                parse_endpoint(given).unwrap_or_else(|e| panic!("{given:?}: {e}"));
            assert_eq!(endpoint, handed);
            assert_eq!(url.scheme, Scheme::Http);
        }
        for (bad, wanted) in [
            ("http://127.0.0.1:9000/?x=1", "has a query"),
            ("http://127.0.0.1:9000/#f", "has a fragment"),
            ("http://127.0.0.1 :9000", "holds a space inside"),
            ("http://h/a\r\nb", "holds the character"),
            (
                "s3://bucket",
                "is not an http:// or https:// URL ('s3://bucket')",
            ),
            ("minio:9000", "is not an http:// or https:// URL"),
            ("http://", "is not a valid URL"),
            ("http://{bad}", "is no host name"),
        ] {
            let error = parse_endpoint(bad).expect_err(bad);
            assert!(error.to_string().contains(wanted), "{bad:?}: {error}");
        }
    }

    #[test]
    fn urls_that_no_request_can_be_made_to_are_refused_in_one_line() {
        for (bad, wanted) in [
            ("http://u:p@{bad}/z.ome.zarr", "is no host name"),
            ("http://:8/z.ome.zarr", "is not a valid URL"),
            ("http://h\u{7}x/z", "control character"),
            ("s3://Bad Bucket/x", "is not a valid URL"),
            ("s3://b{x}/x", "no S3 bucket name"),
            ("ftp://host/x", "'ftp:'"),
            ("http://[zz]/x", "is not a valid URL"),
        ] {
            let error = StoreUrl::parse(bad).expect_err(bad).to_string();
            assert!(error.contains(wanted), "{bad}: {error}");
            assert!(!error.contains("u:p"), "{error}");
        }
        let url = StoreUrl::parse("http://alice:pa%40ss@127.0.0.1:8/x.zarr?t=1").unwrap();
        assert_eq!(
            url.credentials(),
            Some(("alice".to_owned(), Some("pa@ss".to_owned())))
        );
        assert!(url.is_loopback());
        assert_eq!(url.shown, "http://127.0.0.1:8/x.zarr");
        assert!(
            !StoreUrl::parse("https://example.org/x")
                .unwrap()
                .is_loopback()
        );
        assert!(StoreUrl::parse("http://[::1]:80/x").unwrap().is_loopback());
    }
}
