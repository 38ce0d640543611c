//! Several channels of one grid streamed together: a [`BrickSource`] whose bricks of channel
//! `c` are those of its `c`th source (one channel of a store each, or any pyramids of one
//! shape). The streamer keys, caches and cuts them as one pyramid ([`PyramidShape::channels`]),
//! so one GPU budget and one RAM cache serve every channel shown, and a brick of a channel
//! nobody draws is never asked for.

use std::sync::Arc;

use voxscope_volume::Quantization;
use voxscope_volume::remote::RemoteStats;

use crate::{BrickData, BrickError, BrickId, BrickSource, PyramidShape, SourceError, ValueRange};

/// Up to [`crate::MAX_STREAMED_CHANNELS`] sources of one shape as the channels of one pyramid.
pub struct ChannelSources {
    name: String,
    shape: PyramidShape,
    channels: Vec<Arc<dyn BrickSource>>,
}

impl ChannelSources {
    /// `channels` (one or more, each a pyramid of one channel, all of one shape) as channels
    /// 0, 1, … of one pyramid, called `name` in messages.
    pub fn new(name: &str, channels: Vec<Arc<dyn BrickSource>>) -> Result<Self, SourceError> {
        let Some(first) = channels.first() else {
            return Err(SourceError::shape(name)(crate::ShapeError::Channels(0)));
        };
        let levels = first.shape().levels.clone();
        if let Some(other) = channels.iter().find(|c| c.shape().levels != levels) {
            return Err(SourceError::ChannelShapes {
                name: name.to_owned(),
                first: first.shape().dims(),
                other: other.shape().dims(),
            });
        }
        let shape = PyramidShape {
            levels,
            channels: 1,
        }
        .with_channels(channels.len() as u32)
        .map_err(SourceError::shape(name))?;
        Ok(Self {
            name: name.to_owned(),
            shape,
            channels,
        })
    }

    /// Channel `channel`'s source.
    pub fn channel(&self, channel: u32) -> Option<&Arc<dyn BrickSource>> {
        self.channels.get(channel as usize)
    }

    /// The source of brick `id`'s channel, and the brick as that source names it.
    fn of(&self, id: BrickId) -> Result<(&dyn BrickSource, BrickId), BrickError> {
        match self.channels.get(id.channel as usize) {
            Some(source) => Ok((&**source, id.of_channel(0))),
            None => Err(BrickError::invalid(format!(
                "{}: {id}: no such channel ({} channels)",
                self.name,
                self.channels.len()
            ))),
        }
    }
}

impl BrickSource for ChannelSources {
    fn name(&self) -> &str {
        &self.name
    }

    fn shape(&self) -> &PyramidShape {
        &self.shape
    }

    fn spacing(&self) -> [f64; 3] {
        self.channels[0].spacing()
    }

    /// Channel 0's: each channel has its own ([`BrickSource::channel_quantization`]).
    fn quantization(&self) -> Quantization {
        self.channels[0].quantization()
    }

    fn composite(&self) -> bool {
        true
    }

    fn channel_quantization(&self, channel: u32) -> Quantization {
        self.channel(channel)
            .map_or_else(|| self.quantization(), |c| c.quantization())
    }

    /// The largest of the channels': the atlas holds every channel's levels.
    fn max_value_level(&self) -> u16 {
        self.channels
            .iter()
            .map(|c| c.max_value_level())
            .max()
            .unwrap_or(0)
    }

    fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
        let (source, brick) = self.of(id)?;
        source.read_brick(brick)
    }

    fn read_brick_unless_busy(&self, id: BrickId) -> Option<Result<BrickData, BrickError>> {
        match self.of(id) {
            Ok((source, brick)) => source.read_brick_unless_busy(brick),
            Err(error) => Some(Err(error)),
        }
    }

    fn known_range(&self, id: BrickId) -> Option<ValueRange> {
        let (source, brick) = self.of(id).ok()?;
        source.known_range(brick)
    }

    fn fetch_ahead(&self, ids: &[BrickId]) {
        for (channel, source) in self.channels.iter().enumerate() {
            let own: Vec<BrickId> = ids
                .iter()
                .filter(|id| id.channel as usize == channel)
                .map(|id| id.of_channel(0))
                .collect();
            if !own.is_empty() {
                source.fetch_ahead(&own);
            }
        }
    }

    fn can_fetch_ahead(&self) -> bool {
        self.channels.iter().any(|c| c.can_fetch_ahead())
    }

    /// The first channel's store's: channels of one store share it, and its counters.
    fn remote_stats(&self) -> Option<RemoteStats> {
        self.channels[0].remote_stats()
    }

    /// Each channel's caches get an even share of `ram`; channels of one network store share
    /// its fetch cache, sized once from their shares together (sized per channel, the
    /// last one's share would set it for all: 1/N of what it should hold).
    fn reserve_caches(&self, ram: u64) -> u64 {
        let share = ram / self.channels.len() as u64;
        let decoded: u64 = self
            .channels
            .iter()
            .map(|c| c.reserve_decoded_caches(share))
            .sum();
        let mut fetched = 0;
        for (index, channel) in self.channels.iter().enumerate() {
            let store = channel.fetch_store();
            let sharing = match store {
                Some(store) => {
                    let earlier = self.channels[..index]
                        .iter()
                        .any(|c| c.fetch_store() == Some(store));
                    if earlier {
                        continue;
                    }
                    self.channels
                        .iter()
                        .filter(|c| c.fetch_store() == Some(store))
                        .count() as u64
                }
                None => 1,
            };
            fetched += channel.reserve_fetch_cache(share * sharing);
        }
        decoded + fetched
    }

    fn cached_bytes(&self) -> u64 {
        self.channels.iter().map(|c| c.cached_bytes()).sum()
    }

    fn chunks_decoded(&self) -> u64 {
        self.channels.iter().map(|c| c.chunks_decoded()).sum()
    }

    fn labels(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;
    use crate::NoiseSource;

    /// The fetch-cache reservations made: (the store, the bytes it was sized from).
    type Reservations = Arc<Mutex<Vec<(Option<usize>, u64)>>>;

    /// A channel of a network store `store` (None: a folder's) whose fetch-cache reservations
    /// are recorded, as a `ZarrSource` sets its store's.
    struct StoreChannel {
        inner: NoiseSource,
        store: Option<usize>,
        decoded: Mutex<Vec<u64>>,
        fetch: Reservations,
    }

    impl BrickSource for StoreChannel {
        fn name(&self) -> &str {
            self.inner.name()
        }
        fn shape(&self) -> &PyramidShape {
            self.inner.shape()
        }
        fn spacing(&self) -> [f64; 3] {
            self.inner.spacing()
        }
        fn quantization(&self) -> Quantization {
            self.inner.quantization()
        }
        fn max_value_level(&self) -> u16 {
            self.inner.max_value_level()
        }
        fn read_brick(&self, id: BrickId) -> Result<BrickData, BrickError> {
            self.inner.read_brick(id)
        }
        fn reserve_decoded_caches(&self, ram: u64) -> u64 {
            self.decoded.lock().unwrap().push(ram);
            ram / 4
        }
        fn reserve_fetch_cache(&self, ram: u64) -> u64 {
            self.fetch.lock().unwrap().push((self.store, ram));
            ram / 8
        }
        fn fetch_store(&self) -> Option<usize> {
            self.store
        }
    }

    #[test]
    fn channels_of_one_store_size_its_fetch_cache_once_from_their_shares_together() {
        let fetch = Arc::new(Mutex::new(Vec::new()));
        // Three channels of store 7, one of a folder, one of store 9.
        let stores = [Some(7), Some(7), None, Some(7), Some(9)];
        let channels: Vec<Arc<dyn BrickSource>> = stores
            .iter()
            .map(|&store| {
                Arc::new(StoreChannel {
                    inner: NoiseSource::new("noise", [32; 3]).expect("a pyramid"),
                    store,
                    decoded: Mutex::new(Vec::new()),
                    fetch: Arc::clone(&fetch),
                }) as Arc<dyn BrickSource>
            })
            .collect();
        let sources = ChannelSources::new("five", channels).expect("one grid");
        let ram = 5 << 20;
        let share = ram / 5;
        let taken = sources.reserve_caches(ram);
        let fetched = fetch.lock().unwrap().clone();
        assert_eq!(
            fetched,
            [(Some(7), 3 * share), (None, share), (Some(9), share)],
            "store 7's cache is sized once, from its three channels' shares"
        );
        assert_eq!(taken, 5 * (share / 4) + (3 * share) / 8 + 2 * (share / 8));
    }
}
