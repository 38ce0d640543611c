//! Why a store could not be opened before any request was made to it.

use super::url::UrlError;

/// Why [`super::RemoteStore::open`] refused a store: displays as the rest of a line that
/// starts with the URL as shown, without its secrets.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OpenError {
    /// The URL itself is refused.
    #[error(transparent)]
    Url(#[from] UrlError),
    /// A user name and password over plain HTTP to another machine.
    #[error(
        "carries a user name and password, which voxscope sends only over https:// (or http:// to this machine)"
    )]
    PasswordOverHttp,
    /// The HTTP client could not be made (its error, on one line).
    #[error("cannot start an HTTP client: {0}")]
    HttpClient(String),
    /// The S3 endpoint the environment or AWS files give (`given_by` names which) is refused.
    #[error("its S3 endpoint ({given_by}) {error}")]
    S3Endpoint {
        given_by: String,
        #[source]
        error: UrlError,
    },
    /// The S3 client could not be made (its error, on one line, secrets redacted).
    #[error("cannot read from S3: {0}")]
    S3Client(String),
}
