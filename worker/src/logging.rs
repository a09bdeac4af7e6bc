//! Where diagnostics go: lines for people by default, the timestamped log on request. Without
//! `$PARRT_LOG` and without `-v`, a warning or error that a library raises (the NFF reader's
//! "polygons of zero area dropped", a runtime's refused connection) is printed as one plain
//! line, `parrt: warning: …`, beside the command's own lines. With `-v` (level `info`) or
//! `$PARRT_LOG` (a tracing-subscriber filter such as `debug` or `parrt_runtime=debug`), every
//! event is a timestamped log line naming its level and module, for a log file or a bug report.

use std::fmt;
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::fmt::format::Writer;
use tracing_subscriber::fmt::{FmtContext, FormatEvent, FormatFields};
use tracing_subscriber::registry::LookupSpan;

/// The environment variable with the log filter (tracing-subscriber syntax, e.g. `debug`).
pub const LOG_ENV: &str = "PARRT_LOG";

/// The log filter of a command with a `-v` flag when `$PARRT_LOG` is not set: `info` (the
/// timestamped lines of what happens) with `-v`, else `warn` (warnings only, as lines for
/// people beside the command's own).
pub fn log_level(verbose: bool) -> &'static str {
    if verbose {
        "info"
    } else {
        "warn"
    }
}

/// Whether a command prints its lines for people: not when the log was asked for (`-v` or
/// `$PARRT_LOG`), whose timestamped lines say the same and more. (The local workers a master
/// starts are given `$PARRT_LOG`, so they print none.)
pub fn human_lines(verbose: bool) -> bool {
    !verbose && std::env::var_os(LOG_ENV).is_none()
}

/// Installs the stderr subscriber; harmless if one is already installed. With `$PARRT_LOG` set,
/// its filter and the timestamped format; else `default` as the filter, and for `warn` (no
/// `-v`) the plain `parrt: warning: …` lines of [`HumanLine`].
pub fn init_logging(default: &str) {
    let from_env = tracing_subscriber::EnvFilter::try_from_env(LOG_ENV).ok();
    let plain = from_env.is_none() && default == "warn";
    let filter = from_env.unwrap_or_else(|| tracing_subscriber::EnvFilter::new(default));
    // A closed stderr must not stop the work: the log's write errors are dropped, not
    // reported with `eprintln!` (which panics on a closed stderr).
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .log_internal_errors(false)
        .with_writer(std::io::stderr);
    let _ = if plain {
        // Plain text: field names are not coloured, whatever the terminal.
        builder.with_ansi(false).event_format(HumanLine).try_init()
    } else {
        builder
            .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
            .try_init()
    };
}

/// The format of a diagnostic for people: `parrt: warning: MESSAGE` (or `error:`, `note:`),
/// with no time, level column or module path, the way compilers and Unix tools word theirs.
/// Fields other than the message follow it as `name=value`.
#[derive(Clone, Copy, Debug, Default)]
pub struct HumanLine;

impl<S, N> FormatEvent<S, N> for HumanLine
where
    S: Subscriber + for<'a> LookupSpan<'a>,
    N: for<'a> FormatFields<'a> + 'static,
{
    fn format_event(
        &self,
        ctx: &FmtContext<'_, S, N>,
        mut writer: Writer<'_>,
        event: &Event<'_>,
    ) -> fmt::Result {
        let word = match *event.metadata().level() {
            Level::ERROR => "error",
            Level::WARN => "warning",
            _ => "note",
        };
        write!(writer, "parrt: {word}: ")?;
        ctx.field_format().format_fields(writer.by_ref(), event)?;
        writeln!(writer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io;
    use std::sync::{Arc, Mutex};

    /// A writer that keeps what the subscriber wrote.
    #[derive(Clone, Default)]
    struct Captured(Arc<Mutex<Vec<u8>>>);

    impl io::Write for Captured {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_warning_for_people_is_one_plain_line_without_time_or_module() {
        let out = Captured::default();
        let writer = out.clone();
        let subscriber = tracing_subscriber::fmt()
            .with_writer(move || writer.clone())
            .with_ansi(false)
            .event_format(HumanLine)
            .finish();
        tracing::subscriber::with_default(subscriber, || {
            tracing::warn!("scene.nff:10:1: 2 polygons of zero area dropped");
            tracing::error!(peer = "10.0.0.7:4000", "refused");
        });
        let text = String::from_utf8(out.0.lock().unwrap().clone()).unwrap();
        assert_eq!(
            text,
            "parrt: warning: scene.nff:10:1: 2 polygons of zero area dropped\n\
             parrt: error: refused peer=\"10.0.0.7:4000\"\n"
        );
    }
}
