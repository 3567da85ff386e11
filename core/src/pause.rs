//! Pausing a render. While a [`PauseGate`] is closed, a pass's workers wait at their next
//! pixel; opened again, they go on where they stopped, so a paused render is the same, sample
//! for sample, as one never paused. The time spent paused is kept apart: a time budget and the
//! render's figures count rendering only.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

/// How often a worker waiting at a closed gate looks at its cancel flag.
const CANCEL_POLL: Duration = Duration::from_millis(20);

#[derive(Debug, Default)]
struct Clock {
    /// When the current pause began (None: not paused).
    since: Option<Instant>,
    /// Time paused before it, since the clock was last restarted.
    before: Duration,
}

/// Pause and resume for the passes of a render, shared between the thread that renders and
/// the one that controls it.
#[derive(Debug, Default)]
pub struct PauseGate {
    closed: AtomicBool,
    clock: Mutex<Clock>,
    cond: Condvar,
}

impl PauseGate {
    pub fn new() -> PauseGate {
        PauseGate::default()
    }

    fn clock(&self) -> std::sync::MutexGuard<'_, Clock> {
        self.clock.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Closes the gate (nothing if it is closed).
    pub fn pause(&self) {
        let mut c = self.clock();
        if c.since.is_none() {
            c.since = Some(Instant::now());
            self.closed.store(true, Ordering::SeqCst);
        }
    }

    /// Opens the gate, waking the workers waiting at it (nothing if it is open).
    pub fn resume(&self) {
        let mut c = self.clock();
        if let Some(t) = c.since.take() {
            c.before += t.elapsed();
            self.closed.store(false, Ordering::SeqCst);
            self.cond.notify_all();
        }
    }

    pub fn is_paused(&self) -> bool {
        self.closed.load(Ordering::SeqCst)
    }

    /// Time spent paused since the clock was last restarted, the pause under way included.
    pub fn paused_time(&self) -> Duration {
        let c = self.clock();
        c.before + c.since.map_or(Duration::ZERO, |t| t.elapsed())
    }

    /// Counts paused time from now on only (a pause under way counts from now).
    pub fn restart_clock(&self) {
        let mut c = self.clock();
        c.before = Duration::ZERO;
        if c.since.is_some() {
            c.since = Some(Instant::now());
        }
    }

    /// Waits while the gate is closed, until it opens or `cancel` is set; returns at once when
    /// it is open.
    #[inline]
    pub fn wait(&self, cancel: Option<&AtomicBool>) {
        if !self.is_paused() {
            return;
        }
        let mut c = self.clock();
        while c.since.is_some() && !cancel.is_some_and(|f| f.load(Ordering::SeqCst)) {
            c = self.cond.wait_timeout(c, CANCEL_POLL).unwrap_or_else(|e| e.into_inner()).0;
        }
    }

    /// Whether `deadline` has passed, not counting the time paused since the clock was
    /// restarted (the deadline moves on by every pause).
    #[inline]
    pub fn past(&self, deadline: Instant) -> bool {
        let now = Instant::now();
        now >= deadline && now >= deadline + self.paused_time()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// A worker at a closed gate waits until it opens, or until it is cancelled; the time
    /// paused is counted, and a deadline moves on by it.
    #[test]
    fn a_closed_gate_holds_workers_until_it_opens_or_they_are_cancelled() {
        let gate = Arc::new(PauseGate::new());
        gate.wait(None); // open: no wait
        gate.pause();
        assert!(gate.is_paused());
        let g = gate.clone();
        let t = Instant::now();
        let worker = std::thread::spawn(move || {
            g.wait(None);
            t.elapsed()
        });
        std::thread::sleep(Duration::from_millis(150));
        let deadline = Instant::now() - Duration::from_millis(100);
        assert!(!gate.past(deadline), "a deadline 100 ms ago, after 150 ms paused, is still ahead");
        gate.resume();
        let waited = worker.join().unwrap();
        assert!(waited >= Duration::from_millis(150), "{waited:?}");
        assert!(!gate.is_paused() && gate.paused_time() >= Duration::from_millis(150));
        gate.restart_clock();
        assert_eq!(gate.paused_time(), Duration::ZERO);
        assert!(gate.past(Instant::now()));
        // cancelled while paused: the worker leaves
        gate.pause();
        let cancel = Arc::new(AtomicBool::new(false));
        let (g, c) = (gate.clone(), cancel.clone());
        let worker = std::thread::spawn(move || g.wait(Some(&c)));
        std::thread::sleep(Duration::from_millis(50));
        cancel.store(true, Ordering::SeqCst);
        worker.join().unwrap();
        assert!(gate.is_paused());
    }
}
