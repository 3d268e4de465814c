//! The `MicroXRCEAgent`-compatible command line.
//!
//! The agent must be a drop-in replacement for eProsima's `MicroXRCEAgent`, so scripts, launch files and
//! service units written for it have to keep working: the first argument names the transport
//! (`udp4 udp6 tcp4 tcp6 serial multiserial pseudoterminal canfd`), every option keeps eProsima's short and
//! long spelling, meaning and default, and short options accept attached values (`-v6`, `-p8888`).
//!
//! Facts taken from eProsima's agent (v2.x/v3.x argument parser), which this module reproduces:
//! * `-v/--verbose` defaults to level 4 (info) even when absent; a bare `-v` also means 4; 0..=6 only.
//! * `-d/--discovery` is off unless given; a bare `-d` listens on port 7400.
//! * `-P/--p2p` needs a port (we parse it, hidden, and refuse it: P2P is not supported); `-p/--port` is
//!   mandatory for the IP transports.
//! * `-m/--middleware` is one of `ced`, `dds`, `rtps`, default `dds`.
//! * `-r/--refs` must name an existing file (checked while parsing, as eProsima does).
//! * `-b/--baudrate` defaults to 115200; non-standard numeric rates (250000, ...) are accepted, as eProsima
//!   does, and set on Linux through termios2.
//! * `serial` takes its device from `-D/--dev`, or from the first line of the file given with `-f/--file`;
//!   `multiserial` takes a space-separated list in one `-D/--devs` argument, or one device per line of
//!   `-f/--file`. The two sources are mutually exclusive and one is required. `-f` is this device file,
//!   not a configuration file: eProsima has no file of command-line arguments (its "config file" is the
//!   `-r` refs file of XML profiles).
//! * `canfd` needs `-D/--dev` (the SocketCAN interface) and takes `-I/--id`, a CAN id in hexadecimal with or
//!   without `0x`, default `0x00000001` (eProsima v3.0.1 parses it but does not use it).
//!
//! Deliberate differences: unknown options are rejected (eProsima silently ignores them), numeric values
//! out of range are rejected instead of wrapping, a repeated option keeps its last value (eProsima keeps the
//! first), and non-numeric baud rates are rejected (eProsima turns them into 0, which hangs up the line).

use std::ffi::OsString;
use std::io::Read;
use std::path::{Path, PathBuf};

use clap::error::ErrorKind;
use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use tracing::level_filters::LevelFilter;

/// eProsima's default verbosity (info), applied when `-v` is absent or given without a value.
pub const DEFAULT_VERBOSITY: u8 = 4;
/// Highest verbosity: everything, including a hex dump of every message.
pub const MAX_VERBOSITY: u8 = 6;
/// UDP port of the discovery server when `-d` is given without a value.
pub const DEFAULT_DISCOVERY_PORT: u16 = 7400;
/// TCP connections served at once when `--max-connections` is absent (eProsima's agent's build-time default).
pub const DEFAULT_MAX_CONNECTIONS: u16 = 100;
/// Serial line speed when `-b` is absent.
pub const DEFAULT_BAUDRATE: u32 = 115_200;
/// CAN identifier when `-I` is absent (eProsima's `0x00000001`).
pub const DEFAULT_CAN_ID: u32 = 0x0000_0001;
/// Largest identifier of a 29-bit extended CAN frame.
pub const MAX_CAN_ID: u32 = 0x1FFF_FFFF;
/// Largest `-f/--file` device list read; it names a few devices, so anything bigger is a mistake.
pub const MAX_DEVICE_FILE_LEN: u64 = 64 * 1024;
/// Largest `--psk-file` read.
pub const MAX_PSK_FILE_LEN: u64 = 4096;
/// Shortest pre-shared key accepted: 16 bytes (128 bits if random; `openssl rand -hex 32` gives 64).
pub const MIN_PSK_LEN: usize = 16;

