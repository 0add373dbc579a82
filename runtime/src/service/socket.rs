//! Kernel socket buffers bounded for clients that do not read: with the kernel's autotuning a
//! send buffer grows to megabytes, so a client that stops reading is noticed (its write
//! blocks past the deadline) only after megabytes of data; with a bounded buffer, after a few
//! seconds of it.

use std::os::fd::AsRawFd;

/// Caps the kernel's send buffer of `socket` at `bytes`; best effort (a refusal is logged at
/// debug level: the write deadline still ends a client that does not read, only later).
pub(crate) fn bound_send_buffer(socket: &impl AsRawFd, bytes: usize) {
    set(socket, libc::SO_SNDBUF, bytes);
}

/// Caps both kernel buffers of `socket` at `bytes` each; best effort.
pub(crate) fn bound_buffers(socket: &impl AsRawFd, bytes: usize) {
    set(socket, libc::SO_SNDBUF, bytes);
    set(socket, libc::SO_RCVBUF, bytes);
}

#[allow(unsafe_code)]
fn set(socket: &impl AsRawFd, option: libc::c_int, bytes: usize) {
    let size = libc::c_int::try_from(bytes).unwrap_or(libc::c_int::MAX);
    // SAFETY: the descriptor is the open socket `socket` owns for the duration of the call,
    // and the option value is a valid `c_int` of the length given.
    let rc = unsafe {
        libc::setsockopt(
            socket.as_raw_fd(),
            libc::SOL_SOCKET,
            option,
            std::ptr::from_ref(&size).cast(),
            std::mem::size_of::<libc::c_int>() as libc::socklen_t,
        )
    };
    if rc != 0 {
        tracing::debug!(
            "cannot cap a socket buffer: {}",
            std::io::Error::last_os_error()
        );
    }
}
