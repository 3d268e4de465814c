//! Where an agent core lives: parked in its [`SharedCore`] handle while no server runs, and owned by the
//! server's event loop while one does, so the loop's turns take no lock at all. The library API
//! ([`crate::agent::Agent`]) acts on the core through [`SharedCore::with`]: at once on a parked core, or as
//! a job the loop runs at its next turn (the caller waits for the result), woken through the loop's
//! `mio::Waker`. One server at a time can own a core.

use std::fmt::{self, Debug};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use super::DynMiddleware;
use crate::core::AgentCore;

/// The core the shells run.
pub type Core<E> = AgentCore<E, DynMiddleware>;

/// Work the library API hands to the loop that owns the core.
pub type Job<E> = Box<dyn FnOnce(&mut Core<E>) + Send>;

/// A library API call with its result type.
type Call<E, R> = Box<dyn FnOnce(&mut Core<E>) -> R + Send>;

/// A core lent to a server's loop, with the jobs the library API sends it.
pub type Loan<E> = (Box<Core<E>>, Receiver<Job<E>>);

/// A handle on an agent core, cloned by the library API and the server that runs it.
pub struct SharedCore<E>(Arc<Mutex<Slot<E>>>);

enum Slot<E> {
    /// No server runs: the API acts on the core in place.
    Parked(Box<Core<E>>),
    /// A server's loop owns the core and takes jobs.
    Lent { jobs: Sender<Job<E>>, wake: Arc<dyn Fn() + Send + Sync> },
}

impl<E> Clone for SharedCore<E> {
    fn clone(&self) -> Self {
        Self(Arc::clone(&self.0))
    }
}

impl<E> Debug for SharedCore<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let state = match &*self.slot() {
            Slot::Parked(_) => "parked",
            Slot::Lent { .. } => "owned by a running server",
        };
        f.debug_tuple("SharedCore").field(&state).finish()
    }
}

/// The core is already owned by a running server.
#[derive(Debug, thiserror::Error)]
#[error("the agent core already runs in another server")]
pub struct CoreInUse;

impl<E> SharedCore<E> {
    fn slot(&self) -> MutexGuard<'_, Slot<E>> {
        // A panic elsewhere must not stop the agent: the slot is consistent between statements.
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl<E: Send + 'static> SharedCore<E> {
    /// A handle on `core`, parked.
    pub fn new(core: Core<E>) -> Self {
        Self(Arc::new(Mutex::new(Slot::Parked(Box::new(core)))))
    }

    /// Runs `f` on the core and returns its result: in place while no server runs, else in the running
    /// server's next turn (this call waits for it; never call it from inside a turn, e.g. from a
    /// middleware callback, which would wait for itself).
    pub fn with<R: Send + 'static>(&self, f: impl FnOnce(&mut Core<E>) -> R + Send + 'static) -> R {
        let mut job: Call<E, R> = Box::new(f);
        loop {
            let (jobs, wake) = match &mut *self.slot() {
                Slot::Parked(core) => return job(core),
                Slot::Lent { jobs, wake } => (jobs.clone(), Arc::clone(wake)),
            };
            let (result_tx, result_rx) = mpsc::sync_channel(1);
            let (back_tx, back_rx) = mpsc::channel();
            let carrier = JobCarrier { job: Some(job), back: back_tx };
            let sent = jobs.send(Box::new(move |core: &mut Core<E>| {
                let mut carrier = carrier;
                if let Some(job) = carrier.job.take() {
                    let _ = result_tx.send(job(core));
                }
            }));
            if sent.is_ok() {
                wake();
                if let Ok(result) = result_rx.recv() {
                    return result;
                }
            }
            // Not run: the loop stopped first, and dropping the job handed it back. Try again (parked now).
            drop(sent);
            match back_rx.recv() {
                Ok(back) => job = back,
                // It ran and panicked inside the loop (which survives it): the caller gets the panic.
                Err(_) => std::panic::resume_unwind(Box::new("an agent API call panicked inside the server's turn")),
            }
        }
    }

    /// Takes the core out for a server's loop, which runs the jobs it receives and wakes through `wake`;
    /// [`SharedCore::park`] gives it back.
    pub fn lend(&self, wake: Arc<dyn Fn() + Send + Sync>) -> Result<Loan<E>, CoreInUse> {
        let mut slot = self.slot();
        let (tx, rx) = mpsc::channel();
        match std::mem::replace(&mut *slot, Slot::Lent { jobs: tx, wake }) {
            Slot::Parked(core) => Ok((core, rx)),
            lent @ Slot::Lent { .. } => {
                *slot = lent;
                Err(CoreInUse)
            }
        }
    }

    /// Gives the core back when a server stops: runs the jobs still queued, then parks it.
    pub fn park(&self, mut core: Box<Core<E>>, jobs: Receiver<Job<E>>) {
        let mut slot = self.slot();
        while let Ok(job) = jobs.try_recv() {
            job(&mut core);
        }
        *slot = Slot::Parked(core);
        // Jobs sent after this (by a caller that read the slot before) come back to it unrun.
        drop(jobs);
    }
}

/// A job in flight to the loop; dropped unrun (the loop stopped), it hands the job back to its caller.
struct JobCarrier<J> {
    job: Option<J>,
    back: Sender<J>,
}

impl<J> Drop for JobCarrier<J> {
    fn drop(&mut self) {
        if let Some(job) = self.job.take() {
            let _ = self.back.send(job);
        }
    }
}
