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
