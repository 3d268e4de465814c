//! eProsima verbosity levels (0..=6) mapped onto `tracing`, changeable at run time
//! (`Agent::set_verbose_level`). `RUST_LOG` (the `tracing` convention: `info`, `xrce_agent=debug,rustdds=warn`,
//! ...), when set, replaces the `-v` level when the logger is installed.

use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::OnceLock;

use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::{fmt, reload, EnvFilter, Registry};

static HANDLE: OnceLock<reload::Handle<EnvFilter, Registry>> = OnceLock::new();

/// The current eProsima level, for the per-target filter below.
static LEVEL: AtomicU8 = AtomicU8::new(4);

/// `RUST_LOG` chose the filter: the per-target filter below stands aside.
static FROM_ENV: AtomicBool = AtomicBool::new(false);

/// RustDDS (the DDS middleware's stack) logs discovery chatter at INFO; it is shown at level 6 only, and
/// its warnings and errors always (unless `RUST_LOG` says otherwise).
fn dependency_filter(meta: &tracing::Metadata<'_>) -> bool {
    FROM_ENV.load(Ordering::Relaxed)
        || !meta.target().starts_with("rustdds")
        || *meta.level() <= tracing::Level::WARN
        || LEVEL.load(Ordering::Relaxed) >= 6
}

/// The filter for eProsima level `level`, or for `rust_log` (a `RUST_LOG` value) when given and valid; an
/// invalid one is reported on stderr and the level used instead. The flag tells whether `rust_log` won.
pub fn filter_for(level: u8, rust_log: Option<&str>) -> (EnvFilter, bool) {
    if let Some(spec) = rust_log.map(str::trim).filter(|s| !s.is_empty()) {
        match EnvFilter::try_new(spec) {
            Ok(f) => return (f, true),
            Err(e) => eprintln!("RUST_LOG={spec:?} is not a valid filter ({e}); using -v {level}"),
        }
    }
    (EnvFilter::default().add_directive(crate::cli::verbosity_to_filter(level).into()), false)
}

/// Installs the global logger at `level` (or at `RUST_LOG`, when set), or changes its level if this function
/// installed it before. Returns false if another global subscriber was installed by someone else (the level
/// is then theirs).
pub fn set_verbose_level(level: u8) -> bool {
    LEVEL.store(level, Ordering::Relaxed);
    if let Some(handle) = HANDLE.get() {
        let (filter, _) = filter_for(level, None);
        FROM_ENV.store(false, Ordering::Relaxed);
        return handle.modify(|f| *f = filter).is_ok();
    }
    let (filter, from_env) = filter_for(level, std::env::var("RUST_LOG").ok().as_deref());
    FROM_ENV.store(from_env, Ordering::Relaxed);
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

#[cfg(test)]
mod tests {
    use super::filter_for;
    use tracing::level_filters::LevelFilter;

    #[test]
    fn rust_log_replaces_the_level_and_a_bad_one_falls_back() {
        let (f, env) = filter_for(4, None);
        assert_eq!((f.max_level_hint(), env), (Some(LevelFilter::INFO), false));
        let (f, env) = filter_for(4, Some("xrce_agent=trace,rustdds=warn"));
        assert_eq!((f.max_level_hint(), env), (Some(LevelFilter::TRACE), true));
        let (f, env) = filter_for(3, Some("error"));
        assert_eq!((f.max_level_hint(), env), (Some(LevelFilter::ERROR), true));
        let (f, env) = filter_for(3, Some("xrce_agent=loud"));
        assert_eq!((f.max_level_hint(), env), (Some(LevelFilter::WARN), false));
        let (f, env) = filter_for(0, Some("  "));
        assert_eq!((f.max_level_hint(), env), (Some(LevelFilter::OFF), false));
    }
}