/// Everything the command line selects, ready for the agent to start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Config {
    /// Transport and its own parameters.
    pub transport: Transport,
    /// Middleware the agent hands entities to.
    pub middleware: MiddlewareKind,
    /// Fast DDS XML profiles file for entities created by reference (`-r`).
    pub refs: Option<PathBuf>,
    /// eProsima verbosity level 0..=6 (see [`Config::log_level_filter`]).
    pub verbosity: u8,
    /// Port of the agent discovery server, if enabled (`-d`).
    pub discovery: Option<u16>,
    /// Port for eProsima's P2P agent discovery (`-P`): refused when the agent starts (not supported).
    pub p2p: Option<u16>,
    /// RTS/CTS hardware flow control on the serial lines (`--flow-control`; ours: PX4 patches eProsima's
    /// agent for it).
    pub flow_control: bool,
    /// Most TCP connections served at once (`--max-connections`, tcp4 and tcp6; ours): more are closed on
    /// accept, so a flood of connections cannot take every file descriptor of the agent.
    pub max_connections: usize,
    /// ROS 2 graph of the DDS middleware (`--ros-graph`; ours, not eProsima's).
    pub ros_graph: RosGraph,
    /// The DDS middleware creates the default domain's DDS participant at start (`--eager-participant`;
    /// ours): discovery with running DDS applications is done before the first client arrives. It is
    /// retired once a participant created for a name has run 10 s, and created again when none is left.
    pub eager_participant: bool,
    /// The DDS middleware gives each XRCE participant name its own DDS participant, which announces that
    /// name, as eProsima's agent does (`--participant-names`; ours). Off: all share the default one.
    pub participant_names: bool,
    /// Shared memory beside UDPv4 for the Fast DDS participants (`--dds-shm`; ours); `None`: this build's
    /// default (on when Fast DDS came from a ROS 2 installation, off for Debian's 2.9 under /usr).
    pub dds_shm: Option<bool>,
    /// DDS engine of the DDS middleware (`--dds-engine`; ours); `None`: `XRCE_DDS_ENGINE`, else Fast DDS where
    /// built, else rustdds.
    pub dds_engine: Option<DdsEngine>,
    /// Silence after which a client is removed with its entities (`--client-timeout`; ours); `None`: never.
    pub client_timeout: Option<std::time::Duration>,
    /// Client authentication (`--allow`, `--psk-file`; ours): off when empty.
    pub auth: crate::core::AuthPolicy,
    /// Serve Prometheus metrics at `http://ADDR:PORT/metrics` (`--metrics`; ours); `None`: off.
    pub metrics: Option<std::net::SocketAddr>,
    /// Publish ROS 2 `/diagnostics` through the DDS middleware (`--ros-diagnostics`; ours).
    pub ros_diagnostics: bool,
    /// The Zenoh session's configuration file (`--zenoh-config`; ours).
    pub zenoh_config: Option<PathBuf>,
}

/// What `--dds-engine` selects: the DDS implementation behind `-m dds`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DdsEngine {
    /// Pure-Rust RustDDS.
    Rustdds,
    /// Fast DDS 2.x or 3.x, as found at build time (the `fastdds` feature, default).
    Fastdds,
}

impl From<DdsEngine> for xrce_dds::Engine {
    fn from(e: DdsEngine) -> Self {
        match e {
            DdsEngine::Rustdds => xrce_dds::Engine::RustDds,
            DdsEngine::Fastdds => xrce_dds::Engine::FastDds,
        }
    }
}

impl Config {
    /// The `tracing` filter for [`Config::verbosity`]: eProsima's levels are off, critical, error, warning,
    /// info, debug, trace; `tracing` has no critical level, so 1 and 2 both show errors only.
    pub fn log_level_filter(&self) -> LevelFilter {
        verbosity_to_filter(self.verbosity)
    }
}

/// Maps an eProsima verbosity level to a `tracing` filter (levels above 6 count as 6).
pub fn verbosity_to_filter(level: u8) -> LevelFilter {
    match level {
        0 => LevelFilter::OFF,
        1 | 2 => LevelFilter::ERROR,
        3 => LevelFilter::WARN,
        4 => LevelFilter::INFO,
        5 => LevelFilter::DEBUG,
        _ => LevelFilter::TRACE,
    }
}

