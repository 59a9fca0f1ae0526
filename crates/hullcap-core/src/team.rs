//! A team of worker threads kept for a stretch of work that makes many parallel calls.
//!
//! [`for_each_chunk_mut`](crate::for_each_chunk_mut) starts its threads on
//! `std::thread::scope` and joins them on every call. A fit makes about nine such calls
//! per iteration and two hundred per frame, and on a 2-core machine starting and joining
//! a thread costs tens of microseconds, a large part of a fit. [`with_workers`]
//! starts the threads once, on one `std::thread::scope` around the whole stretch, and
//! every `for_each_chunk_mut` made on the calling thread inside it hands its chunks to
//! them instead: the same chunks, so the same results to the bit, each claimed by
//! whichever member is free, so that one whose core is busy elsewhere leaves its chunk to
//! the others instead of holding them up.
//!
//! Handing a chunk to a thread that outlives the call means passing it a borrow that the
//! type system cannot see ending before the thread does. That is the one place of the
//! engine that needs `unsafe` (see [`Team::run`] for why it is sound): the caller waits
//! for every worker to finish the job, panics included, before the borrow ends.

use crate::parallel::WorkerPanicked;
use std::cell::RefCell;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::thread::{self, Thread};

/// Spins before a waiting thread parks: a job usually follows the last one within
/// microseconds (the fit's serial steps between its parallel calls are short), and a
/// parked thread takes about 11 µs to wake on a 2-core machine against well under one
/// when it is still spinning. Short enough that a thread waiting for a longer pause
/// (a Python stage between fits) soon gives its core back.
const SPINS: usize = 2000;

thread_local! {
    /// The team of [`with_workers`] running on this thread, if any.
    static CURRENT: RefCell<Option<Arc<Team>>> = const { RefCell::new(None) };
}

/// Runs `body` with a team of `threads − 1` worker threads (the calling thread is the
/// last member), to which every [`for_each_chunk_mut`](crate::for_each_chunk_mut) call
/// of `body` on this thread hands its chunks instead of starting threads of its own.
/// With `threads` ≤ 1, or inside another `with_workers` on the same thread, `body` simply
/// runs.
pub fn with_workers<R>(threads: usize, body: impl FnOnce() -> R) -> R {
    if threads <= 1 || CURRENT.with(|c| c.borrow().is_some()) {
        return body();
    }
    let team = Arc::new(Team::new(threads - 1));
    thread::scope(|scope| {
        let handles: Vec<_> = (0..team.workers)
            .map(|_| {
                let team = Arc::clone(&team);
                scope.spawn(move || team.work())
            })
            .collect();
        // The threads are known before the first job is published.
        let _ = team
            .threads
            .set(handles.iter().map(|h| h.thread().clone()).collect());
        // Installed for `body`, and on the way out (a panic included) uninstalled and the
        // workers told to stop, so that the scope can join them.
        let _installed = Installed::new(Arc::clone(&team));
        body()
    })
}

/// The team running on this thread when it can take a call: it is not already running a
/// job (a chunk that itself makes a parallel call starts threads of its own).
pub(crate) fn available() -> Option<Arc<Team>> {
    CURRENT.with(|c| {
        c.borrow()
            .as_ref()
            .filter(|team| !team.busy.load(Ordering::Relaxed))
            .cloned()
    })
}

/// What [`with_workers`] keeps installed while its body runs.
struct Installed(Arc<Team>);

impl Installed {
    fn new(team: Arc<Team>) -> Self {
        CURRENT.with(|c| *c.borrow_mut() = Some(Arc::clone(&team)));
        Installed(team)
    }
}

impl Drop for Installed {
    fn drop(&mut self) {
        CURRENT.with(|c| *c.borrow_mut() = None);
        self.0.stop.store(true, Ordering::Release);
        for t in self.0.threads.get().into_iter().flatten() {
            t.unpark();
        }
    }
}

/// A job: chunk `k` of `chunks` is `run(k)`.
#[derive(Clone, Copy)]
struct Job {
    run: &'static (dyn Fn(usize) + Sync),
    chunks: usize,
}

/// The state the members of a team share.
pub(crate) struct Team {
    workers: usize,
    threads: OnceLock<Vec<Thread>>,
    /// The thread that publishes jobs (the one that called [`with_workers`]).
    caller: Thread,
    /// Bumped for every job; a worker looks for a job when it sees a generation it has not.
    generation: AtomicUsize,
    /// The job being run; `None` once its caller has claimed the last chunk, so that a
    /// worker that wakes late finds nothing to join.
    job: Mutex<Option<Job>>,
    /// The next chunk of the job to hand out.
    next: AtomicUsize,
    /// Workers that joined the job and have not yet finished with it.
    active: AtomicUsize,
    /// The first panic of a chunk in the current job.
    panicked: Mutex<Option<WorkerPanicked>>,
    busy: AtomicBool,
    stop: AtomicBool,
}

