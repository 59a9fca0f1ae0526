//! Data-parallel loops on `std::thread::scope`.
//!
//! Work is split into one contiguous chunk per thread; each thread gets a disjoint
//! `&mut` slice of the output, so no locks are needed. Threads are joined explicitly, and
//! a panic in any of them is returned as [`WorkerPanicked`] instead of being re-raised.
//! Inside [`with_workers`](crate::with_workers) the chunks go to its team of threads
//! instead of threads started for the call, each claimed by whichever member is free
//! (`team.rs`).

use std::num::NonZeroUsize;
use std::sync::{Mutex, OnceLock};
use std::thread;

/// A worker thread panicked; the message is the panic's payload when it was a string.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("an engine worker thread panicked: {0}")]
pub struct WorkerPanicked(pub String);

/// The environment variable that caps the engine's threads when a call does not say how
/// many (a batch worker given one core sets it to 1, docs/batch.md).
const THREADS_VARIABLE: &str = "HULLCAP_THREADS";

/// The most threads the engine starts for one call, whatever is asked: more than the
/// cores only share them, and a count of millions would take minutes to start.
pub const MAX_THREADS: usize = 256;

/// The number of threads to use: `requested` when given and non-zero, else the positive
/// whole number in [`THREADS_VARIABLE`] when it holds one, else every core
/// `std::thread::available_parallelism` reports (1 if it cannot tell); at most
/// [`MAX_THREADS`]. The results of the engine do not depend on it, only its speed.
pub fn resolve_threads(requested: Option<usize>) -> usize {
    let from_environment = std::env::var(THREADS_VARIABLE).ok();
    choose_threads(requested, from_environment.as_deref(), cores)
}

/// The cores `std::thread::available_parallelism` reports, asked once per process: on
/// Linux it opens and reads three cgroup files on every call (about 24 µs here), and a
/// tracked frame resolves its threads about 26 times. A process that narrows its own
/// affinity afterwards says so in [`THREADS_VARIABLE`], which is read on every call.
fn cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| thread::available_parallelism().map_or(1, NonZeroUsize::get))
}

fn choose_threads(
    requested: Option<usize>,
    from_environment: Option<&str>,
    cores: impl FnOnce() -> usize,
) -> usize {
    let chosen = match (
        requested,
        from_environment.and_then(|v| v.trim().parse::<usize>().ok()),
    ) {
        (Some(n), _) if n > 0 => n,
        (_, Some(n)) if n > 0 => n,
        _ => cores(),
    };
    chosen.min(MAX_THREADS)
}

/// Calls `f(offset, chunk)` on contiguous chunks of `out` from up to `threads` threads,
/// where `offset` is the index of `chunk[0]` in `out`.
///
/// Chunks are never smaller than `min_chunk` items (so tiny inputs run on the calling
/// thread, without spawning). Returns an error if a worker panicked; the other chunks are
/// then complete but the panicking one may be partly written.
///
/// ```
/// let mut squares = vec![0usize; 1000];
/// hullcap_core::for_each_chunk_mut(&mut squares, 4, 64, |offset, chunk| {
///     for (i, s) in chunk.iter_mut().enumerate() {
///         *s = (offset + i) * (offset + i);
///     }
/// })
/// .unwrap();
/// assert_eq!(squares[999], 999 * 999);
/// ```
pub fn for_each_chunk_mut<T, F>(
    out: &mut [T],
    threads: usize,
    min_chunk: usize,
    f: F,
) -> Result<(), WorkerPanicked>
where
    T: Send,
    F: Fn(usize, &mut [T]) + Sync,
{
    let n = out.len();
    let max_chunks = n.div_ceil(min_chunk.max(1));
    let chunks = threads.max(1).min(max_chunks);
    if chunks <= 1 {
        return run_caught(|| f(0, out));
    }
    let chunk_len = n.div_ceil(chunks);
    if let Some(team) = crate::team::available() {
        // The same chunks, each claimed by whichever member of the team is free: a member
        // the system has not yet scheduled (its core busy with another thread, reading
        // the next frame) leaves its chunk to the others instead of holding up the call.
        let slots: Vec<Mutex<Option<&mut [T]>>> = out
            .chunks_mut(chunk_len)
            .map(|c| Mutex::new(Some(c)))
            .collect();
        let job = |k: usize| {
            let chunk = slots[k].lock().unwrap_or_else(|e| e.into_inner()).take();
            if let Some(chunk) = chunk {
                f(k * chunk_len, chunk);
            }
        };
        return team.run(slots.len(), &job);
    }
    thread::scope(|scope| {
        let f = &f;
        let (first, rest) = out.split_at_mut(chunk_len);
        let handles: Vec<_> = rest
            .chunks_mut(chunk_len)
            .enumerate()
            .map(|(i, chunk)| scope.spawn(move || f((i + 1) * chunk_len, chunk)))
            .collect();
        // The calling thread takes the first chunk itself: one thread fewer to start
        // and to wait for on every call (the fit makes several calls per iteration).
        let mut first_panic = run_caught(|| f(0, first)).err();
        // Join every handle before reporting, so no thread outlives the error.
        for handle in handles {
            if let Err(payload) = handle.join() {
                first_panic.get_or_insert(WorkerPanicked::from_payload(payload.as_ref()));
            }
        }
        first_panic.map_or(Ok(()), Err)
    })
}

