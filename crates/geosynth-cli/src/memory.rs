//! The process's peak memory, for run reports (GUIDE §6: memory is reported for the large
//! cases).

/// The most resident memory this process has held so far, in bytes: the kernel's
/// high-water mark (`VmHWM` in `/proc/self/status`). `None` where the platform does not
/// tell (anything but Linux) or the file cannot be read.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    high_water_mark(&status)
}

/// The `VmHWM:` line of a `/proc/PID/status` text, in bytes (the kernel writes it in
/// kibibytes, `VmHWM:    12345 kB`).
fn high_water_mark(status: &str) -> Option<u64> {
    let line = status.lines().find_map(|l| l.strip_prefix("VmHWM:"))?;
    let mut words = line.split_whitespace();
    let kib: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => kib.checked_mul(1024),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_high_water_mark_is_read_in_bytes() {
        let status =
            "Name:\tgeosynth\nVmPeak:\t  900000 kB\nVmHWM:\t   51234 kB\nVmRSS:\t   40000 kB\n";
        assert_eq!(high_water_mark(status), Some(51234 * 1024));
        for odd in [
            "Name:\tgeosynth\n",
            "VmHWM:\n",
            "VmHWM:\t12 MB\n",
            "VmHWM:\t-3 kB\n",
            "VmHWM:\tmany kB\n",
        ] {
            assert_eq!(high_water_mark(odd), None, "{odd:?}");
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn this_process_has_a_peak_at_least_its_current_memory() {
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        let current: Option<u64> = status
            .lines()
            .find_map(|l| l.strip_prefix("VmRSS:"))
            .and_then(|l| l.split_whitespace().next()?.parse().ok());
        match (peak_resident_bytes(), current) {
            (Some(peak), Some(kib)) => assert!(peak >= kib * 1024, "{peak} vs {kib} kB"),
            other => panic!("{other:?} from {status}"),
        }
    }
}
