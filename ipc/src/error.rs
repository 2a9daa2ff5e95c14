//! The operator interface's one error type: its own file, below the
//! services ([`crate::service`]) and the guard of iceoryx2's files
//! ([`crate::guard`]), which both return it.

/// What went wrong setting up or using the operator interface.
#[derive(Debug, thiserror::Error)]
pub enum IpcError {
    /// The prefix does not make valid service names.
    #[error("IPC prefix '{0}' is not valid (expected letters, digits, '-', '_' and '/')")]
    BadPrefix(String),
    /// A live process other than a daemon of ours holds a service.
    #[error(
        "service '{service}' is held by a live process ({holders}): another anguilla daemon, or a \
         program that created it first; stop it, or give this daemon another [ipc] prefix"
    )]
    Squatted {
        /// The service's full name.
        service: String,
        /// Who holds it ("pid 1234", ...).
        holders: String,
    },
    /// A live process receives on the prefix's E-stop socket.
    #[error(
        "the e-stop socket {0} is in use by a live process: another anguilla daemon serves \
         this prefix; stop it, or give this daemon another [ipc] prefix"
    )]
    EStopSocketInUse(String),
    /// The E-stop socket could not be set up; the text names the step.
    #[error("e-stop socket: {0}")]
    EStopSocket(String),
    /// No daemon serves the prefix.
    #[error(
        "no anguilla daemon serves '{prefix}' ({detail}); is `anguilla run` running with this [ipc] prefix?"
    )]
    NoDaemon {
        /// The prefix tried.
        prefix: String,
        /// iceoryx2's words.
        detail: String,
    },
    /// A file or directory iceoryx2 shares is another user's (or cannot be
    /// restricted); the text names it, its owner and mode, and the fix
    /// ([`crate::guard`]).
    #[error("{0}")]
    Foreign(String),
    /// iceoryx2 refused an operation; the text names it.
    #[error("iceoryx2: {0}")]
    Iceoryx(String),
    /// A remote session (`anguilla link` over Zenoh) failed; the text names
    /// the endpoint and the step.
    #[error("{0}")]
    Remote(String),
}
