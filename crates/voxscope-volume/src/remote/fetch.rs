//! What a store's reads do on the network: fetching objects and byte ranges with deadlines
//! and retries, through the cache, the remembered failures and the request limit, and
//! fetching ahead for the streamer.

use super::*;

/// Why an object is fetched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Fetched {
    /// For a read waiting on it.
    ForRead,
    /// Ahead of its read ([`RemoteStore::fetch_ahead`]): kept as unread until a read takes it.
    Ahead,
    /// A document of the open's batches ([`RemoteStore::prefetch_guessing`]): fetched with
    /// its retries as a read is, but a failure is left to the batch to record (a 403 is
    /// taken there for a missing object where another document of its node is there).
    Document,
    /// A document the open guesses may exist (the levels' of a store not read yet): asked for
    /// once, without retries; its bytes are kept and its absence remembered as any read's,
    /// but a failure (a 403 where a server denies what it does not have, a 5xx) is not the
    /// store's: not counted, not remembered, not a failed operation of the health's (whose
    /// watch for a silent server still sees it). A read asks again. Guessed and document
    /// fetches run only in the open's batches, before any read could share their flight.
    Guess,
}

impl Inner {
    /// How many more fetches ahead may start now: at most twice the request limit under way,
    /// and no more than the fetch cache keeps until they are read ([`FetchCache::ahead_room`];
    /// `bound`: the most bytes each may have, what is expected of each before any object was
    /// fetched).
    pub(super) fn ahead_room(&self, bound: u64) -> usize {
        self.cache
            .lock()
            .map_or(0, |mut cache| self.ahead_room_locked(&mut cache, bound))
    }

    /// [`Self::ahead_room`] with the cache's lock held.
    pub(super) fn ahead_room_locked(&self, cache: &mut FetchCache, bound: u64) -> usize {
        let in_flight = self.ahead.load(Ordering::Relaxed);
        let room = self.max_ahead.saturating_sub(in_flight);
        if room == 0 {
            return 0;
        }
        room.min(cache.ahead_room(in_flight, bound))
    }

    pub(super) fn deadline(&self) -> Duration {
        if self.opened.load(Ordering::Relaxed) {
            self.timing.read_deadline
        } else {
            self.timing.open_deadline
        }
    }

    /// The most bytes the object `key` may have.
    pub(super) fn bound(&self, key: &str) -> u64 {
        self.bounds
            .lock()
            .ok()
            .and_then(|bounds| {
                bounds
                    .iter()
                    .filter(|(prefix, _)| key.starts_with(prefix.as_str()))
                    .max_by_key(|(prefix, _)| prefix.len())
                    .map(|&(_, bound)| bound)
            })
            .unwrap_or(MAX_OBJECT_BYTES)
    }

    /// `piece` of the object `key` (`None`: there is none): from the cache, from the fetch in
    /// flight, or fetched now with its retries. `bound`: the most bytes it may have (`None`:
    /// its prefix's, [`RemoteStore::bound_objects`]).
    pub(super) async fn read(
        self: Arc<Self>,
        key: String,
        piece: Piece,
        bound: Option<u64>,
    ) -> Result<Option<Bytes>, Failure> {
        if piece.is_empty() {
            return Ok(Some(Bytes::new()));
        }
        if let Ok(mut cache) = self.cache.lock() {
            if cache.is_missing(&key) {
                return Ok(None);
            }
            if let Some(cut) = cache.piece(&key, piece) {
                cache.mark_read(&key);
                return cut.map(Some);
            }
        }
        if let Some(cut) = self
            .held
            .lock()
            .ok()
            .and_then(|held| held.piece(&key, piece))
        {
            return cut.map(Some);
        }
        if let Some(failure) = self.remembered.get(&key) {
            return Err(failure);
        }
        // A server known to ignore `Range` is asked for the whole object, once for all pieces.
        let fetched = if self.ranges.load(Ordering::Relaxed) == RANGES_IGNORED {
            Piece::Whole
        } else {
            piece
        };
        // A range inside a coalesced run being fetched is cut from that run.
        if let Some((run, start)) = self.run_holding(&key, fetched) {
            return match run.await? {
                Answer::Missing => Ok(None),
                Answer::Body { bytes, whole } => {
                    let piece = if whole {
                        piece
                    } else {
                        piece.shifted_back(start)
                    };
                    piece.cut(&bytes).map(Some)
                }
            };
        }
        let flight = self.flight(&key, fetched, bound, Fetched::ForRead);
        let answer = flight.await?;
        // A fetch ahead's flight, joined: its bytes are used.
        if let Ok(mut cache) = self.cache.lock() {
            cache.mark_read(&key);
        }
        match answer {
            Answer::Missing => Ok(None),
            Answer::Body { bytes, whole } => {
                if piece == Piece::Whole || (!whole && fetched == piece) {
                    Ok(Some(bytes))
                } else {
                    piece.cut(&bytes).map(Some)
                }
            }
        }
    }

