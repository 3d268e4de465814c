//! Read tasks: what a READ_DATA started (spec §15.2), with its DataDeliveryControl honoured completely —
//! including `min_pace_period`, which eProsima ignores.

use std::time::{Duration, Instant};

use xrce_proto::submessage::{DataDeliveryControl, ReadSpecification};
use xrce_proto::{BaseObjectRequest, StreamId};

/// An active delivery for one reader/requester/replier.
#[derive(Debug, Clone)]
pub struct ReadTask {
    /// The READ_DATA's request id and object, echoed in every DATA.
    pub request: BaseObjectRequest,
    /// Stream the DATA travels on.
    pub stream: StreamId,
    /// Samples still to deliver; `None` is unlimited.
    pub remaining: Option<u32>,
    /// End of the task (`max_elapsed_time`).
    pub deadline: Option<Instant>,
    /// `max_bytes_per_second` token bucket.
    pub bucket: Option<TokenBucket>,
    /// `min_pace_period`.
    pub pace: Option<Duration>,
    /// No sample before this instant (pace).
    pub not_before: Option<Instant>,
}

/// What a READ_DATA asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadRequest {
    /// Stop the current task (C client's cancel: stream 0 and an all-zero control, or `max_samples` 0).
    Cancel,
    /// Start a task.
    Start,
}

impl ReadTask {
    /// The task a READ_DATA describes, or a cancel.
    pub fn from_spec(request: BaseObjectRequest, spec: &ReadSpecification<'_>, now: Instant) -> (ReadRequest, Self) {
        let control = spec.delivery_control;
        let mut task = Self {
            request,
            stream: StreamId(spec.preferred_stream_id),
            remaining: Some(1),
            deadline: None,
            bucket: None,
            pace: None,
            not_before: None,
        };
        let Some(c) = control else { return (ReadRequest::Start, task) };
        if c == DataDeliveryControl::default() || c.max_samples == 0 {
            return (ReadRequest::Cancel, task);
        }
        task.remaining = (c.max_samples != DataDeliveryControl::UNLIMITED).then_some(u32::from(c.max_samples));
        task.deadline = (c.max_elapsed_time != 0).then(|| now + Duration::from_secs(u64::from(c.max_elapsed_time)));
        task.bucket = (c.max_bytes_per_second != 0).then(|| TokenBucket::new(u32::from(c.max_bytes_per_second), now));
        task.pace = (c.min_pace_period != 0).then(|| Duration::from_millis(u64::from(c.min_pace_period)));
        (ReadRequest::Start, task)
    }

    /// Whether the task has ended at `now`.
    pub fn finished(&self, now: Instant) -> bool {
        self.remaining == Some(0) || self.deadline.is_some_and(|d| now >= d)
    }

    /// Whether a sample of `size` bytes may go now; if not, when to try again (None: on new data only).
    pub fn ready(&mut self, size: usize, now: Instant) -> Result<(), Option<Instant>> {
        if let Some(t) = self.not_before {
            if now < t {
                return Err(Some(t));
            }
        }
        if let Some(bucket) = &mut self.bucket {
            bucket.refill(now);
            if let Err(at) = bucket.check(size, now) {
                return Err(Some(at));
            }
        }
        Ok(())
    }

    /// Accounts for a sample of `size` bytes sent at `now`.
    pub fn sent(&mut self, size: usize, now: Instant) {
        if let Some(r) = &mut self.remaining {
            *r = r.saturating_sub(1);
        }
        if let Some(bucket) = &mut self.bucket {
            bucket.charge(size);
        }
        self.not_before = self.pace.map(|p| now + p);
    }

    /// Forgets timers that have expired, so [`Self::wake_at`] never reports an instant in the past.
    pub fn expire_timers(&mut self, now: Instant) {
        if self.not_before.is_some_and(|t| t <= now) {
            self.not_before = None;
        }
        if let Some(b) = &mut self.bucket {
            if b.wake_at.is_some_and(|t| t <= now) {
                b.wake_at = None;
            }
        }
    }

