//! The one error type of the numerical core. The Python binding maps each variant to a class of
//! `roadtex.errors` (python/roadtex/errors.py): InvalidInput to InvalidInputError (a ValueError),
//! DirectSolverFailed to SolverError and ClappFailed to ClappError (RuntimeErrors).

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub enum ContactError {
    /// The caller's input is unusable; the message names the argument and the problem.
    InvalidInput(String),
    /// The dense direct solver's active-set loop did not settle (it never should on valid input).
    DirectSolverFailed(String),
    /// A window of Clapp's sub-profile model could not be solved (it never should on valid input).
    ClappFailed(String),
}

impl fmt::Display for ContactError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ContactError::InvalidInput(msg) => write!(f, "{msg}"),
            ContactError::DirectSolverFailed(msg) => write!(f, "direct solver failed: {msg}"),
            ContactError::ClappFailed(msg) => write!(f, "Clapp's model failed: {msg}"),
        }
    }
}

impl std::error::Error for ContactError {}

pub type Result<T> = std::result::Result<T, ContactError>;

pub(crate) fn invalid<T>(msg: impl Into<String>) -> Result<T> {
    Err(ContactError::InvalidInput(msg.into()))
}
