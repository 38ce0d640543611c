//! The process's resident memory, for the figures `render` and `bench --stream` give: what it
//! holds now and the most it held since the last [`reset_peak`] (Linux's `VmRSS` and `VmHWM`;
//! elsewhere nothing is measured and the figures are left out).

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
