//! An error as the command line prints it: the error and its causes on one line, each cause
//! once.
//!
//! Errors here name their cause in their own message (`bus line1: cannot open /dev/ttyUSB0:
//! Device or resource busy`), so that a log line or a control reply that prints one error
//! says everything, and many also hand that cause on as their `source()`. Printing the whole
//! chain, as `{:#}` does, would then say each cause again at every level. So a cause whose
//! text the line already holds is left out: every command's error reads
//! `what failed: why: why`, each part once.

/// The line for `e` and its chain of causes.
pub(crate) fn error_line(e: &anyhow::Error) -> String {
    join_causes(e.chain().map(ToString::to_string))
}

/// `messages` (an error's, then its causes', outermost first) joined by `: `, leaving out an
/// empty one and one whose text is already in the line.
fn join_causes(messages: impl Iterator<Item = String>) -> String {
    let mut line = String::new();
    for message in messages {
        let message = message.trim();
        if message.is_empty() || line.contains(message) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(message);
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot open /dev/pts/0: {source}")]
    struct Open {
        source: std::io::Error,
    }

    #[derive(Debug, thiserror::Error)]
    #[error("bus line1: {source}")]
    struct Port {
        source: Open,
    }

    #[test]
    fn a_cause_that_each_level_repeats_is_said_once() {
        let busy = std::io::Error::other("Unable to acquire exclusive lock on serial port");
        let e = anyhow::Error::new(Port {
            source: Open { source: busy },
        })
        .context("cannot start the PLC");
        assert_eq!(
            error_line(&e),
            "cannot start the PLC: bus line1: cannot open /dev/pts/0: Unable to acquire \
             exclusive lock on serial port"
        );
        // `{:#}` says the lock three times.
        assert_eq!(format!("{e:#}").matches("exclusive lock").count(), 3);
    }

    #[test]
    fn causes_that_are_not_in_the_message_are_kept_in_order() {
        let e = anyhow::anyhow!("the disk is full")
            .context("cannot write the record")
            .context("flight recorder stopped");
        assert_eq!(
            error_line(&e),
            "flight recorder stopped: cannot write the record: the disk is full"
        );
        let messages = ["outer", "", "  ", "inner"].map(String::from);
        assert_eq!(join_causes(messages.into_iter()), "outer: inner");
    }
}