/// The transport subcommand with its parameters.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Transport {
    /// UDP over IPv4.
    Udp4 {
        /// Local port to listen on.
        port: u16,
    },
    /// UDP over IPv6.
    Udp6 {
        /// Local port to listen on.
        port: u16,
    },
    /// TCP over IPv4.
    Tcp4 {
        /// Local port to listen on.
        port: u16,
    },
    /// TCP over IPv6.
    Tcp6 {
        /// Local port to listen on.
        port: u16,
    },
    /// One serial device.
    Serial {
        /// Device path (from `-D`, or the first line of the `-f` file).
        device: String,
        /// Line speed in baud.
        baudrate: u32,
    },
    /// Several serial devices served by one agent.
    MultiSerial {
        /// Device paths (from `--devs`, or the lines of the `-f` file); never empty.
        devices: Vec<String>,
        /// Line speed in baud, shared by all devices.
        baudrate: u32,
    },
    /// A pseudoterminal the agent creates (its path is printed at start).
    PseudoTerminal {
        /// Line speed in baud.
        baudrate: u32,
    },
    /// CAN FD over Linux SocketCAN.
    CanFd {
        /// SocketCAN interface name, e.g. `can0`.
        device: String,
        /// CAN identifier (29-bit).
        can_id: u32,
    },
}

impl Transport {
    /// The subcommand name, as typed on the command line (for messages such as "not available").
    pub fn name(&self) -> &'static str {
        match self {
            Self::Udp4 { .. } => "udp4",
            Self::Udp6 { .. } => "udp6",
            Self::Tcp4 { .. } => "tcp4",
            Self::Tcp6 { .. } => "tcp6",
            Self::Serial { .. } => "serial",
            Self::MultiSerial { .. } => "multiserial",
            Self::PseudoTerminal { .. } => "pseudoterminal",
            Self::CanFd { .. } => "canfd",
        }
    }

    /// The listening port of the IP transports.
    pub fn port(&self) -> Option<u16> {
        match self {
            Self::Udp4 { port } | Self::Udp6 { port } | Self::Tcp4 { port } | Self::Tcp6 { port } => Some(*port),
            _ => None,
        }
    }
}

/// What `--ros-graph` selects: whether the DDS middleware publishes `ros_discovery_info` so that XRCE
/// participants appear as ROS 2 nodes, and with which GID size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ValueEnum)]
pub enum RosGraph {
    /// Published, 16-byte GIDs: ROS 2 Iron, Jazzy and later.
    #[default]
    On,
    /// Published, 24-byte GIDs: ROS 2 Humble.
    Humble,
    /// Not published.
    Off,
}

/// `on` or `off`, for our long options.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ValueEnum)]
pub enum OnOff {
    /// Enabled.
    #[default]
    On,
    /// Disabled.
    Off,
}

/// Middleware selected with `-m/--middleware`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, ValueEnum)]
pub enum MiddlewareKind {
    /// Centralized data: in-agent routing between clients, no DDS.
    Ced,
    /// Real DDS (eProsima's default, Fast DDS there).
    Dds,
    /// Legacy Fast RTPS middleware name; accepted by eProsima's parser, no longer implemented there.
    Rtps,
    /// A ROS 2 graph on rmw_zenoh (ours; cargo feature `zenoh`).
    Zenoh,
}

impl MiddlewareKind {
    /// The name used on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Ced => "ced",
            Self::Dds => "dds",
            Self::Rtps => "rtps",
            Self::Zenoh => "zenoh",
        }
    }
}

