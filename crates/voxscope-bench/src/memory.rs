//! The process's resident memory, for the figures `render` and `bench --stream` give: what it
//! holds now and the most it held since the last [`reset_peak`] (Linux's `VmRSS` and `VmHWM`;
//! elsewhere nothing is measured and the figures are left out); and the streaming benchmark's
//! memory by phase ([`Phases`]).

use serde_json::json;
use voxscope_stream::StreamCounters;

/// Resident bytes now and at most.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Resident {
    pub now: u64,
    pub peak: u64,
}

/// What `/proc/self/status` says, if it can be read.
pub fn resident() -> Option<Resident> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_status(&status)
}

fn parse_status(status: &str) -> Option<Resident> {
    let bytes = |name: &str| {
        status.lines().find_map(|line| {
            let kib = line.strip_prefix(name)?.trim().strip_suffix("kB")?;
            kib.trim().parse::<u64>().ok().map(|kib| kib * 1024)
        })
    };
    Some(Resident {
        now: bytes("VmRSS:")?,
        peak: bytes("VmHWM:")?,
    })
}

/// Starts a new peak at what is resident now (the kernel's high-water mark reset through
/// `/proc/self/clear_refs`); false where that cannot be done (then the peak stays the
/// process's).
pub fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Mebibytes, for messages.
pub fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1 << 20) as f64
}

/// Resident memory by phase: each phase's peak (the kernel's high-water mark, reset at its
/// start) and what the streamer's caches held at its end.
pub(crate) struct Phases {
    baseline: Option<u64>,
    phases: Vec<serde_json::Value>,
    streaming_peak: u64,
}

impl Phases {
    /// The first phase starts now, at what is resident now (the baseline).
    pub fn start() -> Self {
        reset_peak();
        Self {
            baseline: resident().map(|r| r.now),
            phases: Vec::new(),
            streaming_peak: 0,
        }
    }

    /// Ends the phase `name` (`counters`: a streaming one's, at its end) and starts the next.
    pub fn phase(&mut self, name: &str, counters: Option<&StreamCounters>) {
        let Some(resident) = resident() else {
            return;
        };
        if counters.is_some() {
            self.streaming_peak = self.streaming_peak.max(resident.peak);
        }
        self.phases.push(json!({
            "phase": name,
            "peak_bytes": resident.peak,
            "end_bytes": resident.now,
            "ram_cache_bytes": counters.map(|c| c.ram_bytes),
            "store_cache_bytes": counters.map(|c| c.source_cache_bytes),
        }));
        reset_peak();
    }

    /// The phases, and the streaming phases' peak above the baseline against the RAM budget.
    pub fn report(&self, ram_budget: u64) -> serde_json::Value {
        let over_baseline = self
            .baseline
            .map(|baseline| self.streaming_peak.saturating_sub(baseline));
        json!({
            "baseline_bytes": self.baseline,
            "ram_budget_bytes": ram_budget,
            "streaming_peak_bytes": self.streaming_peak,
            "streaming_peak_over_baseline_bytes": over_baseline,
            "phases": self.phases,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_rss_and_high_water_mark() {
        let status = "Name:\tvoxscope\nVmPeak:\t 900 kB\nVmHWM:\t  2048 kB\nVmRSS:\t  1024 kB\n";
        assert_eq!(
            parse_status(status),
            Some(Resident {
                now: 1 << 20,
                peak: 2 << 20
            })
        );
        assert_eq!(parse_status("VmRSS:\t1 kB\n"), None);
    }

    #[test]
    fn measures_this_process_on_linux() {
        if cfg!(target_os = "linux") {
            let before = resident().expect("/proc/self/status");
            assert!(before.now > 0 && before.peak >= before.now);
            // A peak that a reset brings back to about what is resident now.
            let held = vec![1u8; 64 << 20];
            std::hint::black_box(&held);
            drop(held);
            let grown = resident().expect("/proc/self/status").peak;
            assert!(grown >= before.now + (60 << 20), "{grown} {before:?}");
            assert!(reset_peak());
            let after = resident().expect("/proc/self/status");
            assert!(after.peak < grown, "{after:?} {grown}");
        }
    }
}