    /// `pieces` of the object `key`, in their order (`None`: there is none): those kept from
    /// the cache, the rest fetched together, adjacent ranges in one request ([`coalesce`]),
    /// each piece then kept on its own. Until the store knows whether the server honours
    /// `Range`, one request is made first: a server that ignores it would send the whole
    /// object for each.
    pub(super) async fn read_many(
        self: Arc<Self>,
        key: String,
        pieces: Vec<Piece>,
    ) -> Result<Vec<Option<Bytes>>, Failure> {
        let mut parts: Vec<Option<Option<Bytes>>> = vec![None; pieces.len()];
        if let (Ok(cache), Ok(held)) = (self.cache.lock(), self.held.lock()) {
            for (part, &piece) in parts.iter_mut().zip(&pieces) {
                let kept = cache.piece(&key, piece).or_else(|| held.piece(&key, piece));
                if let Some(Ok(bytes)) = kept {
                    *part = Some(Some(bytes));
                }
            }
        }
        let left: Vec<usize> = (0..pieces.len()).filter(|&i| parts[i].is_none()).collect();
        let left_pieces: Vec<Piece> = left.iter().map(|&i| pieces[i]).collect();
        let mut groups = coalesce(&left_pieces);
        // A server that ignores `Range` answers each merged range with the whole object too:
        // the first group alone until that is known.
        let first = if self.ranges.load(Ordering::Relaxed) == RANGES_UNKNOWN && !groups.is_empty() {
            Some(groups.remove(0))
        } else {
            None
        };
        let mut answers: Vec<(Vec<usize>, Piece, Option<Bytes>)> = Vec::new();
        if let Some((piece, members)) = first {
            let bytes = self.clone().read(key.clone(), piece, None).await?;
            answers.push((members, piece, bytes));
        }
        let reads = groups
            .iter()
            .map(|(piece, _)| self.clone().read(key.clone(), *piece, None));
        for ((piece, members), bytes) in groups.iter().zip(futures::future::join_all(reads).await) {
            answers.push((members.clone(), *piece, bytes?));
        }
        for (members, fetched, bytes) in answers {
            let Some(bytes) = bytes else {
                // A missing object is missing for every piece.
                return Ok(vec![None; pieces.len()]);
            };
            if let [member] = members[..] {
                parts[left[member]] = Some(Some(bytes));
                continue;
            }
            let Piece::Range(start, _) = fetched else {
                continue;
            };
            let mut cache = self.cache.lock().ok();
            for member in members {
                let Piece::Range(a, b) = left_pieces[member] else {
                    continue;
                };
                let cut = Piece::Range(a - start, b - start).cut(&bytes)?;
                if let Some(cache) = cache.as_mut() {
                    cache.insert(&key, left_pieces[member], &cut);
                }
                parts[left[member]] = Some(Some(cut));
            }
            // Each piece is kept on its own: the run need not be kept twice.
            if let Some(cache) = cache.as_mut() {
                cache.remove(&key, fetched);
            }
        }
        Ok(parts.into_iter().map(Option::flatten).collect())
    }

