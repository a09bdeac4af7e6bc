//! Printing for people without risking the render: `println!` and `eprintln!` panic when
//! stdout or stderr is a closed pipe (`parrt master … 2>&1 | true`, `| head -1`), and a panic
//! there lost the image (exit 101). [`outln!`](crate::outln), [`out!`](crate::out) and
//! [`errln!`](crate::errln) write the same text and drop it when no one reads it: what cannot
//! be shown is not worth the render. (The log's writer is set likewise, in
//! `parrt_worker::cli::init_logging`.)

/// `println!` that ignores a closed stdout.
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        let _ = ::std::writeln!(::std::io::stdout(), $($arg)*);
    }};
}

/// `print!` that ignores a closed stdout.
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        let _ = ::std::write!(::std::io::stdout(), $($arg)*);
    }};
}

/// `eprintln!` that ignores a closed stderr.
#[macro_export]
macro_rules! errln {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        let _ = ::std::writeln!(::std::io::stderr(), $($arg)*);
    }};
}

/// Writes `bytes` to stdout, all of them, for a command whose output is the point (a scene,
/// a manual page, a completion script). A reader that has gone (`parrt scene mount | head -1`)
/// is not a failure: the pipe's reader asked for no more, so this returns `Ok` quietly, as
/// `cat` and other Unix filters end on a closed pipe. Any other write error is returned.
pub fn write_stdout(bytes: &[u8], what: &str) -> anyhow::Result<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    match out.write_all(bytes).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(anyhow::Error::new(e).context(format!("cannot write {what} to stdout")))
        }
        _ => Ok(()),
    }
}
