//! How a request fails and what is done about it: the [`Failure`] of one attempt or operation
//! (its cause in words, whether another try may succeed, how long the server asks to wait),
//! the time bounds ([`Timing`]), the backoff between tries, `Retry-After`, and the store's
//! view of its server's health (a server that stopped answering is not asked again and again,
//! each time waiting out a timeout).

use std::sync::Mutex;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// The time bounds of a remote store. [`Timing::default`] is what voxscope uses (and the
/// documentation states); tests shorten them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// Establishing a connection (TCP and TLS).
    pub connect: Duration,
    /// One request: connecting, the headers and the whole body.
    pub request: Duration,
    /// One operation (an object and its retries) while the store is being opened.
    pub open_deadline: Duration,
    /// One operation once the store is open.
    pub read_deadline: Duration,
    /// Retries of one operation at most.
    pub max_retries: u32,
    /// The first backoff; it doubles each retry up to [`Self::max_backoff`].
    pub first_backoff: Duration,
    /// The longest backoff.
    pub max_backoff: Duration,
    /// The longest wait a `Retry-After` may ask for (longer ones fail the operation).
    pub max_retry_after: Duration,
    /// How long an object that failed after its retries answers with that failure without a
    /// request (doubling each time it fails again, up to [`Self::max_remembered`]).
    pub remember_failure: Duration,
    /// The longest an object's failure is remembered (a permanent one: for the store's life).
    pub max_remembered: Duration,
    /// How long a server that let a request time out without answering anything is given
    /// before it is asked again (every request meanwhile fails at once).
    pub silence_cool_down: Duration,
}

impl Default for Timing {
    fn default() -> Self {
        Self {
            connect: Duration::from_secs(5),
            request: Duration::from_secs(20),
            open_deadline: Duration::from_secs(10),
            read_deadline: Duration::from_secs(30),
            max_retries: 8,
            first_backoff: Duration::from_millis(50),
            max_backoff: Duration::from_secs(2),
            max_retry_after: Duration::from_secs(20),
            remember_failure: Duration::from_secs(2),
            max_remembered: Duration::from_secs(60),
            silence_cool_down: Duration::from_secs(5),
        }
    }
}

impl Timing {
    /// The wait before retry `tries` (1 for the first retry): doubling from
    /// [`Self::first_backoff`], at most [`Self::max_backoff`].
    pub(crate) fn backoff(&self, tries: u32) -> Duration {
        self.first_backoff
            .saturating_mul(1 << tries.saturating_sub(1).min(20))
            .min(self.max_backoff)
    }
}

/// Whether another try may succeed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Persistence {
    /// A 5xx, 429, a timeout, a reset, a cut body: retried.
    Transient,
    /// 401, 403, 4xx, a body larger than the object may be, a store that cannot be read this
    /// way: asking again gets the same.
    Permanent,
    /// The server has not answered anything for a while: this operation ends now (other
    /// operations fail at once until the cool-down is over).
    Silent,
}

/// [`Failure::denied`]'s cause.
const DENIED: &str = "access denied (HTTP 403)";

/// One failure: the cause in words (no URL: callers name the object), and what it means.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Failure {
    /// The cause alone (`HTTP 500 Internal Server Error`): the same for every object that
    /// failed the same way.
    pub(crate) cause: String,
    /// Tries made before it was given up (1: no retry).
    pub(crate) tries: u32,
    pub(crate) persistence: Persistence,
    /// What the server's `Retry-After` asked for.
    pub(crate) retry_after: Option<Duration>,
    /// Whether the server answered at all (a status, part of a body): it is alive.
    pub(crate) answered: bool,
    /// The object is larger than it may be: this many bytes, as its length announced.
    pub(crate) too_large: Option<u64>,
}

impl Failure {
    /// A failure another try may not have.
    pub(crate) fn transient(cause: impl Into<String>, answered: bool) -> Self {
        Self {
            cause: cause.into(),
            tries: 1,
            persistence: Persistence::Transient,
            retry_after: None,
            answered,
            too_large: None,
        }
    }

    /// A failure every try has.
    pub(crate) fn permanent(cause: impl Into<String>) -> Self {
        Self {
            persistence: Persistence::Permanent,
            ..Self::transient(cause, true)
        }
    }

