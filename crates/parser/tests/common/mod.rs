//! Helpers shared by the parser's integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use torrey_parser::{parse_scene_str, ParseError, Scene};

/// A fresh, empty temporary folder for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("torrey-parser-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Parses `xml` as if it were `dir/scene.xml`.
pub fn parse_in(dir: &Path, xml: &str) -> Result<Scene, ParseError> {
    parse_scene_str(xml, &dir.join("scene.xml"), &[])
}

pub fn parse(xml: &str) -> Result<Scene, ParseError> {
    parse_scene_str(xml, Path::new("test.xml"), &[])
}

pub fn parse_ok(xml: &str) -> Scene {
    parse(xml).unwrap_or_else(|e| panic!("{e}"))
}

/// The 1-based (line, column) where `needle` first occurs in `xml`.
pub fn pos_of(xml: &str, needle: &str) -> (u32, u32) {
    let at = xml
        .find(needle)
        .unwrap_or_else(|| panic!("'{needle}' not in test XML"));
    let line = xml[..at].matches('\n').count() as u32 + 1;
    let start = xml[..at].rfind('\n').map_or(0, |i| i + 1);
    (line, xml[start..at].chars().count() as u32 + 1)
}

/// Asserts an error's message starts with `message` and it is at `pos`.
pub fn assert_err(e: &ParseError, message: &str, pos: (u32, u32)) {
    assert!(
        e.message.starts_with(message),
        "message\n  {}\ndoes not start with\n  {message}",
        e.message
    );
    assert_eq!(
        (e.location.line, e.location.column),
        pos,
        "position of: {e}"
    );
}
