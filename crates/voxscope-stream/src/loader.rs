//! Worker threads that load bricks: they take the best request from the queue, read it from
//! the source (I/O and decode), convert it to the atlas's texel format, and send it to the
//! streamer, which picks results up once per frame without waiting. No frame ever waits on a
//! worker, and nothing waits for a worker to finish: one blocked on a silent server is left to
//! end on its own (the source's deadlines bound it) when its streamer goes. A panic while
//! reading a brick is caught and becomes that brick's error.

use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;

use super::queue::{Request, RequestQueue, Tier};
use crate::{BrickError, BrickId, BrickSource, PADDED_BRICK_VOXELS, ValueRange};

/// How value levels are stored in the atlas's texels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AtlasTexels {
    /// One byte: every level ≤ 255.
    Unorm8,
    /// Two bytes, normalized: every level exact.
    Unorm16,
    /// Two bytes, half float (devices without 16-bit normalized textures): exact to 2048.
    Float16,
}

impl AtlasTexels {
    /// Bytes per texel.
    pub fn bytes(self) -> usize {
        match self {
            Self::Unorm8 => 1,
            Self::Unorm16 | Self::Float16 => 2,
        }
    }

    /// Texel value × this = value level (the shader's `atlas_scale`).
    pub fn scale(self) -> f32 {
        match self {
            Self::Unorm8 => 255.0,
            Self::Unorm16 => 65535.0,
            Self::Float16 => 1.0,
        }
    }

    /// `levels` as texel bytes.
    pub fn encode(self, levels: &[u16]) -> Arc<[u8]> {
        match self {
            Self::Unorm8 => levels.iter().map(|&l| l.min(255) as u8).collect(),
            Self::Unorm16 => Arc::from(bytemuck::cast_slice::<u16, u8>(levels)),
            Self::Float16 => levels
                .iter()
                .flat_map(|&l| half::f16::from_f32(l as f32).to_le_bytes())
                .collect(),
        }
    }
}

/// A loaded brick as the streamer keeps it.
#[derive(Debug, Clone)]
pub struct LoadedBrick {
    pub range: ValueRange,
    /// The padded brick's texels, or `None` for a uniform brick (drawn from its value alone).
    pub texels: Option<Arc<[u8]>>,
}

impl LoadedBrick {
    /// Bytes of its texels (0 for a uniform brick): what uploading it moves.
    pub fn texel_bytes(&self) -> u64 {
        self.texels.as_ref().map_or(0, |t| t.len() as u64)
    }

    /// Bytes this brick takes in the RAM cache.
    pub fn bytes(&self) -> u64 {
        self.texels.as_ref().map_or(0, |t| t.len() as u64) + 32
    }
}

/// What a worker sends back.
pub struct LoadResult {
    pub key: u32,
    /// Whether it was loaded as a prefetch (not asked for by a ray).
    pub prefetch: bool,
    pub brick: Result<LoadedBrick, BrickError>,
    /// Bytes the source produced for it: its padded voxels in the atlas's texel size (what a
    /// view's floor is counted in).
    pub bytes_read: u64,
    /// How long the worker took: the source's read and decode, and the texel conversion.
    pub seconds: f64,
}

/// Bricks of the queue's best whose network reads may be started ahead
/// ([`BrickSource::fetch_ahead`]) each frame and as a worker takes one. The source starts what
/// its fetch limit has room for, in this order, and passes over bricks it handed over before;
/// the window is wide because eight bricks share a 64³ chunk: 96 bricks were 12–30 chunks, all
/// of one level, so a view's finer level waited for its coarser one to leave the queue, and
/// 512 still held one level of run 72's view at a time (the link half idle meanwhile).
pub const FETCH_AHEAD_BRICKS: usize = 2048;

/// Bricks a loader puts aside at most while other loaders decode chunks they need, before it
/// waits for the oldest ([`work`]).
const PUT_ASIDE: usize = 4;

