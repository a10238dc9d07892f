//! The cancellation token and the monitor: clones share the flag, a cancel from another
//! thread stops a polling loop, a sink that cancels stops the computation at its report.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use stiffness_core::{Cancel, Cancelled, Monitor, Progress};

#[test]
fn a_new_token_is_not_cancelled_and_clones_share_the_flag() {
    let a = Cancel::new();
    let b = a.clone();
    assert!(!a.is_cancelled());
    assert_eq!(a.check(), Ok(()));
    b.cancel();
    assert!(a.is_cancelled());
    assert_eq!(a.check(), Err(Cancelled));
    // An unrelated token is unaffected.
    assert_eq!(Cancel::new().check(), Ok(()));
}

#[test]
fn a_cancel_from_another_thread_stops_a_polling_loop() {
    let cancel = Cancel::new();
    let monitor = Monitor::new(cancel.clone());
    let start = Instant::now();
    let result = std::thread::scope(|s| {
        s.spawn(|| {
            std::thread::sleep(Duration::from_millis(50));
            cancel.cancel();
        });
        // Without the token this loop would run for an hour.
        let mut steps = 0u64;
        loop {
            monitor.check()?;
            steps += 1;
            if start.elapsed() > Duration::from_secs(3600) {
                return Ok::<u64, Cancelled>(steps);
            }
            std::hint::spin_loop();
        }
    });
    assert_eq!(result, Err(Cancelled));
    assert!(start.elapsed() < Duration::from_secs(5));
}

#[test]
fn report_calls_the_sink_then_honours_a_cancel_made_by_the_sink() {
    let cancel = Cancel::new();
    let seen = Mutex::new(Vec::new());
    let sink_cancel = cancel.clone();
    let sink = move |p: Progress| {
        seen.lock().unwrap().push(p);
        if p.done == 3 {
            sink_cancel.cancel();
        }
    };
    let monitor = Monitor::new(cancel).with_progress(&sink);
    let mut completed = 0;
    let result = (1..=10).try_for_each(|done| {
        monitor.report(Progress {
            stage: "step",
            done,
            total: 10,
        })?;
        completed = done;
        Ok::<(), Cancelled>(())
    });
    assert_eq!(result, Err(Cancelled));
    assert_eq!(
        completed, 2,
        "the step whose report cancelled must not count as completed"
    );
}

#[test]
fn a_monitor_is_shared_by_parallel_workers() {
    let calls = AtomicUsize::new(0);
    let sink = |_: Progress| {
        calls.fetch_add(1, Ordering::Relaxed);
    };
    let monitor = Monitor::none().with_progress(&sink);
    std::thread::scope(|s| {
        for w in 0..4 {
            let m = &monitor;
            s.spawn(move || {
                for done in 1..=25 {
                    m.report(Progress {
                        stage: "chunk",
                        done: w * 25 + done,
                        total: 100,
                    })
                    .unwrap();
                }
            });
        }
    });
    assert_eq!(calls.load(Ordering::Relaxed), 100);
    assert_eq!(monitor.check(), Ok(()));
}

#[test]
fn cancelled_reads_as_a_plain_word() {
    assert_eq!(Cancelled.to_string(), "cancelled");
    assert!(format!("{:?}", Cancel::new()).contains("cancelled: false"));
}