impl Team {
    fn new(workers: usize) -> Self {
        Team {
            workers,
            threads: OnceLock::new(),
            caller: thread::current(),
            generation: AtomicUsize::new(0),
            job: Mutex::new(None),
            next: AtomicUsize::new(0),
            active: AtomicUsize::new(0),
            panicked: Mutex::new(None),
            busy: AtomicBool::new(false),
            stop: AtomicBool::new(false),
        }
    }

    /// Runs `f(k)` once for every chunk `k` < `chunks`, each on whichever member claims it
    /// first, the calling thread among them; returns once all of them have finished, with
    /// the first panic among them. A member the system has not scheduled (its core busy
    /// with other work) leaves its chunks to the others instead of holding them all up.
    pub(crate) fn run(
        &self,
        chunks: usize,
        f: &(dyn Fn(usize) + Sync),
    ) -> Result<(), WorkerPanicked> {
        self.busy.store(true, Ordering::Relaxed);
        // SAFETY: the workers reach `f` only through `self.job`: a worker joins the job
        // (counted in `active`) while holding the job's lock and while the job is there,
        // and leaves it (uncounted) once it has claimed past the last chunk. This function
        // takes the job away under that lock once every chunk is claimed, so no worker
        // joins after that, and it does not return (nor unwind: the chunks run under
        // `catch_unwind`, and waiting cannot panic) before `active` is back to 0. So no
        // worker uses `f` after the borrow it came from ends; the `'static` only hides
        // that from the type of `Job`.
        #[allow(unsafe_code)]
        let run: &'static (dyn Fn(usize) + Sync) = unsafe { std::mem::transmute(f) };
        {
            let mut job = lock(&self.job);
            self.next.store(0, Ordering::Relaxed);
            *job = Some(Job { run, chunks });
        }
        self.generation.fetch_add(1, Ordering::AcqRel);
        for t in self.threads.get().into_iter().flatten() {
            t.unpark();
        }
        self.claim(chunks, f);
        *lock(&self.job) = None;
        wait(|| self.active.load(Ordering::Acquire) == 0);
        let panicked = lock(&self.panicked).take();
        self.busy.store(false, Ordering::Relaxed);
        panicked.map_or(Ok(()), Err)
    }

    /// Runs unclaimed chunks of a job of `chunks` chunks until none is left; a chunk's
    /// panic is kept (the first) and the next chunk claimed.
    fn claim(&self, chunks: usize, f: &(dyn Fn(usize) + Sync)) {
        loop {
            let k = self.next.fetch_add(1, Ordering::Relaxed);
            if k >= chunks {
                return;
            }
            if let Err(payload) = catch_unwind(AssertUnwindSafe(|| f(k))) {
                lock(&self.panicked).get_or_insert(WorkerPanicked::from_payload(payload.as_ref()));
            }
        }
    }

    /// A worker's loop: join each job published while it is there and claim its chunks,
    /// until told to stop.
    fn work(&self) {
        let mut seen = 0;
        loop {
            wait(|| {
                self.stop.load(Ordering::Acquire) || self.generation.load(Ordering::Acquire) != seen
            });
            if self.stop.load(Ordering::Acquire) {
                return;
            }
            seen = self.generation.load(Ordering::Acquire);
            let job = {
                let job = lock(&self.job);
                if job.is_some() {
                    self.active.fetch_add(1, Ordering::Relaxed);
                }
                *job
            };
            if let Some(job) = job {
                self.claim(job.chunks, job.run);
                if self.active.fetch_sub(1, Ordering::AcqRel) == 1 {
                    self.caller.unpark();
                }
            }
        }
    }
}

/// Waits until `done()`: spinning first, then parked (woken by an `unpark`, or every
/// millisecond to look again).
fn wait(done: impl Fn() -> bool) {
    for _ in 0..SPINS {
        if done() {
            return;
        }
        std::hint::spin_loop();
    }
    while !done() {
        thread::park_timeout(std::time::Duration::from_millis(1));
    }
}

