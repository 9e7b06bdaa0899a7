//! Load-time diagnostics: every problem of a pipeline file with its location. The engine only
//! collects them; the CLI renders them (with the source snippet).

use std::fmt;
use std::ops::Range;
use std::path::PathBuf;

/// What is wrong. Tests assert on this, users read the message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum DiagKind {
    /// The file is not valid RON.
    Syntax,
    /// Valid RON, but not the shape of a graph (`nodes` missing, a field that is not a string…).
    Structure,
    /// Two nodes (or two graph params, or two inputs) with the same name.
    Duplicate,
    /// No node kind of that name is registered.
    UnknownKind,
    /// A parameter the node kind does not have.
    UnknownParam,
    /// A parameter whose value does not parse into the expected type.
    BadParam,
    /// A parameter out of its range or inconsistent with others.
    InvalidParam,
    /// `$name` with no graph param `name`.
    UndefinedVar,
    /// `--set name=…` for a graph param the file does not declare.
    UnknownGraphParam,
    /// An input refers to a node that does not exist.
    UnknownNode,
    /// An input or output port the node kind does not have.
    UnknownPort,
    /// An edge whose two ends carry different types.
    TypeMismatch,
    /// A required input that is not connected.
    MissingInput,
    /// The edges form a cycle.
    Cycle,
    /// The file cannot be read.
    Io,
    /// Two nodes write the same file, or a node writes a file the graph reads.
    FileConflict,
}

/// One problem, located in the pipeline file when it came from one.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    pub kind: DiagKind,
    pub message: String,
    /// Byte range in the source text.
    pub span: Option<Range<usize>>,
    /// 1-based; 0 when there is no location.
    pub line: usize,
    pub column: usize,
    /// A hint (`did you mean …`).
    pub help: Option<String>,
    /// What the label under the snippet says.
    pub label: String,
}

impl Diagnostic {
    pub fn new(kind: DiagKind, message: impl Into<String>) -> Self {
        Diagnostic {
            kind,
            message: message.into(),
            span: None,
            line: 0,
            column: 0,
            help: None,
            label: String::new(),
        }
    }
    pub fn at(mut self, span: Option<Range<usize>>, label: impl Into<String>) -> Self {
        self.span = span;
        self.label = label.into();
        self
    }
    pub fn help(mut self, help: Option<String>) -> Self {
        self.help = help;
        self
    }
}

/// Why a graph could not be loaded: all problems found, in source order.
#[derive(Clone, Debug)]
pub struct LoadError {
    /// The pipeline file, when the graph came from one.
    pub file: Option<PathBuf>,
    /// Its text, for snippets.
    pub source_text: Option<String>,
    pub diagnostics: Vec<Diagnostic>,
}

impl LoadError {
    /// Whether some diagnostic has this kind.
    pub fn has(&self, kind: DiagKind) -> bool {
        self.diagnostics.iter().any(|d| d.kind == kind)
    }
    /// The diagnostics of one kind.
    pub fn of(&self, kind: DiagKind) -> Vec<&Diagnostic> {
        self.diagnostics.iter().filter(|d| d.kind == kind).collect()
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let file = self
            .file
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|| "<graph>".into());
        for (i, d) in self.diagnostics.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            if d.line > 0 {
                write!(f, "{file}:{}:{}: {}", d.line, d.column, d.message)?;
            } else {
                write!(f, "{file}: {}", d.message)?;
            }
            if let Some(h) = &d.help {
                write!(f, " ({h})")?;
            }
        }
        Ok(())
    }
}

impl std::error::Error for LoadError {}

/// Levenshtein distance, for "did you mean".
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for i in 1..=a.len() {
        cur[0] = i;
        for j in 1..=b.len() {
            let sub = prev[j - 1] + usize::from(a[i - 1] != b[j - 1]);
            cur[j] = sub.min(prev[j] + 1).min(cur[j - 1] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The closest candidate within a distance that scales with the word length.
pub fn did_you_mean<'a>(
    word: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<String> {
    let len = word.chars().count();
    let limit = (len / 3).max(2);
    candidates
        .into_iter()
        .map(|c| (edit_distance(word, c), c))
        .filter(|(d, _)| *d <= limit && *d < len)
        .min()
        .map(|(_, c)| format!("did you mean `{c}`?"))
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn distances() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(
            did_you_mean(
                "curvature.polynomal",
                ["curvature.polynomial", "io.load_mesh"]
            ),
            Some("did you mean `curvature.polynomial`?".into())
        );
        assert_eq!(did_you_mean("zzz", ["curvature.polynomial"]), None);
    }
}
