//! Composable processing stages, run contexts, progress reporting and cancellation.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::{Error, Result};

/// One progress report: which stage, how far, out of how much (when known).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProgressUpdate<'a> {
    /// Name of the stage reporting.
    pub stage: &'a str,
    /// Units of work done so far.
    pub done: u64,
    /// Total units, when known.
    pub total: Option<u64>,
}

/// Receives progress reports. Implemented for every `FnMut(&ProgressUpdate)` closure.
pub trait Progress: Send {
    /// Called whenever a stage has advanced.
    fn update(&mut self, update: &ProgressUpdate<'_>);
}

impl<F: FnMut(&ProgressUpdate<'_>) + Send> Progress for F {
    fn update(&mut self, update: &ProgressUpdate<'_>) {
        self(update)
    }
}

/// A progress sink that ignores every report.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn update(&mut self, _update: &ProgressUpdate<'_>) {}
}

/// A shared flag that asks a running stage to stop; clone it to another thread and call
/// [`CancelFlag::cancel`]. Stages check it between units of work and return
/// [`Error::Cancelled`].
#[derive(Debug, Clone, Default)]
pub struct CancelFlag(Arc<AtomicBool>);

impl CancelFlag {
    /// A flag that is not set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Requests cancellation.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether cancellation was requested.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// What every stage gets besides its input: the seed, a progress sink, a cancel flag, and a
/// log of per-stage timings that run reports print.
pub struct RunContext {
    seed: u64,
    progress: Box<dyn Progress>,
    cancel: CancelFlag,
    timings: Vec<(String, Duration)>,
}

impl std::fmt::Debug for RunContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunContext")
            .field("seed", &self.seed)
            .field("cancelled", &self.cancel.is_cancelled())
            .field("timings", &self.timings)
            .finish()
    }
}

impl Default for RunContext {
    fn default() -> Self {
        Self::new(0)
    }
}

impl RunContext {
    /// A context with the given seed, no progress output and a fresh cancel flag.
    pub fn new(seed: u64) -> Self {
        Self {
            seed,
            progress: Box::new(NoProgress),
            cancel: CancelFlag::new(),
            timings: Vec::new(),
        }
    }

    /// Replaces the progress sink.
    pub fn with_progress(mut self, progress: impl Progress + 'static) -> Self {
        self.progress = Box::new(progress);
        self
    }

    /// Uses an existing cancel flag (so another thread can cancel this run).
    pub fn with_cancel_flag(mut self, cancel: CancelFlag) -> Self {
        self.cancel = cancel;
        self
    }

    /// The run's seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The cancel flag.
    pub fn cancel_flag(&self) -> &CancelFlag {
        &self.cancel
    }

    /// Sends a progress report.
    pub fn report(&mut self, stage: &str, done: u64, total: Option<u64>) {
        self.progress.update(&ProgressUpdate { stage, done, total });
    }

    /// `Err(Error::Cancelled)` once cancellation was requested.
    pub fn check_cancelled(&self) -> Result<()> {
        if self.cancel.is_cancelled() {
            Err(Error::Cancelled)
        } else {
            Ok(())
        }
    }

    /// Runs `work`, recording how long it took under `name`.
    pub fn timed<T>(&mut self, name: &str, work: impl FnOnce(&mut Self) -> T) -> T {
        let start = Instant::now();
        let out = work(self);
        self.record_timing(name, start.elapsed());
        out
    }

    /// Adds `elapsed` to the timing entry `name` (created on first use).
    pub fn record_timing(&mut self, name: &str, elapsed: Duration) {
        match self.timings.iter_mut().find(|(n, _)| n == name) {
            Some((_, total)) => *total += elapsed,
            None => self.timings.push((name.to_string(), elapsed)),
        }
    }

    /// Recorded timings, in first-use order.
    pub fn timings(&self) -> &[(String, Duration)] {
        &self.timings
    }
}