/// The mutex's value; a panic never happens while one of these is held, so a poisoned
/// lock still holds a consistent value.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::for_each_chunk_mut;
    use std::collections::HashSet;
    use std::thread::ThreadId;

    /// Each item's index times `k`, and the thread that wrote it, by `for_each_chunk_mut`.
    fn fill(threads: usize, n: usize, k: usize) -> Result<Vec<(usize, ThreadId)>, WorkerPanicked> {
        let mut out = vec![(0, thread::current().id()); n];
        for_each_chunk_mut(&mut out, threads, 1, |offset, chunk| {
            for (i, slot) in chunk.iter_mut().enumerate() {
                *slot = ((offset + i) * k, thread::current().id());
            }
        })?;
        Ok(out)
    }

    #[test]
    fn a_team_gives_the_same_results_and_keeps_its_threads() {
        let calls = 200;
        let values = |runs: &[Vec<(usize, ThreadId)>]| -> Vec<Vec<usize>> {
            runs.iter()
                .map(|r| r.iter().map(|v| v.0).collect())
                .collect()
        };
        let ids = |runs: &[Vec<(usize, ThreadId)>]| -> HashSet<ThreadId> {
            runs.iter().flatten().map(|v| v.1).collect()
        };
        let alone: Vec<_> = (0..calls).map(|k| fill(3, 1000, k).unwrap()).collect();
        let teamed = with_workers(3, || {
            (0..calls)
                .map(|k| fill(3, 1000, k).unwrap())
                .collect::<Vec<_>>()
        });
        assert_eq!(values(&alone), values(&teamed));
        // Threads started for each call: the caller and two new ones per call.
        assert_eq!(ids(&alone).len(), 1 + 2 * calls);
        // The team's: the caller and at most its two workers (a worker that wakes after
        // the caller has claimed every chunk runs none), whatever the number of calls.
        assert!((1..=3).contains(&ids(&teamed).len()));
        assert!(ids(&teamed).contains(&thread::current().id()));
    }

    /// A member that has not started (here one whose thread never runs) leaves its chunk
    /// to the caller, which runs every chunk once and returns without it.
    #[test]
    fn a_member_that_has_not_started_leaves_its_chunk_to_the_others() {
        let team = Team::new(1);
        let runs: Vec<AtomicUsize> = (0..2).map(|_| AtomicUsize::new(0)).collect();
        team.run(2, &|k| {
            runs[k].fetch_add(1, Ordering::Relaxed);
        })
        .unwrap();
        let counts: Vec<usize> = runs.iter().map(|r| r.load(Ordering::Relaxed)).collect();
        assert_eq!(counts, [1, 1]);
        assert!(!team.busy.load(Ordering::Relaxed));
    }

    #[test]
    fn a_panic_in_any_chunk_is_returned_and_the_team_goes_on() {
        with_workers(2, || {
            for bad in [0, 999] {
                let mut out = vec![0usize; 1000];
                let err = for_each_chunk_mut(&mut out, 2, 1, |offset, chunk| {
                    for (i, v) in chunk.iter_mut().enumerate() {
                        assert!(offset + i != bad, "item {bad} is bad");
                        *v = offset + i;
                    }
                })
                .unwrap_err();
                assert!(err.0.contains(&format!("item {bad} is bad")), "{err}");
            }
            // The team still works after both.
            let out = fill(2, 10, 1).unwrap();
            assert_eq!(
                out.iter().map(|v| v.0).collect::<Vec<_>>(),
                (0..10).collect::<Vec<_>>()
            );
        });
    }

    #[test]
    fn calls_within_calls_and_teams_within_teams_just_run() {
        let total = with_workers(2, || {
            with_workers(2, || {
                let mut sums = vec![0usize; 4];
                for_each_chunk_mut(&mut sums, 2, 1, |offset, chunk| {
                    for (i, s) in chunk.iter_mut().enumerate() {
                        // A chunk's own parallel call, while the team is busy with this one.
                        *s = fill(2, 100, offset + i).unwrap().iter().map(|v| v.0).sum();
                    }
                })
                .unwrap();
                sums.iter().sum::<usize>()
            })
        });
        assert_eq!(total, (0..4).map(|k| k * 4950).sum::<usize>());
    }

    #[test]
    fn a_panic_of_the_body_stops_the_team_and_goes_on_up() {
        let caught = std::panic::catch_unwind(|| {
            with_workers(2, || {
                fill(2, 100, 1).unwrap();
                panic!("the body gave up");
            })
        });
        assert!(caught.is_err());
        // No team is left installed on this thread: a call starts its own threads again.
        let ids: HashSet<_> = (0..3)
            .flat_map(|k| fill(2, 100, k).unwrap())
            .map(|v| v.1)
            .collect();
        assert_eq!(ids.len(), 1 + 3);
    }
}
