//! eProsima verbosity levels (0..=6) mapped onto `tracing`, changeable at run time
//! (`Agent::set_verbose_level`).

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::OnceLock;

use tracing::level_filters::LevelFilter;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::{fmt, reload, Registry};

static HANDLE: OnceLock<reload::Handle<LevelFilter, Registry>> = OnceLock::new();

/// The current eProsima level, for the per-target filter below.
static LEVEL: AtomicU8 = AtomicU8::new(4);

/// RustDDS (the DDS middleware's stack) logs discovery chatter at INFO; it is shown at level 6 only, and
/// its warnings and errors always.
fn dependency_filter(meta: &tracing::Metadata<'_>) -> bool {
    !meta.target().starts_with("rustdds") || *meta.level() <= tracing::Level::WARN || LEVEL.load(Ordering::Relaxed) >= 6
}

/// Installs the global logger at `level`, or changes its level if this function installed it before.
/// Returns false if another global subscriber was installed by someone else (the level is then theirs).
pub fn set_verbose_level(level: u8) -> bool {
    let filter = crate::cli::verbosity_to_filter(level);
    LEVEL.store(level, Ordering::Relaxed);
    if let Some(handle) = HANDLE.get() {
        return handle.modify(|f| *f = filter).is_ok();
    }
    let (layer, handle) = reload::Layer::new(filter);
    let installed = Registry::default()
        .with(layer)
        .with(tracing_subscriber::filter::filter_fn(dependency_filter))
        // Colours only on a terminal: logs redirected to a file or a journal stay plain text.
        .with(fmt::layer().with_target(false).with_ansi(std::io::IsTerminal::is_terminal(&std::io::stdout())))
        .try_init()
        .is_ok();
    if installed {
        let _ = HANDLE.set(handle);
    }
    installed
}