/// The worker threads and the channel their results arrive on.
pub struct Loader {
    source: Arc<dyn BrickSource>,
    queue: Arc<RequestQueue>,
    results: Receiver<LoadResult>,
}

impl Loader {
    /// Starts `workers` threads (at least one) loading from `source` what `queue` holds.
    pub fn start(
        source: Arc<dyn BrickSource>,
        queue: Arc<RequestQueue>,
        texels: AtlasTexels,
        workers: usize,
    ) -> Self {
        let (sender, results) = channel();
        let remote = source.remote_stats().is_some();
        // rayon's global pool started here, at this thread's priority, not by a loader's first
        // read at the loaders' (its threads would take their priority for good).
        rayon::current_num_threads();
        for index in 0..workers.max(1) {
            let (source, queue, sender) = (Arc::clone(&source), Arc::clone(&queue), sender.clone());
            // Detached: see the module's documentation.
            let _detached: JoinHandle<()> = std::thread::Builder::new()
                .name(format!("voxscope-brick-loader-{index}"))
                .spawn(move || {
                    yield_to_frames();
                    work(&*source, remote, &queue, texels, &sender)
                })
                .expect("the system starts a thread");
        }
        Self {
            source,
            queue,
            results,
        }
    }

    /// Starts the reads of the queue's next bricks without waiting
    /// ([`BrickSource::fetch_ahead`]: a network store's requests, a folder's files read ahead
    /// into the page cache; nothing for a source in memory).
    pub fn fetch_ahead(&self) {
        fetch_ahead(&*self.source, &self.queue);
    }

    /// Every result that has arrived, without waiting.
    pub fn received(&self) -> Vec<LoadResult> {
        self.results.try_iter().collect()
    }

    /// The next result, waiting up to `timeout` for it (a benchmark's; a frame never waits).
    pub fn next_received(&self, timeout: std::time::Duration) -> Option<LoadResult> {
        self.results.recv_timeout(timeout).ok()
    }
}

/// How much less this system's scheduler favours a loader thread than the others (Linux's
/// nice value): the loaders take every core the frames leave, and the scheduler gives a
/// frame's update a core before them (run 77's updates waited ≤ 0.04 ms for one).
pub const LOADER_NICENESS: i32 = 10;

/// Lowers the calling thread's priority by [`LOADER_NICENESS`] where the system has
/// per-thread priorities (Linux); elsewhere the loaders run at the frames' priority.
fn yield_to_frames() {
    #[cfg(target_os = "linux")]
    // SAFETY: setpriority and gettid only read their arguments; on Linux the nice value is
    // the thread's own, named by its id.
    unsafe {
        let thread = libc::gettid() as libc::id_t;
        let niceness = libc::getpriority(libc::PRIO_PROCESS, thread) + LOADER_NICENESS;
        libc::setpriority(libc::PRIO_PROCESS, thread, niceness.min(19));
    }
}

/// Reads one brick as the loader does (also used for the pinned levels, on the caller's
/// thread); a panic in the source becomes the brick's error.
pub fn load_brick(
    source: &dyn BrickSource,
    id: BrickId,
    texels: AtlasTexels,
) -> (Result<LoadedBrick, BrickError>, u64) {
    load_brick_unless_busy(source, id, texels, true).expect("a read that waits reads")
}