/// Summary printed after the top-level help, so `--help` alone lists every option of every transport
/// (eProsima's help has the same per-transport layout).
const ALL_ARGUMENTS: &str = "\
Arguments per transport (place them after the transport):
  * COMMON (every transport)
      -h/--help                       print help
      -m/--middleware <ced|dds|rtps|zenoh>  middleware [default: dds; zenoh: rmw_zenoh's ROS 2 graph,
                                      builds with the `zenoh` feature]
      -r/--refs <FILE>                Fast DDS XML profiles for entities created by reference
      -v/--verbose [0-6]              log level: 0 off .. 6 trace with hex dumps [default: 4, bare -v: 4]
      -d/--discovery [PORT]           answer agent discovery requests [bare -d: 7400]
      --ros-graph <on|humble|off>     ROS 2 nodes for named XRCE participants (dds middleware; ours)
                                      [default: on, 16-byte GIDs (Iron and later); humble: 24-byte GIDs]
      --dds-engine <rustdds|fastdds>  DDS implementation of the dds middleware (ours)
                                      [default: $XRCE_DDS_ENGINE, else fastdds where built, else rustdds]
      --eager-participant <on|off>    create the default DDS participant at start, before any client;
                                      retired once a named one has run 10 s (dds middleware; ours)
                                      [default: on]
      --participant-names <on|off>    a DDS participant per XRCE participant name, announcing it; off:
                                      all share one, named xrce-rs (dds middleware; ours) [default: on]
      --dds-shm <on|off>              shared memory beside UDPv4 with local nodes of the same Fast DDS
                                      (dds middleware; ours) [default: on when built against a ROS 2
                                      installation's Fast DDS, off for Debian's under /usr]
      --client-timeout <SECS>         remove a client silent this long with its entities, probing it
                                      from half of it; 0: never (ours) [default: 60]
      --allow <KEY[@ADDRESS]>         only these client keys (hex or *) from IP, IP/PREFIX or IP:PORT
                                      may create a session; repeatable (ours) [default: anybody]
      --psk-file <FILE>               require a CREATE_CLIENT token made with this pre-shared key (ours)
      --metrics <ADDR:PORT>           serve Prometheus metrics at http://ADDR:PORT/metrics (ours) [default: off]
      --ros-diagnostics <on|off>      publish ROS 2 /diagnostics at 1 Hz (dds middleware; ours) [default: on]
      --zenoh-config <FILE>           Zenoh session configuration (zenoh middleware; ours) [default:
                                      $ZENOH_SESSION_CONFIG_URI, else a peer connecting to tcp/localhost:7447]
  * IPvX (udp4, udp6, tcp4, tcp6)
      -p/--port <PORT>                local port (required)
      --max-connections <N>           tcp4, tcp6: most connections served at once (ours) [default: 100]
  * SERIAL (serial, multiserial, pseudoterminal)
      -b/--baudrate <BAUD>            line speed [default: 115200]
      -D/--dev <DEVICE>               serial: device path
      -D/--devs \"<DEVICE> ...\"        multiserial: space-separated device paths in one argument
      -f/--file <FILE>                serial: device path on the first line; multiserial: one per line
      --flow-control                  serial, multiserial: RTS/CTS hardware flow control (ours) [default: off]
  * CAN FD (canfd)
      -D/--dev <INTERFACE>            SocketCAN interface (required)
      -I/--id <HEX>                   CAN identifier, unused as by eProsima [default: 0x00000001]

Or, every transport of a TOML file in one agent (ours; docs/cli.md, \"Configuration file\"):
      --config <FILE>                 common options at the top, one [[transport]] table per transport

Example: xrce-agent udp4 -p 8888 -m ced -v6";

#[derive(Debug, Parser)]
#[command(
    name = "xrce-agent",
    version = concat!(env!("CARGO_PKG_VERSION"), " (DDS engine: ", env!("XRCE_AGENT_DDS_BUILT_WITH"), ")"),
    about = "DDS-XRCE agent, a drop-in replacement for eProsima's MicroXRCEAgent",
    arg_required_else_help = true,
    args_conflicts_with_subcommands = true,
    disable_help_subcommand = true,
    args_override_self = true,
    after_help = ALL_ARGUMENTS
)]
struct Cli {
    /// Runs every transport of a TOML file in one agent (ours; see docs/cli.md, "Configuration file"): its
    /// common options at the top, one [[transport]] table per transport. Takes no other argument.
    #[arg(long, value_name = "FILE", exclusive = true)]
    config: Option<PathBuf>,

    #[command(subcommand)]
    transport: Option<TransportCommand>,
}

/// What a command line asks for: one transport (every `MicroXRCEAgent` form), or the transports of a
/// configuration file (`--config FILE`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Invocation {
    /// A transport subcommand and its options.
    Command(Config),
    /// `--config FILE`: the file's path, read by [`crate::config_file::load`].
    File(PathBuf),
}

#[derive(Debug, Subcommand)]
enum TransportCommand {
    /// UDP over IPv4.
    Udp4(IpArgs),
    /// UDP over IPv6.
    Udp6(IpArgs),
    /// TCP over IPv4.
    Tcp4(TcpArgs),
    /// TCP over IPv6.
    Tcp6(TcpArgs),
    /// One serial device.
    Serial(SerialArgs),
    /// Several serial devices.
    Multiserial(MultiSerialArgs),
    /// A pseudoterminal created by the agent.
    Pseudoterminal(PseudoTerminalArgs),
    /// CAN FD over SocketCAN
    Canfd(CanArgs),
}