/// A typed processing step. Implement `run`; chain steps with [`Stage::then`].
///
/// ```
/// use pointset_core::{RunContext, Stage};
///
/// struct Double;
/// impl Stage for Double {
///     type Input = f64;
///     type Output = f64;
///     type Error = pointset_core::Error;
///     fn name(&self) -> &str { "double" }
///     fn run(&self, x: f64, _ctx: &mut RunContext) -> Result<f64, Self::Error> { Ok(2.0 * x) }
/// }
///
/// let pipeline = Double.then(Double);
/// assert_eq!(pipeline.run(1.5, &mut RunContext::new(0))?, 6.0);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub trait Stage {
    /// What the stage consumes.
    type Input;
    /// What the stage produces.
    type Output;
    /// The stage's error type.
    type Error: std::error::Error + Send + Sync + 'static;

    /// A short name for progress output and timing reports.
    fn name(&self) -> &str;

    /// Runs the stage.
    fn run(&self, input: Self::Input, ctx: &mut RunContext) -> Result<Self::Output, Self::Error>;

    /// This stage followed by `next`, which consumes this stage's output. The pipeline's
    /// error type is `next`'s, which must be convertible from this stage's.
    fn then<S>(self, next: S) -> Then<Self, S>
    where
        Self: Sized,
        S: Stage<Input = Self::Output>,
        S::Error: From<Self::Error>,
    {
        let name = format!("{} -> {}", self.name(), next.name());
        Then {
            first: self,
            second: next,
            name,
        }
    }

    /// This stage with its output passed through `f`: the adaptor between stages whose
    /// types do not meet, such as a synthesis whose output holds the points the next stage
    /// reads (`quilt.map(|out| out.points).then(reconstruct)`). The stage keeps its name;
    /// `f` cannot fail and is not timed apart.
    ///
    /// ```
    /// use pointset_core::{RunContext, Stage};
    ///
    /// struct Count;
    /// impl Stage for Count {
    ///     type Input = Vec<f32>;
    ///     type Output = (usize, Vec<f32>);
    ///     type Error = pointset_core::Error;
    ///     fn name(&self) -> &str { "count" }
    ///     fn run(&self, v: Vec<f32>, _ctx: &mut RunContext) -> Result<Self::Output, Self::Error> {
    ///         Ok((v.len(), v))
    ///     }
    /// }
    ///
    /// let lengths = Count.map(|(n, _)| n).run(vec![1.0, 2.0], &mut RunContext::new(0))?;
    /// assert_eq!(lengths, 2);
    /// Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    fn map<F, T>(self, f: F) -> Map<Self, F>
    where
        Self: Sized,
        F: Fn(Self::Output) -> T,
    {
        Map { stage: self, f }
    }
}

/// A stage whose output is passed through a function; made by [`Stage::map`].
#[derive(Clone)]
pub struct Map<A, F> {
    stage: A,
    f: F,
}

impl<A: std::fmt::Debug, F> std::fmt::Debug for Map<A, F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Map").field("stage", &self.stage).finish()
    }
}

impl<A, F, T> Stage for Map<A, F>
where
    A: Stage,
    F: Fn(A::Output) -> T,
{
    type Input = A::Input;
    type Output = T;
    type Error = A::Error;

    fn name(&self) -> &str {
        self.stage.name()
    }

    fn run(&self, input: A::Input, ctx: &mut RunContext) -> Result<T, A::Error> {
        self.stage.run(input, ctx).map(&self.f)
    }
}

/// Two stages run one after the other; made by [`Stage::then`]. Each stage's wall time is
/// recorded in the [`RunContext`] under the stage's name.
#[derive(Debug, Clone)]
pub struct Then<A, B> {
    first: A,
    second: B,
    name: String,
}

impl<A, B> Stage for Then<A, B>
where
    A: Stage,
    B: Stage<Input = A::Output>,
    B::Error: From<A::Error>,
{
    type Input = A::Input;
    type Output = B::Output;
    type Error = B::Error;

    fn name(&self) -> &str {
        &self.name
    }

    fn run(&self, input: A::Input, ctx: &mut RunContext) -> Result<B::Output, B::Error> {
        let start = Instant::now();
        let mid = self.first.run(input, ctx)?;
        ctx.record_timing(self.first.name(), start.elapsed());
        let start = Instant::now();
        let out = self.second.run(mid, ctx)?;
        ctx.record_timing(self.second.name(), start.elapsed());
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    struct AddOne;
    impl Stage for AddOne {
        type Input = u32;
        type Output = u32;
        type Error = Error;
        fn name(&self) -> &str {
            "add-one"
        }
        fn run(&self, x: u32, ctx: &mut RunContext) -> Result<u32> {
            ctx.check_cancelled()?;
            ctx.report("add-one", 1, Some(1));
            Ok(x + 1)
        }
    }

    #[test]
    fn then_composes_and_records_timings() {
        let seen = Arc::new(Mutex::new(0u32));
        let sink = Arc::clone(&seen);
        let mut ctx = RunContext::new(5).with_progress(move |u: &ProgressUpdate<'_>| {
            if let Ok(mut n) = sink.lock() {
                *n += u32::try_from(u.done).unwrap_or(0);
            }
        });
        let p = AddOne.then(AddOne).then(AddOne);
        assert_eq!(p.name(), "add-one -> add-one -> add-one");
        assert_eq!(p.run(1, &mut ctx).unwrap(), 4);
        assert_eq!(*seen.lock().unwrap(), 3);
        assert_eq!(ctx.timings().len(), 2);
        assert_eq!(ctx.seed(), 5);
    }

    #[test]
    fn map_adapts_an_output_between_stages() {
        let mut ctx = RunContext::new(0);
        let p = AddOne.map(|x| x * 10).then(AddOne).map(|x| x.to_string());
        assert_eq!(p.name(), "add-one -> add-one");
        assert_eq!(p.run(1, &mut ctx).unwrap(), "21");
        let flag = CancelFlag::new();
        let mut cancelled = RunContext::new(0).with_cancel_flag(flag.clone());
        flag.cancel();
        assert!(matches!(
            AddOne.map(|x| x + 1).run(1, &mut cancelled),
            Err(Error::Cancelled)
        ));
    }

    #[test]
    fn cancellation_stops_a_pipeline() {
        let flag = CancelFlag::new();
        let mut ctx = RunContext::new(0).with_cancel_flag(flag.clone());
        flag.cancel();
        assert!(matches!(
            AddOne.then(AddOne).run(1, &mut ctx),
            Err(Error::Cancelled)
        ));
    }
}