    /// A fetch in flight of a range of `key` that holds all of `piece` (a range, not itself
    /// being fetched), and where that range starts.
    pub(super) fn run_holding(&self, key: &str, piece: Piece) -> Option<(Flight, u64)> {
        let Piece::Range(a, b) = piece else {
            return None;
        };
        let flights = self.flights.lock().ok()?;
        if flights.contains_key(&(key.to_owned(), piece)) {
            return None;
        }
        flights.iter().find_map(|((k, run), flight)| match *run {
            Piece::Range(start, end) if k == key && start <= a && b <= end => {
                Some((flight.clone(), start))
            }
            _ => None,
        })
    }

    /// The fetch of `piece` of `key` in flight, started now if there is none.
    pub(super) fn flight(
        self: &Arc<Self>,
        key: &str,
        piece: Piece,
        bound: Option<u64>,
        fetched: Fetched,
    ) -> Flight {
        let id = (key.to_owned(), piece);
        let Ok(mut flights) = self.flights.lock() else {
            return self
                .clone()
                .fetch(key.to_owned(), piece, bound, fetched)
                .boxed()
                .shared();
        };
        if let Some(flight) = flights.get(&id) {
            return flight.clone();
        }
        let inner = self.clone();
        let flight = async move {
            let result = inner
                .clone()
                .fetch(id.0.clone(), piece, bound, fetched)
                .await;
            if let Ok(mut flights) = inner.flights.lock() {
                flights.remove(&id);
            }
            result
        }
        .boxed()
        .shared();
        flights.insert((key.to_owned(), piece), flight.clone());
        flight
    }

    /// Fetches `piece` of `key` with its retries and keeps what it learned: the bytes, that
    /// the object is missing, or that it failed.
    pub(super) async fn fetch(
        self: Arc<Self>,
        key: String,
        piece: Piece,
        bound: Option<u64>,
        fetched: Fetched,
    ) -> Result<Answer, Failure> {
        let bound = bound.unwrap_or_else(|| self.bound(&key));
        let attempt = || self.transport.get(&key, piece, bound);
        let received = |answer: &Answer| match answer {
            Answer::Body { bytes, .. } => bytes.len() as u64,
            Answer::Missing => 0,
        };
        let result = match fetched {
            Fetched::ForRead | Fetched::Ahead => self.retrying(attempt, received).await,
            Fetched::Document => {
                let retries = self.health.retries(self.timing.max_retries);
                let result = self.retrying_unrecorded(attempt, received, retries).await;
                if result.is_ok() {
                    self.health.operation_ended(false);
                }
                result
            }
            Fetched::Guess => self.retrying_unrecorded(attempt, received, 0).await,
        };
        match &result {
            Ok(Answer::Missing) => {
                self.remembered.forget(&key);
                if let Ok(mut cache) = self.cache.lock() {
                    cache.insert_missing(&key);
                }
            }
            Ok(Answer::Body { bytes, whole }) => {
                self.remembered.forget(&key);
                if piece != Piece::Whole {
                    let ranges = if *whole {
                        RANGES_IGNORED
                    } else {
                        RANGES_HONOURED
                    };
                    let _ = self.ranges.compare_exchange(
                        RANGES_UNKNOWN,
                        ranges,
                        Ordering::Relaxed,
                        Ordering::Relaxed,
                    );
                }
                if let Ok(mut cache) = self.cache.lock() {
                    let kept = if *whole { Piece::Whole } else { piece };
                    if kept == Piece::Whole && self.opened.load(Ordering::Relaxed) {
                        cache.note_object(bytes.len() as u64);
                    }
                    if fetched == Fetched::Ahead && kept == Piece::Whole {
                        cache.insert_ahead(&key, bytes);
                    } else {
                        cache.insert(&key, kept, bytes);
                    }
                }
            }
            Err(_) if matches!(fetched, Fetched::Document | Fetched::Guess) => {}
            Err(failure) => self.record_failure(&key, failure),
        }
        result
    }