    /// The server denies the object (HTTP 403): where it lets nobody list the store (an S3
    /// bucket without `s3:ListBucket`), what an object that does not exist gets too.
    pub(crate) fn denied() -> Self {
        Self::permanent(DENIED)
    }

    /// Whether this is [`Self::denied`]'s failure.
    pub(crate) fn is_denied(&self) -> bool {
        self.cause == DENIED
    }

    /// An object of at least `size` bytes where at most `bound` may be.
    pub(crate) fn too_large(size: u64, bound: u64, exact: bool) -> Self {
        let size_words = if exact {
            format!("{size} bytes")
        } else {
            format!("more than {bound} bytes")
        };
        Self {
            too_large: exact.then_some(size),
            ..Self::permanent(format!(
                "the object is {size_words}; at most {bound} are read for it"
            ))
        }
    }

    /// Whether another try may succeed.
    pub(crate) fn is_transient(&self) -> bool {
        self.persistence == Persistence::Transient
    }

    /// The failure as it ends an operation of `tries` tries.
    pub(crate) fn after(mut self, tries: u32) -> Self {
        self.tries = tries;
        self
    }

    /// The cause and, when it was retried, how often: `HTTP 500 Internal Server Error (after
    /// 9 tries)`.
    pub(crate) fn describe(&self) -> String {
        if self.tries > 1 {
            format!("{} (after {} tries)", self.cause, self.tries)
        } else {
            self.cause.clone()
        }
    }
}

/// Whether the server is answering: after a request timed out with nothing heard from the
/// server since it was sent, every request fails at once for [`Timing::silence_cool_down`],
/// so that a server that went silent costs one timeout, not one per object. And whether its
/// objects fail: while most of the latest operations ended in failure after their retries (a
/// level whose every chunk answers 500), an operation retries [`FEW_RETRIES`] times, not
/// [`Timing::max_retries`], so that a dead level costs each brick a moment, not seconds.
#[derive(Debug, Default)]
pub(crate) struct Health {
    state: Mutex<HealthState>,
}

/// Retries of an operation while most operations fail.
pub(crate) const FEW_RETRIES: u32 = 2;

/// Operations whose outcome is remembered.
const OUTCOMES: usize = 16;

#[derive(Debug, Default)]
struct HealthState {
    last_answer: Option<Instant>,
    silent_until: Option<Instant>,
    silent_for: Duration,
    /// Whether each of the latest operations failed, oldest first.
    outcomes: std::collections::VecDeque<bool>,
}

impl Health {
    /// The failure a request gets at once while the server is taken to be silent.
    pub(crate) fn check(&self) -> Option<Failure> {
        let state = self.state.lock().ok()?;
        let until = state.silent_until?;
        let now = Instant::now();
        (until > now).then(|| Failure {
            persistence: Persistence::Silent,
            ..Failure::transient(
                format!(
                    "no answer from the server for {} s (asked again in {} s)",
                    seconds(state.silent_for),
                    seconds(until - now).max(1)
                ),
                false,
            )
        })
    }

    /// The server answered something.
    pub(crate) fn answered(&self) {
        if let Ok(mut state) = self.state.lock() {
            state.last_answer = Some(Instant::now());
            state.silent_until = None;
        }
    }

    /// An operation (an object and its retries) ended, in failure or not.
    pub(crate) fn operation_ended(&self, failed: bool) {
        if let Ok(mut state) = self.state.lock() {
            if state.outcomes.len() == OUTCOMES {
                state.outcomes.pop_front();
            }
            state.outcomes.push_back(failed);
        }
    }

    /// The retries an operation starting now may make: `max`, or [`FEW_RETRIES`] while at
    /// least three quarters of the latest operations (eight or more) failed.
    pub(crate) fn retries(&self, max: u32) -> u32 {
        let Ok(state) = self.state.lock() else {
            return max;
        };
        let failed = state.outcomes.iter().filter(|&&f| f).count();
        if state.outcomes.len() >= 8 && failed * 4 >= state.outcomes.len() * 3 {
            max.min(FEW_RETRIES)
        } else {
            max
        }
    }

    /// A request sent at `sent` timed out after `waited`: if nothing was heard from the server
    /// since, it is silent for `cool_down`.
    pub(crate) fn timed_out(&self, sent: Instant, waited: Duration, cool_down: Duration) {
        if let Ok(mut state) = self.state.lock()
            && state.last_answer.is_none_or(|heard| heard < sent)
        {
            state.silent_until = Some(Instant::now() + cool_down);
            state.silent_for = waited;
        }
    }
}

