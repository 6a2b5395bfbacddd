//! How a command ends: done, a solve not converged (its file written), or a typed
//! error; and the exit code of each (docs/cli.md, "Exit codes").

/// Exit codes: 0 done, 1 an error, 2 a usage error (clap's, and `--threads 0`), 3 a
/// solve that did not converge.
pub const EXIT_ERROR: u8 = 1;
pub const EXIT_USAGE: u8 = 2;
pub const EXIT_NOT_CONVERGED: u8 = 3;

/// How a command ended without an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Done,
    /// A solve stopped before it converged (its file is written).
    NotConverged,
}

/// What ends a command with exit code 1.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Pipeline(#[from] rad_pipeline::Error),
    /// A flag value the binary checks itself (the camera, the PNG's exposure), or a
    /// combination of flags that cannot be run.
    #[error("{0}")]
    Flags(String),
    #[error("cannot write to standard output: {0}")]
    Stdout(std::io::Error),
    /// A bug: every bad input is an error of its own.
    #[error("internal error (a panic: {0}); please report it")]
    Panic(String),
    /// Another rank's error, as the ranks' gather gives it.
    #[error("{0}")]
    Peers(String),
}
