//! An agent served over a custom transport (eProsima's `CustomAgent`, seed 004): the transport's pieces
//! ([`crate::transport::custom`]: the user's operations, endpoints, the reader thread and the loop side)
//! around an [`Agent`], which it builds, starts and stops.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use crate::agent::Agent;
use crate::core::CoreConfig;
use crate::middleware::MiddlewareKind;
use crate::transport::custom::{
    CustomAgentError, CustomAgentIo, CustomOptions, EndpointDesc, EndpointId, EndpointTable, Mode, Parts,
};

/// A running agent's threads.
struct Running {
    /// Gives the endpoint table back when the loop ends.
    server: JoinHandle<io::Result<EndpointTable>>,
    reader: JoinHandle<()>,
}

/// An agent on a custom transport (eProsima's `CustomAgent`): built stopped, configured through
/// [`Self::agent`] (refs, verbosity, middleware callbacks, clients made ahead), then [`Self::start`]ed.
/// It can be stopped and started again; dropping it stops it.
pub struct CustomAgent {
    name: String,
    desc: EndpointDesc,
    mode: Mode,
    options: CustomOptions,
    io: Arc<dyn CustomAgentIo>,
    agent: Agent<EndpointId>,
    stop: Arc<AtomicBool>,
    running: Option<Running>,
    /// The endpoints of the last run, kept for the next: the core keeps its clients across a restart.
    table: Option<EndpointTable>,
}

impl std::fmt::Debug for CustomAgent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CustomAgent")
            .field("name", &self.name)
            .field("endpoint", &self.desc)
            .field("mode", &self.mode)
            .field("running", &self.running.is_some())
            .finish_non_exhaustive()
    }
}

impl CustomAgent {
    /// eProsima's `CustomAgent(name, &endpoint, middleware_kind, framing, open, close, write, read)`: an
    /// agent on `middleware` with default core limits; `mode` takes eProsima's `framing` bool too.
    pub fn new(
        name: impl Into<String>,
        endpoint: EndpointDesc,
        middleware: MiddlewareKind,
        mode: impl Into<Mode>,
        io: impl CustomAgentIo,
    ) -> Result<Self, CustomAgentError> {
        Self::with_agent(name, endpoint, Agent::new(middleware, CoreConfig::default())?, mode, io)
    }

    /// As [`Self::new`], around an agent of the caller's (core limits, DDS options: [`Agent::with_dds`]).
    pub fn with_agent(
        name: impl Into<String>,
        endpoint: EndpointDesc,
        agent: Agent<EndpointId>,
        mode: impl Into<Mode>,
        io: impl CustomAgentIo,
    ) -> Result<Self, CustomAgentError> {
        let name = name.into();
        if let Err(source) = endpoint.validate() {
            return Err(CustomAgentError::Endpoint { name, source });
        }
        Ok(Self {
            name,
            desc: endpoint,
            mode: mode.into(),
            options: CustomOptions::default(),
            io: Arc::new(io),
            agent,
            stop: Arc::new(AtomicBool::new(false)),
            running: None,
            table: None,
        })
    }

    /// Replaces the limits and timing (applies from the next [`Self::start`]).
    #[must_use]
    pub fn with_options(mut self, options: CustomOptions) -> Self {
        self.options = options;
        self
    }

    /// The agent API (eProsima's `Agent` base class): `load_config_file`, `set_verbose_level`,
    /// `add_middleware_callback`, `create_client`, … Usable before and while it runs.
    pub fn agent(&self) -> &Agent<EndpointId> {
        &self.agent
    }

    /// The transport's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Framing on or off.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Whether it was started and not stopped since (its loop may have ended on an error: [`Self::stop`]
    /// reports it).
    pub fn is_running(&self) -> bool {
        self.running.is_some()
    }

    /// Setting this flag stops the agent (e.g. from a signal handler); [`Self::run`] then returns.
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        self.stop.clone()
    }

    /// eProsima's `start`: opens the transport and starts the reader thread and the event loop.
    pub fn start(&mut self) -> Result<(), CustomAgentError> {
        if self.running.is_some() {
            return Err(CustomAgentError::AlreadyRunning(self.name.clone()));
        }
        let name = self.name.clone();
        self.io.open().map_err(|source| CustomAgentError::Open { name: name.clone(), source })?;
        self.stop.store(false, Ordering::Relaxed);
        match self.spawn() {
            Ok(running) => {
                tracing::info!(transport = %name, mode = ?self.mode, "custom agent running");
                self.running = Some(running);
                Ok(())
            }
            Err(source) => {
                self.stop.store(true, Ordering::Relaxed);
                if let Err(e) = self.io.close() {
                    tracing::debug!(transport = %name, "close after a failed start: {e}");
                }
                Err(CustomAgentError::Io { name, source })
            }
        }
    }

    fn spawn(&mut self) -> io::Result<Running> {
        let table = self.table.take().unwrap_or_else(|| EndpointTable::new(self.options.max_endpoints));
        let parts = Parts { name: &self.name, desc: &self.desc, mode: self.mode, options: &self.options, io: &self.io };
        let (server, reader) = parts.serve(self.agent.core(), table, &self.stop)?;
        Ok(Running { server, reader })
    }

    /// Blocks until the stop flag is set or the loop ends on an error, then stops (eProsima's
    /// `AgentInstance::run`).
    pub fn run(&mut self) -> Result<(), CustomAgentError> {
        while !self.stop.load(Ordering::Relaxed) {
            if self.running.as_ref().is_none_or(|r| r.server.is_finished()) {
                break;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        self.stop()
    }

    /// eProsima's `stop`: ends the loop and the reader (within about [`CustomOptions::read_timeout`]), then
    /// closes the transport. The agent's clients and entities stay, for a later [`Self::start`].
    pub fn stop(&mut self) -> Result<(), CustomAgentError> {
        let Some(running) = self.running.take() else { return Ok(()) };
        self.stop.store(true, Ordering::Relaxed);
        let served = running.server.join();
        // The loop is gone, so is its side of the channel: a reader blocked on a full queue wakes up too.
        let _ = running.reader.join();
        let closed = self.io.close();
        tracing::info!(transport = %self.name, "custom agent stopped");
        let name = self.name.clone();
        match served {
            Ok(Ok(table)) => self.table = Some(table),
            Ok(Err(source)) => return Err(CustomAgentError::Io { name, source }),
            Err(_) => return Err(CustomAgentError::Io { name, source: io::Error::other("event loop panicked") }),
        }
        closed.map_err(|source| CustomAgentError::Close { name, source })
    }
}

impl Drop for CustomAgent {
    fn drop(&mut self) {
        if let Err(e) = self.stop() {
            tracing::warn!("{e}");
        }
    }
}
