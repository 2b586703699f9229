//! The timed phases of a command, for its report's `timings`, and the clock its report's
//! `wall_seconds` reads.
//!
//! A report's `timings` list the phases of the whole command, from reading its input to
//! writing its outputs: none lies inside another, so they add up to the time the command
//! spent in them, and what they leave out of `wall_seconds` is what no phase names (the
//! checks and notes between them).

use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Named durations in the order their names first ran (a stage's
/// [`geosynth::core::RunContext::timings`] has this form).
pub type Timings = Vec<(String, Duration)>;

/// The phase of reading a command's input file.
pub const READING: &str = "reading";
/// The phase of preparing a point set or mesh read for a stage: strays and isolated
/// points found, normals checked, faces turned to agree (stages it runs on the way, such as
/// fitting normals, are listed as phases of their own).
pub const PREPARING: &str = "preparing the input";
/// The phase of measuring a synthesis's quality against its exemplar.
pub const MEASURING: &str = "measuring quality";
/// The phase of writing a command's outputs.
pub const WRITING: &str = "writing";

/// When the command started ([`start_clock`]).
static STARTED: OnceLock<Instant> = OnceLock::new();

/// Starts the command's clock; `main` calls it first. Later calls change nothing.
pub fn start_clock() {
    STARTED.get_or_init(Instant::now);
}

/// Seconds since [`start_clock`]; `None` where it was never started.
pub fn wall_seconds() -> Option<f64> {
    STARTED.get().map(|started| started.elapsed().as_secs_f64())
}

/// Adds `elapsed` to the entry `name` of `timings` (appended on first use).
pub fn add(timings: &mut Timings, name: &str, elapsed: Duration) {
    match timings.iter_mut().find(|(n, _)| n == name) {
        Some((_, total)) => *total += elapsed,
        None => timings.push((name.to_string(), elapsed)),
    }
}

/// Adds each of `more` to `timings` ([`add`]): a name both hold adds up in its first place.
pub fn extend(timings: &mut Timings, more: &[(String, Duration)]) {
    for (name, elapsed) in more {
        add(timings, name, *elapsed);
    }
}

/// Runs `work`, adding its time to `timings` under `name`.
pub fn timed<T>(timings: &mut Timings, name: &str, work: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let out = work();
    add(timings, name, start.elapsed());
    out
}

/// Runs `work`, which may time phases of its own into `timings`, and adds under `name` the
/// time it took beyond theirs: so a reading that estimates normals on the way lists
/// "reading" and then "fitting normals", neither counted twice. A new `name` goes before
/// the phases `work` added, where it began.
pub fn timed_rest<T>(timings: &mut Timings, name: &str, work: impl FnOnce(&mut Timings) -> T) -> T {
    let (before, began) = (total(timings), timings.len());
    let start = Instant::now();
    let out = work(timings);
    let rest = start
        .elapsed()
        .saturating_sub(total(timings).saturating_sub(before));
    match timings.iter_mut().find(|(n, _)| n == name) {
        Some((_, total)) => *total += rest,
        None => timings.insert(began, (name.to_string(), rest)),
    }
    out
}

fn total(timings: &Timings) -> Duration {
    timings.iter().map(|(_, d)| *d).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inner_phases_are_not_counted_twice() {
        let mut timings = Timings::new();
        let outer = Instant::now();
        let value = timed_rest(&mut timings, "reading", |timings| {
            std::thread::sleep(Duration::from_millis(20));
            timed(timings, "fitting normals", || {
                std::thread::sleep(Duration::from_millis(30));
                7
            })
        });
        let spent = outer.elapsed();
        assert_eq!(value, 7);
        let names: Vec<&str> = timings.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["reading", "fitting normals"]);
        // The two phases tile the call: together no longer than it, each at least its sleep.
        let [(_, reading), (_, fitting)] = [&timings[0], &timings[1]];
        assert!(*reading + *fitting <= spent, "{timings:?} in {spent:?}");
        assert!(*fitting >= Duration::from_millis(30), "{timings:?}");
        assert!(*reading >= Duration::from_millis(20), "{timings:?}");
    }

    #[test]
    fn a_name_used_twice_adds_up_in_its_first_place() {
        let mut timings = Timings::new();
        add(&mut timings, "writing", Duration::from_millis(5));
        add(&mut timings, "measuring", Duration::from_millis(1));
        add(&mut timings, "writing", Duration::from_millis(7));
        assert_eq!(
            timings,
            [
                ("writing".to_string(), Duration::from_millis(12)),
                ("measuring".to_string(), Duration::from_millis(1)),
            ]
        );
    }

    #[test]
    fn the_clock_counts_from_its_first_start() {
        start_clock();
        let first = wall_seconds().unwrap_or(-1.0);
        start_clock();
        std::thread::sleep(Duration::from_millis(5));
        let second = wall_seconds().unwrap_or(-1.0);
        assert!(first >= 0.0 && second >= first + 0.005, "{first} {second}");
    }
}
