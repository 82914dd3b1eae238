//! The one error type of the numerical core. The Python binding maps every variant to ValueError
//! (bad input) or RuntimeError (a solver that could not do what was asked).

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub enum ContactError {
    /// The caller's input is unusable; the message names the argument and the problem.
    InvalidInput(String),
    /// The dense direct solver's active-set loop did not settle (it never should on valid input).
    DirectSolverFailed(String),
}

impl fmt::Display for ContactError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ContactError::InvalidInput(msg) => write!(f, "{msg}"),
            ContactError::DirectSolverFailed(msg) => write!(f, "direct solver failed: {msg}"),
        }
    }
}

impl std::error::Error for ContactError {}

pub type Result<T> = std::result::Result<T, ContactError>;

pub(crate) fn invalid<T>(msg: impl Into<String>) -> Result<T> {
    Err(ContactError::InvalidInput(msg.into()))
}