/// [`load_brick`], or `None` where `wait` is off and the read would wait for another loader
/// ([`BrickSource::read_brick_unless_busy`]).
fn load_brick_unless_busy(
    source: &dyn BrickSource,
    id: BrickId,
    texels: AtlasTexels,
    wait: bool,
) -> Option<(Result<LoadedBrick, BrickError>, u64)> {
    let read = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        if wait {
            Some(source.read_brick(id))
        } else {
            source.read_brick_unless_busy(id)
        }
    }))
    .unwrap_or_else(|panic| {
        let text = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Some(Err(BrickError::invalid(format!(
            "{}: reading {id} failed inside voxscope ({})",
            source.name(),
            text.split_whitespace().collect::<Vec<_>>().join(" ")
        ))))
    });
    Some(match read? {
        Ok(data) => {
            let bytes_read = (data.levels.len() * texels.bytes()) as u64;
            if data.levels.len() != PADDED_BRICK_VOXELS {
                return Some((
                    Err(BrickError::invalid(format!(
                        "{}: {id} has {} value levels, not {PADDED_BRICK_VOXELS}",
                        source.name(),
                        data.levels.len()
                    ))),
                    bytes_read,
                ));
            }
            let texels = (!data.range.is_uniform()).then(|| texels.encode(&data.levels));
            (
                Ok(LoadedBrick {
                    range: data.range,
                    texels,
                }),
                bytes_read,
            )
        }
        Err(error) => (Err(error), 0),
    })
}

fn fetch_ahead(source: &dyn BrickSource, queue: &RequestQueue) {
    if !source.can_fetch_ahead() {
        return;
    }
    let upcoming = queue.upcoming(FETCH_AHEAD_BRICKS);
    if !upcoming.is_empty() {
        source.fetch_ahead(&upcoming);
    }
}

fn work(
    source: &dyn BrickSource,
    remote: bool,
    queue: &RequestQueue,
    texels: AtlasTexels,
    results: &Sender<LoadResult>,
) {
    // Reads `request`'s brick and sends it, its time the attempt's and `spent` (earlier ones');
    // `Err` with the attempt's time (nothing sent) where `wait` is off and the read would wait
    // for another loader; `Ok(false)` once the streamer is gone.
    let load = |request: &Request, wait: bool, spent: f64| -> Result<bool, f64> {
        let started = std::time::Instant::now();
        let Some((brick, bytes_read)) = load_brick_unless_busy(source, request.id, texels, wait)
        else {
            return Err(started.elapsed().as_secs_f64());
        };
        let result = LoadResult {
            key: request.key,
            prefetch: request.priority.tier() == Tier::Prefetch,
            brick,
            bytes_read,
            seconds: spent + started.elapsed().as_secs_f64(),
        };
        Ok(results.send(result).is_ok())
    };
    // Bricks put aside because another loader was decoding a chunk they need (neighbouring
    // bricks share chunks, and the queue hands out neighbours together), oldest first, each
    // with the seconds its attempts took: asked for again, without waiting, after each other
    // brick read, by when their chunks are usually decoded; waited for once there are
    // PUT_ASIDE of them, or nothing else of their tier to read (a visible brick does not wait
    // behind prefetches).
    let mut aside: Vec<(Request, f64)> = Vec::new();
    loop {
        let next = match aside.first() {
            _ if aside.len() >= PUT_ASIDE => None,
            // Waits while the queue is empty; `None` once it is closed.
            None => Some(queue.take()),
            Some((oldest, _)) => {
                let tier = oldest.priority.tier();
                queue
                    .try_take_if(|next| next.priority.tier() == tier)
                    .map(Some)
            }
        };
        match next {
            Some(Some(request)) => {
                // What comes after this brick goes on the wire while this one is read and
                // decoded (a folder's reads ahead are asked for each frame, hundreds of chunks
                // ahead of the loaders, enough for a disk: the queue is not looked at here).
                if remote {
                    fetch_ahead(source, queue);
                }
                match load(&request, false, 0.0) {
                    Ok(true) => {}
                    Ok(false) => return, // the streamer is gone
                    Err(spent) => {
                        aside.push((request, spent));
                        continue;
                    }
                }
            }
            Some(None) => return, // closed
            None => {
                let (oldest, spent) = aside.remove(0);
                if load(&oldest, true, spent) != Ok(true) {
                    return;
                }
            }
        }
        // A brick was read meanwhile: those put aside are asked for again.
        let mut index = 0;
        while index < aside.len() {
            let (request, spent) = aside[index];
            match load(&request, false, spent) {
                Ok(true) => drop(aside.remove(index)),
                Ok(false) => return,
                Err(more) => {
                    aside[index].1 += more;
                    index += 1;
                }
            }
        }
    }
}