/// Runs `f` on the calling thread, turning a panic into [`WorkerPanicked`].
fn run_caught(f: impl FnOnce()) -> Result<(), WorkerPanicked> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f))
        .map_err(|payload| WorkerPanicked::from_payload(payload.as_ref()))
}

impl WorkerPanicked {
    /// The error for a thread's panic payload (as `JoinHandle::join` or `catch_unwind`
    /// return it), its message when the payload is a string.
    pub fn from_payload(payload: &(dyn std::any::Any + Send)) -> Self {
        let message = if let Some(s) = payload.downcast_ref::<&str>() {
            (*s).to_owned()
        } else if let Some(s) = payload.downcast_ref::<String>() {
            s.clone()
        } else {
            "(no message)".to_owned()
        };
        WorkerPanicked(message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_is_visited_once_with_its_offset() {
        for n in [0, 1, 7, 64, 65, 1000, 1001] {
            for threads in [1, 2, 3, 8] {
                let mut out = vec![usize::MAX; n];
                for_each_chunk_mut(&mut out, threads, 16, |offset, chunk| {
                    for (i, x) in chunk.iter_mut().enumerate() {
                        *x = offset + i;
                    }
                })
                .unwrap();
                assert!(
                    out.iter().enumerate().all(|(i, &x)| x == i),
                    "n={n} t={threads}"
                );
            }
        }
    }

    #[test]
    fn a_panicking_worker_becomes_an_error() {
        let mut out = vec![0u8; 10_000];
        let err = for_each_chunk_mut(&mut out, 4, 1, |offset, _| {
            if offset > 0 {
                panic!("boom at {offset}");
            }
        })
        .unwrap_err();
        assert!(err.0.starts_with("boom at"), "{err}");
        // The calling thread's own chunk too, the other chunks still done.
        let err = for_each_chunk_mut(&mut out, 4, 1, |offset, chunk| {
            if offset == 0 {
                panic!("first");
            }
            chunk.fill(1);
        })
        .unwrap_err();
        assert_eq!(err.0, "first");
        assert!(out[out.len() / 4..].iter().all(|&x| x == 1));
        // Also on the calling thread (a single chunk).
        let err = for_each_chunk_mut(&mut out, 1, 1, |_, _| panic!("inline")).unwrap_err();
        assert_eq!(err.0, "inline");
    }

    #[test]
    fn zero_requested_threads_means_all_cores() {
        assert!(resolve_threads(None) >= 1);
        assert_eq!(resolve_threads(Some(0)), resolve_threads(None));
        assert_eq!(resolve_threads(Some(3)), 3);
    }

    #[test]
    fn the_environment_caps_threads_a_call_leaves_open() {
        let cores = || 8;
        assert_eq!(choose_threads(None, Some("2"), cores), 2);
        assert_eq!(choose_threads(Some(0), Some(" 3 "), cores), 3);
        assert_eq!(choose_threads(Some(5), Some("2"), cores), 5);
        for ignored in [None, Some("0"), Some("many"), Some("-1"), Some("")] {
            assert_eq!(choose_threads(None, ignored, cores), 8, "{ignored:?}");
        }
    }

    #[test]
    fn no_call_starts_more_than_the_most_threads() {
        let many = || 100_000;
        assert_eq!(choose_threads(Some(1_000_000), None, many), MAX_THREADS);
        assert_eq!(choose_threads(None, Some("1000000"), many), MAX_THREADS);
        assert_eq!(choose_threads(None, None, many), MAX_THREADS);
    }
}