/// Options every transport takes.
#[derive(Debug, Args)]
struct CommonArgs {
    /// Middleware.
    #[arg(short = 'm', long, value_enum, default_value_t = MiddlewareKind::Dds)]
    middleware: MiddlewareKind,

    /// Fast DDS XML profiles file for entities created by reference (must exist).
    #[arg(short = 'r', long, value_name = "FILE", value_parser = existing_file)]
    refs: Option<PathBuf>,

    /// Log level 0 (off) ..= 6 (trace, with a hex dump of every message); bare -v means 4.
    #[arg(
        short = 'v',
        long,
        value_name = "LEVEL",
        num_args = 0..=1,
        default_value_t = DEFAULT_VERBOSITY,
        default_missing_value = "4",
        value_parser = clap::value_parser!(u8).range(0..=i64::from(MAX_VERBOSITY))
    )]
    verbose: u8,

    /// Answer agent discovery requests on this UDP port (bare -d: 7400).
    #[arg(short = 'd', long, value_name = "PORT", num_args = 0..=1, default_missing_value = "7400")]
    discovery: Option<u16>,

    /// eProsima's agent-to-agent bridging of CED topics: not supported (see `AgentError::P2p`); still
    /// parsed, hidden from the help, so a command line with it gets a clear error instead of an unknown option.
    #[arg(short = 'P', long, value_name = "PORT", hide = true)]
    p2p: Option<u16>,

    /// ROS 2 graph (DDS middleware): XRCE participants appear as ROS 2 nodes (on: 16-byte GIDs, Iron and
    /// later; humble: 24-byte GIDs; off: nothing published on ros_discovery_info).
    #[arg(long, value_enum, value_name = "MODE", default_value_t = RosGraph::On)]
    ros_graph: RosGraph,

    /// DDS implementation behind the dds middleware (default: $XRCE_DDS_ENGINE, else fastdds where built, else
    /// rustdds).
    #[arg(long, value_enum, value_name = "ENGINE")]
    dds_engine: Option<DdsEngine>,
    /// DDS middleware: create the default domain's DDS participant at start, so discovery with running
    /// DDS applications (ROS 2 nodes) is done before the first client arrives (off: on first use).
    #[arg(long, value_enum, value_name = "on|off", default_value_t = OnOff::On)]
    eager_participant: OnOff,
    /// DDS middleware: one DDS participant per XRCE participant name, announcing that name (as eProsima's
    /// agent); off: every XRCE participant shares the default DDS participant (named `xrce-rs`).
    #[arg(long, value_enum, value_name = "on|off", default_value_t = OnOff::On)]
    participant_names: OnOff,
    /// DDS middleware (Fast DDS): shared memory beside UDPv4, as the ROS 2 nodes of the Fast DDS this agent
    /// was built with use between themselves (default: on when built against a ROS 2 installation's Fast
    /// DDS, off for Debian's under /usr, which ROS 2 nodes do not run).
    #[arg(long, value_enum, value_name = "on|off")]
    dds_shm: Option<OnOff>,
    /// Remove a client silent this many seconds (decimals allowed) with its entities, probing it from half
    /// of it on; 0: never, as eProsima. A client's `uxr_hl` property overrides it.
    #[arg(long, value_name = "SECS", default_value = "60", value_parser = parse_seconds)]
    client_timeout: std::time::Duration,
    /// Authentication: only clients matching one of these may create a session (KEY: hexadecimal client
    /// key or *; ADDRESS: IP, IP/PREFIX or IP:PORT; none: any address). Repeatable.
    #[arg(long, value_name = "KEY[@ADDRESS]", action = clap::ArgAction::Append)]
    allow: Vec<crate::core::AllowRule>,
    /// Authentication: require in CREATE_CLIENT a token made with the pre-shared key in this file (its
    /// bytes, trailing whitespace removed; at least 16).
    #[arg(long, value_name = "FILE")]
    psk_file: Option<PathBuf>,
    /// Serve Prometheus metrics (text format) at http://ADDR:PORT/metrics, e.g. 127.0.0.1:9464 (off by
    /// default).
    #[arg(long, value_name = "ADDR:PORT")]
    metrics: Option<std::net::SocketAddr>,
    /// DDS middleware: publish a ROS 2 diagnostic_msgs/DiagnosticArray on /diagnostics every second, one
    /// status per client and one for the agent, once a /diagnostics reader is known (on by default).
    #[arg(long, value_enum, value_name = "on|off", default_value_t = OnOff::On)]
    ros_diagnostics: OnOff,
    /// Zenoh middleware: the Zenoh session's configuration file (JSON5, as zenohd's and rmw_zenoh's; default:
    /// $ZENOH_SESSION_CONFIG_URI, else rmw_zenoh's node defaults, a peer connecting to tcp/localhost:7447).
    #[arg(long, value_name = "FILE", value_parser = existing_file)]
    zenoh_config: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct IpArgs {
    /// Local port.
    #[arg(short = 'p', long, value_name = "PORT")]
    port: u16,

    #[command(flatten)]
    common: CommonArgs,
}

