//! The subcommands' output, and what a closed pipe does to it.
//!
//! Rust ignores SIGPIPE, so a write to a pipe whose reader has gone (`softplc check p.yaml |
//! head`) fails with `BrokenPipe`, and `print!` turns that into a panic. Every subcommand writes
//! through [`out`] instead: a closed stdout ends the command quietly, by an error
//! [`StdoutClosed`] that [`super::main`] turns into exit status 141 (128 + SIGPIPE, what a shell
//! reports for a program a closed pipe ended), with nothing on stderr. Diagnostics go through
//! [`err`], which never fails: with stderr closed there is nowhere to say anything, and a
//! running PLC must not stop over its log.

use std::fmt;
use std::io::Write;

/// The exit status of a command whose stdout was closed under it: 128 + SIGPIPE (13).
pub(crate) const CLOSED_STATUS: u8 = 141;

/// Stdout was closed (its reader went away) while a command was writing to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct StdoutClosed;

impl fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("standard output closed")
    }
}

impl std::error::Error for StdoutClosed {}

/// Writes `text` to stdout, flushed. A closed stdout is [`StdoutClosed`]; any other failure is
/// an error saying so.
pub(crate) fn out(text: &str) -> anyhow::Result<()> {
    write_to(&mut std::io::stdout().lock(), text)
}

/// [`out`] followed by a newline.
pub(crate) fn outln(text: &str) -> anyhow::Result<()> {
    let mut lock = std::io::stdout().lock();
    write_to(&mut lock, text)?;
    write_to(&mut lock, "\n")
}

fn write_to(w: &mut impl Write, text: &str) -> anyhow::Result<()> {
    match w.write_all(text.as_bytes()).and_then(|()| w.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(e) => Err(anyhow::Error::new(e).context("cannot write to standard output")),
    }
}

/// Writes `text` and a newline to stderr, best effort: a failure is ignored.
pub(crate) fn errln(text: &str) {
    err(&format!("{text}\n"));
}

/// Writes `text` to stderr, best effort: a failure is ignored.
pub(crate) fn err(text: &str) {
    let mut lock = std::io::stderr().lock();
    drop(lock.write_all(text.as_bytes()).and_then(|()| lock.flush()));
}

/// Whether `e` is, or was caused by, a closed stdout.
pub(crate) fn is_closed(e: &anyhow::Error) -> bool {
    e.chain()
        .any(|c| c.downcast_ref::<StdoutClosed>().is_some())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer whose reader has gone.
    struct Closed;

    impl Write for Closed {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::ErrorKind::BrokenPipe.into())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A writer that fails otherwise.
    struct Full;

    impl Write for Full {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::Error::from_raw_os_error(libc::ENOSPC))
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_closed_pipe_is_told_apart_from_other_failures() {
        let closed = write_to(&mut Closed, "x").unwrap_err();
        assert!(is_closed(&closed));
        assert!(is_closed(&closed.context("while printing the report")));
        let full = write_to(&mut Full, "x").unwrap_err();
        assert!(!is_closed(&full));
        assert!(format!("{full:#}").starts_with("cannot write to standard output: "));
        let mut v = Vec::new();
        write_to(&mut v, "ok").unwrap();
        assert_eq!(v, b"ok");
    }
}
