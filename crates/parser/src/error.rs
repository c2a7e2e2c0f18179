//! The one error type of the parser. Every error carries the scene file position it is about,
//! so a user can jump straight to the offending element.

use crate::scene::SourceLocation;

/// A fatal problem with a scene: where it is and what is wrong.
/// Displays as `"{file}:{line}:{column}: error: {message}"`, the format editors understand.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{location}: error: {message}")]
pub struct ParseError {
    /// Where in the scene file the problem is (the element or attribute at fault).
    pub location: SourceLocation,
    /// What is wrong, naming the element, parameter or file involved.
    pub message: String,
}

/// Shorthand used throughout the crate.
pub type Result<T> = std::result::Result<T, ParseError>;
