//! The process's peak memory, for run reports (GUIDE §6: memory is reported for the large
//! cases), and the machine's available memory, to refuse runs that cannot fit.

/// The most resident memory this process has held so far, in bytes: the kernel's
/// high-water mark (`VmHWM` in `/proc/self/status`). `None` where the platform does not
/// tell (anything but Linux) or the file cannot be read.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    kib_field(&status, "VmHWM:")
}

/// The memory this process holds now, in bytes (`VmRSS` in `/proc/self/status`). `None`
/// where the platform does not tell.
pub fn resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    kib_field(&status, "VmRSS:")
}

/// The memory a new allocation can have without pushing anything out, in bytes: the
/// kernel's estimate of available memory plus free swap (`MemAvailable` and `SwapFree`
/// in `/proc/meminfo`). `None` where the platform does not tell.
pub fn available_bytes() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok()?;
    let swap = kib_field(&meminfo, "SwapFree:").unwrap_or(0);
    kib_field(&meminfo, "MemAvailable:")?.checked_add(swap)
}

/// The line of a `/proc` text that starts with `key`, in bytes (the kernel writes these in
/// kibibytes, `VmHWM:    12345 kB`).
fn kib_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find_map(|l| l.strip_prefix(key))?;
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
        assert_eq!(kib_field(status, "VmHWM:"), Some(51234 * 1024));
        for odd in [
            "Name:\tgeosynth\n",
            "VmHWM:\n",
            "VmHWM:\t12 MB\n",
            "VmHWM:\t-3 kB\n",
            "VmHWM:\tmany kB\n",
        ] {
            assert_eq!(kib_field(odd, "VmHWM:"), None, "{odd:?}");
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn the_machine_has_some_memory_available_and_less_than_it_has() {
        let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
        let total = kib_field(&meminfo, "MemTotal:").unwrap_or(0);
        let swap = kib_field(&meminfo, "SwapTotal:").unwrap_or(0);
        let available = available_bytes().unwrap_or(0);
        assert!(
            available > 0 && available <= total + swap,
            "{available} of {total} + {swap}"
        );
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn this_process_has_a_peak_at_least_its_current_memory() {
        let current = resident_bytes();
        match (peak_resident_bytes(), current) {
            (Some(peak), Some(now)) => assert!(peak >= now && now > 0, "{peak} vs {now}"),
            other => panic!("{other:?}"),
        }
    }
}