#[derive(Debug, Args)]
struct TcpArgs {
    /// Local port.
    #[arg(short = 'p', long, value_name = "PORT")]
    port: u16,

    /// Most connections served at once; more are closed on accept (ours).
    #[arg(
        long,
        value_name = "N",
        default_value_t = DEFAULT_MAX_CONNECTIONS,
        value_parser = clap::value_parser!(u16).range(1..)
    )]
    max_connections: u16,

    #[command(flatten)]
    common: CommonArgs,
}

#[derive(Debug, Args)]
struct SerialArgs {
    /// Serial device path.
    #[arg(short = 'D', long = "dev", value_name = "DEVICE", required_unless_present = "file", conflicts_with = "file")]
    dev: Option<String>,

    /// File whose first line is the serial device path.
    #[arg(short = 'f', long, value_name = "FILE")]
    file: Option<PathBuf>,

    /// Line speed in baud.
    #[arg(short = 'b', long, value_name = "BAUD", default_value_t = DEFAULT_BAUDRATE)]
    baudrate: u32,

    /// RTS/CTS hardware flow control (ours).
    #[arg(long)]
    flow_control: bool,

    #[command(flatten)]
    common: CommonArgs,
}

#[derive(Debug, Args)]
struct MultiSerialArgs {
    /// Serial device paths, space-separated in one argument.
    #[arg(
        short = 'D',
        long = "devs",
        value_name = "DEVICES",
        required_unless_present = "file",
        conflicts_with = "file"
    )]
    devs: Option<String>,

    /// File with one serial device path per line.
    #[arg(short = 'f', long, value_name = "FILE")]
    file: Option<PathBuf>,

    /// Line speed in baud.
    #[arg(short = 'b', long, value_name = "BAUD", default_value_t = DEFAULT_BAUDRATE)]
    baudrate: u32,

    /// RTS/CTS hardware flow control on every device (ours).
    #[arg(long)]
    flow_control: bool,

    #[command(flatten)]
    common: CommonArgs,
}

#[derive(Debug, Args)]
struct PseudoTerminalArgs {
    /// Line speed in baud.
    #[arg(short = 'b', long, value_name = "BAUD", default_value_t = DEFAULT_BAUDRATE)]
    baudrate: u32,

    /// Accepted and ignored, as by eProsima's agent (which ignores arguments it does not know): the agent
    /// creates its pseudoterminal and prints its path. Scripts that pass the serial subcommands' -D keep working.
    #[arg(short = 'D', long = "dev", value_name = "DEVICE", hide = true)]
    dev: Option<String>,

    #[command(flatten)]
    common: CommonArgs,
}

#[derive(Debug, Args)]
struct CanArgs {
    /// SocketCAN interface, e.g. can0.
    #[arg(short = 'D', long = "dev", value_name = "INTERFACE")]
    dev: String,

    /// CAN identifier in hexadecimal, with or without 0x; accepted and unused, as by eProsima's agent (each
    /// client is answered on its own identifier).
    #[arg(short = 'I', long = "id", value_name = "HEX", default_value = "0x00000001", value_parser = parse_can_id)]
    id: u32,

    #[command(flatten)]
    common: CommonArgs,
}

/// The clap command, for `--help` rendering, shell completions or man pages.
pub fn command() -> clap::Command {
    Cli::command()
}

