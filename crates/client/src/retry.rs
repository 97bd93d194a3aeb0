//! How long the app keeps trying when the service does not answer.

use crate::error::ClientError;
use std::time::{Duration, Instant};

/// Retry policy for transient failures ([`ClientError::is_transient`]):
/// waits `first_wait`, doubling up to `max_wait`, and gives up once
/// `give_up_after` has passed since the first failure of an operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Retry {
    /// Wait after the first failure.
    pub first_wait: Duration,
    /// Longest wait between two attempts.
    pub max_wait: Duration,
    /// Give up this long after the first failure.
    pub give_up_after: Duration,
}

impl Default for Retry {
    /// 20 ms, doubling up to 1 s, for at most 60 s.
    fn default() -> Self {
        Self {
            first_wait: Duration::from_millis(20),
            max_wait: Duration::from_secs(1),
            give_up_after: Duration::from_secs(60),
        }
    }
}

impl Retry {
    /// Never retry: the first failure is returned.
    pub fn never() -> Self {
        Self {
            first_wait: Duration::ZERO,
            max_wait: Duration::ZERO,
            give_up_after: Duration::ZERO,
        }
    }

    /// Runs `op` until it succeeds, fails for good, or the policy gives up.
    /// Returns the value and how many transient failures came before it.
    pub fn run<T>(
        &self,
        mut op: impl FnMut() -> Result<T, ClientError>,
    ) -> Result<(T, u32), ClientError> {
        let mut b = Backoff::new(*self);
        loop {
            match op() {
                Ok(v) => return Ok((v, b.failures)),
                Err(e) => b.failed(e)?,
            }
        }
    }
}

/// The state of one operation's retries.
#[derive(Debug)]
pub(crate) struct Backoff {
    retry: Retry,
    first_failure: Option<Instant>,
    wait: Duration,
    /// Transient failures so far.
    pub(crate) failures: u32,
}

impl Backoff {
    pub(crate) fn new(retry: Retry) -> Self {
        Self {
            retry,
            first_failure: None,
            wait: retry.first_wait,
            failures: 0,
        }
    }

    /// Records a failure: returns it when it is not transient or the
    /// policy gives up; else sleeps before the next attempt.
    pub(crate) fn failed(&mut self, e: ClientError) -> Result<(), ClientError> {
        if !e.is_transient() {
            return Err(e);
        }
        self.failures += 1;
        let first = *self.first_failure.get_or_insert_with(Instant::now);
        let waited = first.elapsed();
        if waited >= self.retry.give_up_after {
            return Err(ClientError::GaveUp {
                attempts: self.failures,
                waited_ms: waited.as_millis() as u64,
                last: Box::new(e),
            });
        }
        // The service's Retry-After is a floor (it knows when it is busy),
        // never past the point of giving up.
        let wait = match e.retry_after() {
            Some(ra) => ra
                .max(self.wait)
                .min(self.retry.give_up_after.saturating_sub(waited)),
            None => self.wait,
        };
        std::thread::sleep(wait);
        self.wait = (self.wait * 2).min(self.retry.max_wait);
        Ok(())
    }
}