impl Drop for Loader {
    fn drop(&mut self) {
        // Workers take nothing more; one still reading ends when its read does.
        self.queue.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BrickData, PyramidShape};
    use voxscope_volume::Quantization;

    /// A source whose reads do what `read` says, and that records what it is asked to fetch
    /// ahead; brick x is busy (another loader decoding a chunk it needs) the first `busy[x]`
    /// times it is asked without waiting, and each read is recorded: the brick's x, and
    /// whether it waited.
    struct Scripted<R> {
        name: &'static str,
        shape: PyramidShape,
        read: R,
        fetched: std::sync::Mutex<Vec<Vec<BrickId>>>,
        busy: std::sync::Mutex<Vec<usize>>,
        reads: std::sync::Mutex<Vec<(u32, bool)>>,
    }

    /// What a [`Scripted`] source reads with.
    trait ReadBrick: Fn(BrickId) -> Result<BrickData, BrickError> + Send + Sync {}
    impl<R: Fn(BrickId) -> Result<BrickData, BrickError> + Send + Sync> ReadBrick for R {}

    impl<R: Fn(BrickId) -> Result<BrickData, BrickError> + Send + Sync> Scripted<R> {
        fn new(name: &'static str, dims: [usize; 3], read: R) -> Self {
            Self {
                name,
                shape: PyramidShape::new(dims).expect("a shape"),
                read,
                fetched: Default::default(),
                busy: Default::default(),
                reads: Default::default(),
            }
        }

        fn read(&self, id: BrickId, waited: bool) -> Result<BrickData, BrickError> {
            self.reads
                .lock()
                .expect("not poisoned")
                .push((id.brick[0], waited));
            (self.read)(id)
        }
    }

