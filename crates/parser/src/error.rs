//! The one error type of the parser. Every error carries the scene file position it is about,
//! so a user can jump straight to the offending element.

use crate::scene::SourceLocation;

/// A fatal problem with a scene: where it is and what is wrong.
/// Displays as `"{file}:{line}:{column}: error: {message}"`, the format editors understand,
/// on one line of bounded length (see [`one_line`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{location}: error: {}", one_line(message))]
pub struct ParseError {
    /// Where in the scene file the problem is (the element or attribute at fault).
    pub location: SourceLocation,
    /// What is wrong, naming the element, parameter or file involved.
    pub message: String,
}

/// Shorthand used throughout the crate.
pub type Result<T> = std::result::Result<T, ParseError>;

/// Longest message [`one_line`] prints unshortened, in characters.
const MAX_MESSAGE_CHARS: usize = 400;

/// A message as printed: line breaks become spaces, and a message longer than 400 characters
/// (one quoting a 10 MB attribute value, say) keeps its start and end around a note of how
/// much was left out, so that every diagnostic stays one readable line.
pub(crate) fn one_line(message: &str) -> String {
    let flat: String = message
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    let n = flat.chars().count();
    if n <= MAX_MESSAGE_CHARS {
        return flat;
    }
    let head: String = flat.chars().take(250).collect();
    let tail: String = flat.chars().skip(n - 100).collect();
    format!("{head}[... {} characters left out ...]{tail}", n - 350)
}

#[cfg(test)]
mod tests {
    use super::one_line;

    #[test]
    fn long_and_multi_line_messages_become_one_short_line() {
        assert_eq!(one_line("a\nb\tc"), "a b c");
        let long = format!(
            "unknown bsdf type '{}' (supported: diffuse)",
            "x".repeat(10_000_000)
        );
        let shown = one_line(&long);
        assert!(shown.len() < 450, "{}", shown.len());
        assert!(shown.starts_with("unknown bsdf type 'xxx"));
        assert!(shown.ends_with("xxx' (supported: diffuse)"));
        assert!(shown.contains(" characters left out ...]"), "{shown}");
    }
}
