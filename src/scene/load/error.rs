//! [`SceneError`]: every user mistake in a scene file, located (file, line and
//! column, or key path) and with its fix; the loader's two ways of making one.

use std::path::PathBuf;

use super::Loader;

/// A user mistake in a scene file (or a file it names).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file cannot be read.
    #[error("{}: cannot read the scene file: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why it cannot be read.
        source: std::io::Error,
    },
    /// TOML syntax, unknown keys, wrong types, missing keys: with line and column.
    #[error("{}:{line}:{column}: {message}\n{snippet}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// The 1-based line of the mistake.
        line: usize,
        /// The 1-based column of the mistake.
        column: usize,
        /// What is wrong.
        message: String,
        /// The source around the mistake, with a caret under it.
        snippet: String,
    },
    /// A file that is not a scene (e.g. OpenSCAD source).
    #[error("{}: {message}", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What it is and what to do instead.
        message: String,
    },
    /// A value that parses but is not valid, located by its key path.
    #[error("{}{}: {key}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Line of the table the key belongs to, when known.
        line: Option<usize>,
        /// The key, as a path from the top-level table.
        key: String,
        /// What is wrong with the value.
        message: String,
    },
}

impl Loader<'_> {
    pub(super) fn invalid(
        &self,
        line: Option<usize>,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_path_buf(),
            line,
            key: key.into(),
            message: message.into(),
        }
    }

    pub(super) fn syntax(&self, e: toml::de::Error) -> SceneError {
        let (line, column, snippet) = match e.span() {
            Some(span) => {
                let (l, c) = self.line_col(span.start);
                let src = self.text.lines().nth(l - 1).unwrap_or("");
                let width = self.text[span.start..span.end.min(self.text.len())]
                    .lines()
                    .next()
                    .map(|s| s.chars().count())
                    .unwrap_or(1)
                    .max(1);
                let gutter = l.to_string().len();
                let snippet = format!(
                    "{:g$} |\n{l} | {src}\n{:g$} | {}{}",
                    "",
                    "",
                    " ".repeat(c - 1),
                    "^".repeat(width),
                    g = gutter
                );
                (l, c, snippet)
            }
            None => (1, 1, String::new()),
        };
        SceneError::Syntax {
            path: self.path.to_path_buf(),
            line,
            column,
            message: e.message().trim_end().to_string(),
            snippet,
        }
    }
}