/// Parses a full command line (`args[0]` is the program name) into a [`Config`].
///
/// Errors are clap errors so the caller can simply `err.exit()`: `--help` comes back as an error of kind
/// [`ErrorKind::DisplayHelp`] whose text is the help. Besides parsing, this checks the files eProsima checks
/// while parsing: `-r` must exist, and a `-f` device file is read (at most [`MAX_DEVICE_FILE_LEN`] bytes)
/// and must name at least one device.
pub fn parse_from<I, T>(args: I) -> Result<Config, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    match parse_invocation(args)? {
        Invocation::Command(config) => Ok(config),
        Invocation::File(_) => {
            Err(clap::Error::raw(ErrorKind::ArgumentConflict, "--config names a file: use parse_invocation\n"))
        }
    }
}

/// As [`parse_from`], and `--config FILE` too.
pub fn parse_invocation<I, T>(args: I) -> Result<Invocation, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let mut cmd = Cli::command();
    let matches = cmd.try_get_matches_from_mut(args)?;
    let cli = Cli::from_arg_matches(&matches).map_err(|e| e.format(&mut cmd))?;
    if let Some(file) = cli.config {
        return Ok(Invocation::File(file));
    }
    let Some(transport) = cli.transport else {
        return Err(cmd.error(ErrorKind::MissingSubcommand, "a transport or --config FILE is required"));
    };
    transport.into_config().map(Invocation::Command).map_err(|e| e.format(&mut cmd))
}

impl TransportCommand {
    fn into_config(self) -> Result<Config, clap::Error> {
        let mut flow_control = false;
        let mut max_connections = DEFAULT_MAX_CONNECTIONS;
        let (transport, common) = match self {
            TransportCommand::Udp4(a) => (Transport::Udp4 { port: a.port }, a.common),
            TransportCommand::Udp6(a) => (Transport::Udp6 { port: a.port }, a.common),
            TransportCommand::Tcp4(a) => {
                max_connections = a.max_connections;
                (Transport::Tcp4 { port: a.port }, a.common)
            }
            TransportCommand::Tcp6(a) => {
                max_connections = a.max_connections;
                (Transport::Tcp6 { port: a.port }, a.common)
            }
            TransportCommand::Serial(a) => {
                let device = match (a.dev, a.file) {
                    (Some(dev), _) => dev,
                    (None, Some(file)) => first_device(&read_device_file(&file)?, &file)?,
                    (None, None) => return Err(missing("--dev <DEVICE> or --file <FILE>")),
                };
                flow_control = a.flow_control;
                (Transport::Serial { device, baudrate: a.baudrate }, a.common)
            }
            TransportCommand::Multiserial(a) => {
                let devices = match (a.devs, a.file) {
                    (Some(devs), _) => {
                        let devices: Vec<String> = devs.split_whitespace().map(str::to_owned).collect();
                        if devices.is_empty() {
                            return Err(clap::Error::raw(
                                ErrorKind::InvalidValue,
                                "--devs needs at least one device path\n",
                            ));
                        }
                        devices
                    }
                    (None, Some(file)) => all_devices(&read_device_file(&file)?, &file)?,
                    (None, None) => return Err(missing("--devs <DEVICES> or --file <FILE>")),
                };
                flow_control = a.flow_control;
                (Transport::MultiSerial { devices, baudrate: a.baudrate }, a.common)
            }
            TransportCommand::Pseudoterminal(a) => {
                if let Some(dev) = &a.dev {
                    tracing::warn!(device = %dev, "pseudoterminal: -D is ignored (the agent creates its own device)");
                }
                (Transport::PseudoTerminal { baudrate: a.baudrate }, a.common)
            }
            TransportCommand::Canfd(a) => (Transport::CanFd { device: a.dev, can_id: a.id }, a.common),
        };
        let psk = common.psk_file.as_deref().map(read_psk_file).transpose()?;
        Ok(Config {
            transport,
            middleware: common.middleware,
            refs: common.refs,
            verbosity: common.verbose,
            discovery: common.discovery,
            p2p: common.p2p,
            flow_control,
            max_connections: usize::from(max_connections),
            ros_graph: common.ros_graph,
            dds_engine: common.dds_engine,
            eager_participant: common.eager_participant == OnOff::On,
            participant_names: common.participant_names == OnOff::On,
            dds_shm: common.dds_shm.map(|v| v == OnOff::On),
            client_timeout: Some(common.client_timeout).filter(|t| !t.is_zero()),
            auth: crate::core::AuthPolicy { allow: common.allow, psk },
            metrics: common.metrics,
            ros_diagnostics: common.ros_diagnostics == OnOff::On,
            zenoh_config: common.zenoh_config,
        })
    }
}

