//! `SimError`: everything that can go wrong while loading a scenario, a world image or a
//! truth file, and while rendering.
//!
//! The simulator is the first stage of the pipeline: a person writes a scenario folder by
//! hand, and this error is what they read when it is wrong. So every variant names the
//! FILE, the KEY (dotted, e.g. `robot.speed` or `sketch[1].image`) and what is wrong, with
//! the 1-based line number when it is known. Nothing in the simulator panics on bad input.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// An error of the simulator library.
#[derive(Debug, Error)]
pub enum SimError {
    /// A ROS 2 bag cannot be used: not MCAP, a topic missing or of another type, a
    /// message that does not decode.
    #[error("{}: {message}", .file.display())]
    Bag {
        /// The bag.
        file: PathBuf,
        /// What is wrong, naming the topic.
        message: String,
    },

    /// A file could not be read or written.
    #[error("{}: {action}: {source}", .file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// What was being done ("cannot read", "cannot write").
        action: &'static str,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },

    /// The file is not valid TOML, or does not have the expected shape (unknown key,
    /// missing key, wrong type).
    #[error("{}: {}{message}", location(.file, *.line), key_prefix(.key.as_deref()))]
    Parse {
        /// The scenario file.
        file: PathBuf,
        /// 1-based line of the offending text, when the parser gave a position.
        line: Option<usize>,
        /// The dotted key at that line, when one could be found.
        key: Option<String>,
        /// The parser's description.
        message: String,
    },

    /// A key is well-formed but its value is not acceptable (negative speed, start inside a
    /// wall, a path leg through a wall, ...).
    #[error("{}: key `{key}`: {message}", location(.file, *.line))]
    Invalid {
        /// The scenario file.
        file: PathBuf,
        /// 1-based line of the key, when it could be found.
        line: Option<usize>,
        /// The dotted key, e.g. `robot.path`.
        key: String,
        /// What is wrong with the value.
        message: String,
    },

    /// An image named by a scenario key does not exist or does not decode.
    #[error("{}: key `{key}`: image {}: {message}", location(.file, *.line), .image.display())]
    Image {
        /// The scenario file naming the image.
        file: PathBuf,
        /// 1-based line of the key, when it could be found.
        line: Option<usize>,
        /// The dotted key naming the image, e.g. `world.image`.
        key: String,
        /// The image's absolute path.
        image: PathBuf,
        /// Why it cannot be used.
        message: String,
    },

    /// A truth CSV file is malformed.
    #[error("{}: {message}", location(.file, *.line))]
    Csv {
        /// The CSV file.
        file: PathBuf,
        /// 1-based line.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
}

/// Why `simulator generate` could not write a world.
#[derive(Debug, Error)]
pub enum GenerateError {
    /// A file or folder could not be written.
    #[error("{}: {action}: {source}", .path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What was being done ("cannot create", "cannot write").
        action: &'static str,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },

    /// An image could not be encoded.
    #[error("{}: cannot encode: {message}", .path.display())]
    Encode {
        /// The image file.
        path: PathBuf,
        /// The encoder's reason.
        message: String,
    },

    /// No floor of this kind and seed gave a route that passes the checks (in range,
    /// clear of every wall and piece of clutter) within the allowed number of re-draws.
    #[error(
        "seed {seed}, kind {kind}: no valid route after {attempts} floor plans; last problem: {last}"
    )]
    NoRoute {
        /// The seed asked for.
        seed: u64,
        /// The kind drawn.
        kind: String,
        /// Floor plans tried.
        attempts: u32,
        /// What was wrong with the last one.
        last: String,
    },

    /// The written folder does not load as a scenario (a bug of the generator).
    #[error("the generated scenario does not load: {0}")]
    Check(#[source] SimError),
}

/// `file:line` or `file`.
fn location(file: &Path, line: Option<usize>) -> String {
    let mut s = file.display().to_string();
    if let Some(line) = line {
        let _ = write!(s, ":{line}");
    }
    s
}

fn key_prefix(key: Option<&str>) -> String {
    key.map(|k| format!("key `{k}`: ")).unwrap_or_default()
}

/// 1-based line number of byte `offset` in `source` (clamped to the text).
pub(crate) fn line_of_offset(source: &str, offset: usize) -> usize {
    let end = offset.min(source.len());
    // Count newlines in the bytes before `offset`; slicing bytes avoids char boundaries.
    source.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_numbers_are_one_based() {
        let s = "a = 1\nb = 2\n\nc = 3";
        assert_eq!(line_of_offset(s, 0), 1);
        assert_eq!(line_of_offset(s, 6), 2);
        assert_eq!(line_of_offset(s, s.len() - 1), 4);
        assert_eq!(line_of_offset(s, 10_000), 4);
    }

    #[test]
    fn messages_name_file_line_and_key() {
        let e = SimError::Invalid {
            file: PathBuf::from("/s/scenario.toml"),
            line: Some(12),
            key: "robot.speed".into(),
            message: "must be positive, got -1".into(),
        };
        assert_eq!(
            e.to_string(),
            "/s/scenario.toml:12: key `robot.speed`: must be positive, got -1"
        );
    }
}