    impl<R: Fn(BrickId) -> Result<BrickData, BrickError> + Send + Sync> BrickSource for Scripted<R> {
        fn name(&self) -> &str {
            self.name
        }
        fn shape(&self) -> &PyramidShape {
            &self.shape
        }
        fn spacing(&self) -> [f64; 3] {
            [1.0; 3]
        }
        fn quantization(&self) -> Quantization {
            Quantization {
                offset: 0.0,
                step: 1.0,
            }
        }
        fn max_value_level(&self) -> u16 {
            255
        }
        fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
            self.read(id, true)
        }
        fn read_brick_unless_busy(&self, id: BrickId) -> Option<Result<BrickData, BrickError>> {
            let mut busy = self.busy.lock().expect("not poisoned");
            if let Some(left) = busy.get_mut(id.brick[0] as usize)
                && *left > 0
            {
                *left -= 1;
                return None;
            }
            drop(busy);
            Some(self.read(id, false))
        }
        fn can_fetch_ahead(&self) -> bool {
            true
        }
        fn fetch_ahead(&self, ids: &[BrickId]) {
            self.fetched
                .lock()
                .expect("not poisoned")
                .push(ids.to_vec());
        }
    }

    /// A read that fails, naming the brick.
    fn not_read(id: BrickId) -> Result<BrickData, BrickError> {
        Err(BrickError::invalid(format!("{id} is not read here")))
    }

    #[test]
    fn the_queues_next_bricks_are_fetched_ahead_in_its_order() {
        let source = Scripted::new("recording", [256, 256, 256], not_read);
        let queue = RequestQueue::default();
        let request = |tier, level, off_center, x| crate::Request {
            priority: crate::Priority::new(tier, level, off_center),
            id: BrickId {
                level,
                brick: [x, 0, 0],
                channel: 0,
            },
            key: level << 28 | x,
        };
        queue.replace(vec![
            request(Tier::Prefetch, 2, 0.0, 0),
            request(Tier::Visible, 0, 0.5, 1),
            request(Tier::Visible, 0, 0.1, 2),
            request(Tier::Visible, 1, 0.9, 3),
        ]);
        fetch_ahead(&source, &queue);
        let asked: Vec<(u32, u32)> = source.fetched.lock().expect("not poisoned")[0]
            .iter()
            .map(|id| (id.level, id.brick[0]))
            .collect();
        // Visible before prefetch, coarse before fine, the center before the edge.
        assert_eq!(asked, [(1, 3), (0, 2), (0, 1), (2, 0)]);
        // A worker takes the best; the next call asks for the rest.
        assert_eq!(queue.try_take().map(|r| r.id.brick[0]), Some(3));
        fetch_ahead(&source, &queue);
        assert_eq!(source.fetched.lock().expect("not poisoned")[1].len(), 3);
        // Nothing waiting: nothing asked.
        while queue.try_take().is_some() {}
        fetch_ahead(&source, &queue);
        assert_eq!(source.fetched.lock().expect("not poisoned").len(), 2);
    }

    /// The calling thread's nice value: the 19th field of its stat line, after the
    /// parenthesized name.
    #[cfg(target_os = "linux")]
    fn thread_niceness() -> i32 {
        let stat = std::fs::read_to_string("/proc/thread-self/stat").expect("Linux");
        let after_name = &stat[stat.rfind(')').expect("a name") + 2..];
        let nice = after_name.split_whitespace().nth(16).expect("a nice field");
        nice.parse().expect("a number")
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn loaders_run_below_the_frames_priority() {
        let niceness = Arc::new(std::sync::Mutex::new(Vec::new()));
        let read = Arc::clone(&niceness);
        let source = Arc::new(Scripted::new("niceness", [40, 40, 40], move |id| {
            read.lock().expect("not poisoned").push(thread_niceness());
            not_read(id)
        }));
        let queue = Arc::new(RequestQueue::default());
        let loader = Loader::start(source.clone(), Arc::clone(&queue), AtlasTexels::Unorm8, 2);
        queue.replace(vec![crate::Request {
            priority: crate::Priority::new(Tier::Visible, 0, 0.0),
            id: BrickId {
                level: 0,
                brick: [0, 0, 0],
                channel: 0,
            },
            key: 0,
        }]);
        let started = std::time::Instant::now();
        while loader.received().is_empty() && started.elapsed() < std::time::Duration::from_secs(10)
        {
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        // SAFETY: getpriority only reads its arguments.
        let ours = unsafe { libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t) };
        let read = niceness.lock().expect("not poisoned").clone();
        assert_eq!(read, [(ours + LOADER_NICENESS).min(19)]);
    }

    #[test]
    fn a_panic_while_reading_a_brick_is_that_bricks_error() {
        let source = Scripted::new(
            "panicking",
            [40, 40, 40],
            |_| -> Result<BrickData, BrickError> {
                panic!("index out of bounds: the len is 3 but the index is 7")
            },
        );
        let id = BrickId {
            level: 0,
            brick: [1, 0, 0],
            channel: 0,
        };
        let (brick, bytes) = load_brick(&source, id, AtlasTexels::Unorm8);
        let error = brick.expect_err("it panicked");
        assert!(matches!(error, BrickError::Invalid(_)), "{error:?}");
        assert_eq!(
            error.to_string(),
            "panicking: reading level 0 brick (1, 0, 0) failed inside voxscope (index out of bounds: the len is 3 but the index is 7)"
        );
        assert_eq!(bytes, 0);
        // And in a worker: the result arrives, the worker lives on for the next request.
        let queue = Arc::new(RequestQueue::default());
        let loader = Loader::start(Arc::new(source), Arc::clone(&queue), AtlasTexels::Unorm8, 1);
        let request = |key| crate::Request {
            priority: crate::Priority::new(Tier::Visible, 0, 0.0),
            id: BrickId {
                level: 0,
                brick: [key, 0, 0],
                channel: 0,
            },
            key,
        };
        queue.replace(vec![request(0), request(1)]);
        let mut results = Vec::new();
        let started = std::time::Instant::now();
        while results.len() < 2 && started.elapsed() < std::time::Duration::from_secs(10) {
            results.extend(loader.received());
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        assert_eq!(results.len(), 2);
        assert!(results.iter().all(|r| r.brick.is_err()));
    }

    /// A source of bricks of their x, busy as `busy` says ([`Scripted`]).
    fn contended(busy: Vec<usize>) -> Arc<Scripted<impl ReadBrick>> {
        let source = Scripted::new("contended", [256, 32, 32], |id: BrickId| {
            Ok(BrickData::new(
                vec![id.brick[0] as u16; PADDED_BRICK_VOXELS],
                [32; 3],
            ))
        });
        *source.busy.lock().expect("not poisoned") = busy;
        Arc::new(source)
    }

    /// What one loader reads of bricks 0, 1, … (best first; those from `prefetch_from` on
    /// prefetches) from `source`, in order.
    fn read_in_order(
        source: Arc<Scripted<impl ReadBrick + 'static>>,
        bricks: u32,
        prefetch_from: u32,
    ) -> Vec<(u32, bool)> {
        let queue = Arc::new(RequestQueue::default());
        queue.replace(
            (0..bricks)
                .map(|x| crate::Request {
                    priority: crate::Priority::new(
                        if x < prefetch_from {
                            Tier::Visible
                        } else {
                            Tier::Prefetch
                        },
                        0,
                        x as f32,
                    ),
                    id: BrickId {
                        level: 0,
                        brick: [x, 0, 0],
                        channel: 0,
                    },
                    key: x,
                })
                .collect(),
        );
        let loader = Loader::start(source.clone(), queue, AtlasTexels::Unorm8, 1);
        let mut keys: Vec<u32> = (0..bricks)
            .map(|_| {
                let result = loader
                    .next_received(std::time::Duration::from_secs(10))
                    .expect("every brick arrives");
                assert!(result.brick.is_ok());
                result.key
            })
            .collect();
        keys.sort_unstable();
        assert_eq!(keys, (0..bricks).collect::<Vec<_>>(), "each brick once");
        source.reads.lock().expect("not poisoned").clone()
    }

    #[test]
    fn a_loader_reads_the_next_brick_while_another_decodes_what_its_brick_needs() {
        // Brick 0 is busy once: brick 1 is read meanwhile, then 0, without waiting.
        let reads = read_in_order(contended(vec![1, 0, 0]), 3, 3);
        assert_eq!(reads, [(1, false), (0, false), (2, false)]);
        // Busy for a while: 0 and 2 are put aside, 1 and 3 read, then 0 and 2 once free.
        let reads = read_in_order(contended(vec![2, 0, 1, 0]), 4, 4);
        assert_eq!(reads, [(1, false), (3, false), (0, false), (2, false)]);
        // A visible brick is not put behind a prefetch: it is waited for.
        let reads = read_in_order(contended(vec![1, 0]), 2, 1);
        assert_eq!(reads, [(0, true), (1, false)]);
    }

    #[test]
    fn a_loader_waits_for_the_oldest_brick_once_it_has_put_aside_enough() {
        // Never free without waiting: PUT_ASIDE bricks are put aside, then the oldest is
        // waited for, and each after it as the next one is put aside; the last ones, with
        // nothing left to read meanwhile, are waited for in order. None is lost, none is
        // read twice.
        let bricks = PUT_ASIDE as u32 + 2;
        let reads = read_in_order(contended(vec![usize::MAX; bricks as usize]), bricks, bricks);
        assert_eq!(reads, (0..bricks).map(|x| (x, true)).collect::<Vec<_>>());
    }
}