/// `--client-timeout`: non-negative decimal seconds.
fn parse_seconds(value: &str) -> Result<std::time::Duration, String> {
    let secs: f64 = value.trim().parse().map_err(|_| format!("`{value}` is not a number of seconds"))?;
    std::time::Duration::try_from_secs_f64(secs).map_err(|_| format!("`{value}` is not a duration in seconds"))
}

/// The pre-shared key in `path`: its bytes, trailing whitespace (a final newline) removed.
fn read_psk_file(path: &Path) -> Result<Vec<u8>, clap::Error> {
    let fail =
        |why: String| clap::Error::raw(ErrorKind::InvalidValue, format!("--psk-file {}: {why}\n", path.display()));
    let mut key = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_PSK_FILE_LEN + 1).read_to_end(&mut key))
        .map_err(|e| fail(e.to_string()))?;
    if key.len() as u64 > MAX_PSK_FILE_LEN {
        return Err(fail(format!("longer than {MAX_PSK_FILE_LEN} bytes")));
    }
    while key.last().is_some_and(u8::is_ascii_whitespace) {
        key.pop();
    }
    if key.len() < MIN_PSK_LEN {
        return Err(fail(format!("the key has {} bytes, fewer than {MIN_PSK_LEN}", key.len())));
    }
    Ok(key)
}

fn missing(what: &str) -> clap::Error {
    clap::Error::raw(ErrorKind::MissingRequiredArgument, format!("{what} is required\n"))
}

/// `-r` value parser: the refs file must exist when the agent starts, as eProsima checks.
fn existing_file(value: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(value);
    if path.is_file() {
        Ok(path)
    } else {
        Err(format!("reference file '{value}' does not exist"))
    }
}

/// `-I` value parser: hexadecimal like C's `strtoul(s, NULL, 16)` (optional `0x`), limited to 29 bits.
fn parse_can_id(value: &str) -> Result<u32, String> {
    let trimmed = value.trim();
    let digits = trimmed.strip_prefix("0x").or_else(|| trimmed.strip_prefix("0X")).unwrap_or(trimmed);
    let id = u32::from_str_radix(digits, 16).map_err(|_| format!("'{value}' is not a hexadecimal CAN id"))?;
    if digits.starts_with('+') || id > MAX_CAN_ID {
        return Err(format!("CAN id '{value}' is not a 29-bit hexadecimal id (0 ..= 0x{MAX_CAN_ID:X})"));
    }
    Ok(id)
}

/// Reads a `-f/--file` device list, bounded by [`MAX_DEVICE_FILE_LEN`].
fn read_device_file(path: &Path) -> Result<String, clap::Error> {
    let io_error = |e: std::io::Error| {
        clap::Error::raw(ErrorKind::Io, format!("cannot read device file '{}': {e}\n", path.display()))
    };
    let file = std::fs::File::open(path).map_err(io_error)?;
    let mut text = String::new();
    file.take(MAX_DEVICE_FILE_LEN + 1).read_to_string(&mut text).map_err(io_error)?;
    if text.len() as u64 > MAX_DEVICE_FILE_LEN {
        return Err(clap::Error::raw(
            ErrorKind::InvalidValue,
            format!("device file '{}' is larger than {MAX_DEVICE_FILE_LEN} bytes\n", path.display()),
        ));
    }
    Ok(text)
}

fn no_device(path: &Path) -> clap::Error {
    clap::Error::raw(ErrorKind::InvalidValue, format!("device file '{}' names no device\n", path.display()))
}

/// Serial: the first line of the file (trimmed), as eProsima reads it.
fn first_device(text: &str, path: &Path) -> Result<String, clap::Error> {
    match text.lines().next().map(str::trim) {
        Some(line) if !line.is_empty() => Ok(line.to_owned()),
        _ => Err(no_device(path)),
    }
}

/// Multiserial: one device per line; blank lines are skipped (eProsima would try to open "").
fn all_devices(text: &str, path: &Path) -> Result<Vec<String>, clap::Error> {
    let devices: Vec<String> = text.lines().map(str::trim).filter(|l| !l.is_empty()).map(str::to_owned).collect();
    if devices.is_empty() {
        return Err(no_device(path));
    }
    Ok(devices)
}

#[cfg(test)]
mod tests;
