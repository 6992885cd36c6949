//! Independent trials on worker threads, each a pure function of its index: results come back
//! in index order, so they equal a serial run's whatever the thread count.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// `f` of `0..count` on up to `threads` threads (default: the cores), in order; `done` runs
/// after each. The first error stops handing out indices and is returned.
pub fn on_threads<T: Send>(
    count: usize,
    threads: Option<usize>,
    done: impl Fn() + Sync,
    f: impl Fn(usize) -> Result<T, String> + Sync,
) -> Result<Vec<T>, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = threads.unwrap_or(cores).clamp(1, count.max(1));
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<T, String>>>> =
        Mutex::new((0..count).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= count {
                        break;
                    }
                    let result = f(i);
                    let failed = result.is_err();
                    if let Ok(mut all) = results.lock() {
                        all[i] = Some(result);
                    }
                    done();
                    if failed {
                        next.store(count, Ordering::Relaxed);
                    }
                }
            });
        }
    });
    let results = results.into_inner().map_err(|_| "a worker thread panicked".to_string())?;
    results
        .into_iter()
        .enumerate()
        .map(|(i, r)| r.unwrap_or_else(|| Err(format!("trial {i} did not run"))))
        .collect()
}