    /// When this task next wants to run, if it waits for time rather than data.
    pub fn wake_at(&self) -> Option<Instant> {
        let bucket = self.bucket.as_ref().and_then(|b| b.wake_at);
        [self.not_before, bucket].into_iter().flatten().min()
    }
}

/// Token bucket with rate = capacity = bytes per second. A sample bigger than the capacity goes when the
/// bucket is full and leaves it in debt (eProsima never delivers it: its task retries forever).
#[derive(Debug, Clone)]
pub struct TokenBucket {
    rate: u32,
    tokens: i64,
    last: Instant,
    /// When enough tokens for the last refused sample will be there.
    pub wake_at: Option<Instant>,
}

impl TokenBucket {
    /// A full bucket.
    pub fn new(rate: u32, now: Instant) -> Self {
        Self { rate, tokens: i64::from(rate), last: now, wake_at: None }
    }

    fn refill(&mut self, now: Instant) {
        let elapsed = now.saturating_duration_since(self.last);
        let add = elapsed.as_micros().saturating_mul(u128::from(self.rate)) / 1_000_000;
        if add > 0 {
            let add = i64::try_from(add).unwrap_or(i64::MAX);
            self.tokens = self.tokens.saturating_add(add).min(i64::from(self.rate));
            self.last = now;
        }
    }

    fn check(&mut self, size: usize, now: Instant) -> Result<(), Instant> {
        let need = i64::try_from(size).unwrap_or(i64::MAX).min(i64::from(self.rate));
        if self.tokens >= need {
            self.wake_at = None;
            return Ok(());
        }
        let missing = u64::try_from(need - self.tokens).unwrap_or(0);
        let micros = missing.saturating_mul(1_000_000) / u64::from(self.rate.max(1)) + 1;
        let at = now + Duration::from_micros(micros);
        self.wake_at = Some(at);
        Err(at)
    }

    fn charge(&mut self, size: usize) {
        self.tokens = self.tokens.saturating_sub(i64::try_from(size).unwrap_or(i64::MAX));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use xrce_proto::{ObjectId, RequestId};

    fn spec(c: Option<DataDeliveryControl>) -> ReadSpecification<'static> {
        ReadSpecification {
            preferred_stream_id: 0x80,
            data_format: 0,
            content_filter_expression: None,
            delivery_control: c,
        }
    }

    #[test]
    fn controls_map_to_tasks() {
        let now = Instant::now();
        let req = BaseObjectRequest { request_id: RequestId(5), object_id: ObjectId::from_raw(0x16) };
        let (kind, t) = ReadTask::from_spec(req, &spec(None), now);
        assert_eq!((kind, t.remaining), (ReadRequest::Start, Some(1)));
        let unlimited = DataDeliveryControl { max_samples: 0xFFFF, ..Default::default() };
        let (_, t) = ReadTask::from_spec(req, &spec(Some(unlimited)), now);
        assert_eq!(t.remaining, None);
        let (kind, _) = ReadTask::from_spec(req, &spec(Some(DataDeliveryControl::default())), now);
        assert_eq!(kind, ReadRequest::Cancel);
    }

    #[test]
    fn bucket_limits_rate_and_pace_spaces_samples() {
        let now = Instant::now();
        let req = BaseObjectRequest::default();
        let c = DataDeliveryControl {
            max_samples: 0xFFFF,
            max_bytes_per_second: 100,
            min_pace_period: 10,
            ..Default::default()
        };
        let (_, mut t) = ReadTask::from_spec(req, &spec(Some(c)), now);
        assert!(t.ready(60, now).is_ok());
        t.sent(60, now);
        assert!(t.ready(60, now).is_err());
        let later = now + Duration::from_millis(20);
        assert!(t.ready(60, later).is_err(), "only 42 tokens after 20 ms");
        assert!(t.ready(60, now + Duration::from_millis(300)).is_ok());
    }
}