/// Whole seconds of `duration`, rounded up (a message says "within 1 s", not "0 s").
pub(crate) fn seconds(duration: Duration) -> u64 {
    duration.as_millis().div_ceil(1000) as u64
}

/// A `Retry-After` header's wait: delay-seconds, or an HTTP date (IMF-fixdate, the form
/// RFC 9110 requires senders to use). `None` if it is neither.
pub(crate) fn parse_retry_after(value: &str) -> Option<Duration> {
    let value = value.trim();
    if let Ok(seconds) = value.parse::<u64>() {
        return Some(Duration::from_secs(seconds));
    }
    let at = parse_imf_fixdate(value)?;
    let now = SystemTime::now().duration_since(UNIX_EPOCH).ok()?.as_secs();
    Some(Duration::from_secs(at.saturating_sub(now)))
}

/// `Sun, 06 Nov 1994 08:49:37 GMT` as seconds since the Unix epoch.
fn parse_imf_fixdate(text: &str) -> Option<u64> {
    let parts: Vec<&str> = text.split_whitespace().collect();
    let [_, day, month, year, time, "GMT"] = parts.as_slice() else {
        return None;
    };
    let day: u64 = day.parse().ok()?;
    let month = [
        "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
    ]
    .iter()
    .position(|m| m == month)? as u64
        + 1;
    let year: u64 = year.parse().ok()?;
    let mut hms = time.split(':').map(|p| p.parse::<u64>().ok());
    let (h, m, s) = (hms.next()??, hms.next()??, hms.next()??);
    if !(1..=31).contains(&day) || year < 1970 || h > 23 || m > 59 || s > 60 {
        return None;
    }
    // Days from the civil date (Howard Hinnant's algorithm).
    let (y, mo) = if month <= 2 {
        (year - 1, month + 9)
    } else {
        (year, month - 3)
    };
    let era = y / 400;
    let yoe = y - era * 400;
    let doy = (153 * mo + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    Some(days * 86_400 + h * 3600 + m * 60 + s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retry_after_reads_seconds_and_http_dates() {
        assert_eq!(parse_retry_after(" 7 "), Some(Duration::from_secs(7)));
        assert_eq!(
            parse_imf_fixdate("Sun, 06 Nov 1994 08:49:37 GMT"),
            Some(784_111_777)
        );
        assert_eq!(
            parse_retry_after("Sun, 06 Nov 1994 08:49:37 GMT"),
            Some(Duration::ZERO)
        );
        assert_eq!(parse_retry_after("soon"), None);
        assert_eq!(parse_retry_after("Sun, 06 Nov 1994 25:49:37 GMT"), None);
    }

    #[test]
    fn backoff_doubles_up_to_its_bound() {
        let timing = Timing::default();
        assert_eq!(timing.backoff(1), Duration::from_millis(50));
        assert_eq!(timing.backoff(3), Duration::from_millis(200));
        assert_eq!(timing.backoff(30), Duration::from_secs(2));
    }

    #[test]
    fn a_silent_server_fails_requests_at_once_until_it_answers() {
        let health = Health::default();
        assert!(health.check().is_none());
        let sent = Instant::now();
        health.timed_out(sent, Duration::from_secs(20), Duration::from_secs(5));
        let failure = health.check().expect("silent");
        assert_eq!(failure.persistence, Persistence::Silent);
        assert!(
            failure.cause.contains("no answer from the server for 20 s"),
            "{}",
            failure.cause
        );
        health.answered();
        assert!(health.check().is_none());
        // A timeout of a request sent before the last answer says nothing.
        health.timed_out(sent, Duration::from_secs(20), Duration::from_secs(5));
        assert!(health.check().is_none());
    }

    #[test]
    fn while_most_operations_fail_few_retries_are_made() {
        let health = Health::default();
        assert_eq!(health.retries(8), 8);
        for _ in 0..7 {
            health.operation_ended(true);
        }
        assert_eq!(health.retries(8), 8, "too few to judge");
        health.operation_ended(true);
        assert_eq!(health.retries(8), FEW_RETRIES);
        for _ in 0..4 {
            health.operation_ended(false);
        }
        assert_eq!(
            health.retries(8),
            8,
            "8 of 12 failed: fewer than three quarters"
        );
    }
}
