//! Hand-written TOML files of the simulator's inputs (`scenario.toml`, `dataset.toml`):
//! reading one, deserializing it, and the key locator that gives every error its file,
//! dotted key and 1-based line.
//!
//! The first step of loading a scenario ([`crate::scenario`]) or a dataset
//! ([`crate::dataset`]): both read their file with [`read`], deserialize it through a
//! [`Ctx`] (a [`SimError::Parse`] names the line and the key there, or the missing key)
//! and report bad values with [`Ctx::invalid`] (a [`SimError::Invalid`] naming the key of
//! its [`Table`] and the line where it is set). The locator reads headers (`[t]`,
//! `[[t]]` counted per name), skips comments and unquotes keys.

use crate::error::{SimError, line_of_offset};
use std::path::Path;

/// Reads a whole input file, an unreadable one being a [`SimError::Io`].
pub(crate) fn read(file: &Path) -> Result<String, SimError> {
    std::fs::read_to_string(file).map_err(|source| SimError::Io {
        file: file.to_path_buf(),
        action: "cannot read",
        source,
    })
}

/// Where a key lives: the top level, a `[table]`, or the n-th `[[table]]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Table {
    /// The top level, before any header.
    Root,
    /// `[name]`.
    Named(&'static str),
    /// The n-th (0-based) `[[name]]`.
    Array(&'static str, usize),
}

impl Table {
    /// The dotted key of `key` in this table.
    pub(crate) fn key(&self, key: &str) -> String {
        match self {
            Table::Root => key.to_string(),
            Table::Named(t) => format!("{t}.{key}"),
            Table::Array(t, i) => format!("{t}[{i}].{key}"),
        }
    }
}

/// The file being read, for building errors.
pub(crate) struct Ctx<'a> {
    /// The file, as errors name it.
    pub(crate) file: &'a Path,
    /// Its text.
    pub(crate) source: &'a str,
}

/// What a line of TOML is, for the key locator.
enum LineKind<'s> {
    Header { name: &'s str, array: bool },
    Key(&'s str),
    Other,
}

fn classify(line: &str) -> LineKind<'_> {
    let t = line.trim();
    if let Some(rest) = t.strip_prefix("[[") {
        let name = rest.split("]]").next().unwrap_or("").trim();
        return LineKind::Header { name, array: true };
    }
    if let Some(rest) = t.strip_prefix('[') {
        let name = rest.split(']').next().unwrap_or("").trim();
        return LineKind::Header { name, array: false };
    }
    if t.starts_with('#') {
        return LineKind::Other;
    }
    match t.split_once('=') {
        Some((k, _)) => LineKind::Key(k.trim().trim_matches('"').trim_matches('\'')),
        None => LineKind::Other,
    }
}

impl Ctx<'_> {
    /// An [`SimError::Invalid`] for `key` of `table`, with the key's line when found.
    pub(crate) fn invalid(&self, table: Table, key: &str, message: String) -> SimError {
        SimError::Invalid {
            file: self.file.to_path_buf(),
            line: self.key_line(table, key),
            key: table.key(key),
            message,
        }
    }

    /// The 1-based line where `key` is set inside `table`, if it can be found.
    pub(crate) fn key_line(&self, table: Table, key: &str) -> Option<usize> {
        let mut current = Table::Root;
        let mut array_counts: Vec<(&str, usize)> = Vec::new();
        for (n, line) in self.source.lines().enumerate() {
            match classify(line) {
                LineKind::Header { name, array } => {
                    current = if array {
                        let count = match array_counts.iter_mut().find(|(t, _)| *t == name) {
                            Some((_, c)) => {
                                *c += 1;
                                *c
                            }
                            None => {
                                array_counts.push((name, 0));
                                0
                            }
                        };
                        match table {
                            Table::Array(t, _) if t == name => Table::Array(t, count),
                            _ => Table::Named(""),
                        }
                    } else {
                        match table {
                            Table::Named(t) if t == name => table,
                            _ => Table::Named(""),
                        }
                    };
                }
                LineKind::Key(k) if current == table && k == key => return Some(n + 1),
                _ => {}
            }
        }
        None
    }

    /// The dotted key set (or table opened) at 1-based `line`, if any.
    fn key_at_line(&self, line: usize) -> Option<String> {
        let mut table: Option<String> = None;
        let mut array_counts: Vec<(String, usize)> = Vec::new();
        for (n, text) in self.source.lines().enumerate().take(line) {
            let here = n + 1 == line;
            match classify(text) {
                LineKind::Header { name, array } => {
                    let label = if array {
                        let count = match array_counts.iter_mut().find(|(t, _)| t == name) {
                            Some((_, c)) => {
                                *c += 1;
                                *c
                            }
                            None => {
                                array_counts.push((name.to_string(), 0));
                                0
                            }
                        };
                        format!("{name}[{count}]")
                    } else {
                        name.to_string()
                    };
                    if here {
                        return Some(label);
                    }
                    table = Some(label);
                }
                LineKind::Key(k) if here => {
                    return Some(match &table {
                        Some(t) => format!("{t}.{k}"),
                        None => k.to_string(),
                    });
                }
                _ => {}
            }
        }
        table
    }

    /// Deserializes the text into the file's shape (`T` rejects unknown keys), a problem
    /// being a [`SimError::Parse`] naming the line and key.
    pub(crate) fn deserialize<T: serde::de::DeserializeOwned>(&self) -> Result<T, SimError> {
        toml::from_str(self.source).map_err(|e| self.parse_error(&e))
    }

    /// The [`SimError::Parse`] of a TOML error: file, line and the dotted key there.
    fn parse_error(&self, e: &toml::de::Error) -> SimError {
        let line = e.span().map(|span| line_of_offset(self.source, span.start));
        // A span at offset 0 covers the whole document (e.g. a missing table): no key.
        let key = match e.span() {
            Some(span) if span.start > 0 => line.and_then(|l| self.key_at_line(l)),
            _ => None,
        };
        // "missing field `x`" points at the table that lacks it: name the full key.
        let missing = e
            .message()
            .strip_prefix("missing field `")
            .and_then(|rest| rest.split('`').next());
        let key = match (key, missing) {
            (Some(table), Some(field)) => Some(format!("{table}.{field}")),
            (None, Some(field)) => Some(field.to_string()),
            (key, None) => key,
        };
        SimError::Parse {
            file: self.file.to_path_buf(),
            line,
            key,
            message: e.message().trim().to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "name = \"x\"\n[world]\nimage = \"w.png\"\n[[sketch]]\nname = \"A\"\n[[sketch]]\nname = \"B\"\nimage = \"b.png\"\n";

    #[test]
    fn finds_key_lines() {
        let ctx = Ctx {
            file: Path::new("s.toml"),
            source: TEXT,
        };
        assert_eq!(ctx.key_line(Table::Root, "name"), Some(1));
        assert_eq!(ctx.key_line(Table::Named("world"), "image"), Some(3));
        assert_eq!(ctx.key_line(Table::Array("sketch", 1), "name"), Some(7));
        assert_eq!(ctx.key_line(Table::Array("sketch", 1), "image"), Some(8));
        assert_eq!(ctx.key_line(Table::Array("sketch", 0), "image"), None);
        assert_eq!(ctx.key_at_line(8).as_deref(), Some("sketch[1].image"));
        assert_eq!(ctx.key_at_line(3).as_deref(), Some("world.image"));
        assert_eq!(ctx.key_at_line(6).as_deref(), Some("sketch[1]"));
    }
}