    /// A failed object as the store keeps it: counted among its errors, and remembered (for
    /// a while, or for good) so that reads of it ask again only later.
    pub(super) fn record_failure(&self, key: &str, failure: &Failure) {
        self.counters.errors.fetch_add(1, Ordering::Relaxed);
        self.remembered.remember(key, failure, &self.timing);
    }

    /// Runs `attempt` until it succeeds, fails for good, or the operation's deadline (which
    /// starts with its first request) or retries run out; each attempt within
    /// [`Timing::request`]; `received` counts an answer's bytes.
    pub(super) async fn retrying<T, F>(
        &self,
        attempt: impl Fn() -> F,
        received: impl Fn(&T) -> u64,
    ) -> Result<T, Failure>
    where
        F: Future<Output = Result<T, Failure>>,
    {
        let retries = self.health.retries(self.timing.max_retries);
        let result = self.retrying_unrecorded(attempt, received, retries).await;
        // A silent server is the health's own business; an operation that got an answer or
        // failed after its tries counts.
        if result
            .as_ref()
            .err()
            .is_none_or(|f| f.persistence != fault::Persistence::Silent)
        {
            self.health.operation_ended(result.is_err());
        }
        result
    }

    /// [`Self::retrying`] with at most `max_retries` retries, the operation's end not
    /// counted in the health.
    pub(super) async fn retrying_unrecorded<T, F>(
        &self,
        attempt: impl Fn() -> F,
        received: impl Fn(&T) -> u64,
        max_retries: u32,
    ) -> Result<T, Failure>
    where
        F: Future<Output = Result<T, Failure>>,
    {
        let timing = self.timing;
        let mut tries = 0u32;
        let mut deadline: Option<Instant> = None;
        loop {
            if let Some(silent) = self.health.check() {
                return Err(silent);
            }
            let permit = self
                .limit
                .acquire()
                .await
                .map_err(|_| Failure::permanent("the store is closed"))?;
            let sent = Instant::now();
            let deadline = *deadline.get_or_insert(sent + self.deadline());
            let wait = timing.request.min(deadline.saturating_duration_since(sent));
            let now = self.counters.in_flight.fetch_add(1, Ordering::Relaxed) + 1;
            self.counters
                .peak_in_flight
                .fetch_max(now, Ordering::Relaxed);
            let answer = tokio::time::timeout(wait, attempt()).await;
            self.counters.in_flight.fetch_sub(1, Ordering::Relaxed);
            self.counters.requests.fetch_add(1, Ordering::Relaxed);
            drop(permit);
            tries += 1;
            let failure = match answer {
                Ok(Ok(value)) => {
                    self.health.answered();
                    self.counters
                        .bytes
                        .fetch_add(received(&value), Ordering::Relaxed);
                    return Ok(value);
                }
                Ok(Err(failure)) => {
                    if failure.answered {
                        self.health.answered();
                    }
                    failure
                }
                Err(_) => {
                    // Only a whole request's time without a word says the server is silent
                    // (not the last moments of an operation's deadline).
                    if wait >= timing.request.min(timing.open_deadline) {
                        self.health.timed_out(sent, wait, timing.silence_cool_down);
                    }
                    Failure::transient(
                        format!("no answer within {} s", fault::seconds(wait)),
                        false,
                    )
                }
            };
            if !failure.is_transient() || tries > max_retries {
                return Err(failure.after(tries));
            }
            let pause = match failure.retry_after {
                Some(asked) if asked > timing.max_retry_after => {
                    return Err(failure.after(tries));
                }
                Some(asked) => asked,
                None => timing.backoff(tries),
            };
            if Instant::now() + pause >= deadline {
                return Err(failure.after(tries));
            }
            tokio::time::sleep(pause).await;
        }
    }

    /// One line for `failure` as zarrs passes it on: the cause, every secret blanked out.
    pub(super) fn storage_error(&self, failure: Failure) -> StorageError {
        StorageError::Other(url::redact_text(&failure.describe(), &self.secrets))
    }
}
