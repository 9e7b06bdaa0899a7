//! The graph model: named nodes with a kind, parameter text and input edges, plus graph-level
//! parameters. It is built from a RON pipeline file ([`Graph::from_ron`], DESIGN §3) or in code
//! ([`Graph::new`] and [`Graph::node`]); [`crate::load()`] turns it into a checked [`crate::Plan`].

use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::diag::{DiagKind, Diagnostic, LoadError};
use crate::spanned::{self, key_text, SKind, SValue};

/// A graph as written: not yet checked against a registry.
#[derive(Clone, Debug, Default)]
pub struct Graph {
    /// Graph-level params, name -> RON text of the value, in declaration order.
    pub params: Vec<GraphParam>,
    pub nodes: Vec<NodeSpec>,
    /// Relative paths in params are resolved against this folder (the pipeline file's folder).
    pub base_dir: PathBuf,
    /// The pipeline file and its text, when the graph came from one (for locations).
    pub file: Option<PathBuf>,
    pub source: Option<String>,
}

/// A graph-level parameter (`params: { "mesh": "…" }`), usable in node params as `$mesh`.
#[derive(Clone, Debug)]
pub struct GraphParam {
    pub name: String,
    /// The value as RON text.
    pub value: String,
    pub span: Option<Range<usize>>,
}

/// One node as written.
#[derive(Clone, Debug)]
pub struct NodeSpec {
    pub name: String,
    pub kind: String,
    /// The params as RON text (`(rings: 2)`), possibly with `$name` references.
    pub params: String,
    pub inputs: Vec<InputSpec>,
    pub name_span: Option<Range<usize>>,
    pub kind_span: Option<Range<usize>>,
    /// Where `params` starts in the source (the text is a verbatim slice of it).
    pub params_span: Option<Range<usize>>,
}

/// `"port": "node.output"`.
#[derive(Clone, Debug)]
pub struct InputSpec {
    pub port: String,
    /// `node.output` as written.
    pub from: String,
    pub port_span: Option<Range<usize>>,
    pub from_span: Option<Range<usize>>,
}

impl InputSpec {
    /// Splits `from` into node and port (at the last dot, so node names may not contain dots).
    pub fn source(&self) -> Option<(&str, &str)> {
        let (n, p) = self.from.rsplit_once('.')?;
        if n.is_empty() || p.is_empty() {
            None
        } else {
            Some((n, p))
        }
    }
}

/// A handle for adding inputs to a node built in code.
pub struct NodeBuilder<'g> {
    node: &'g mut NodeSpec,
}

impl NodeBuilder<'_> {
    /// Connects input `port` to `from` (`"node.output"`).
    pub fn input(self, port: &str, from: &str) -> Self {
        self.node.inputs.push(InputSpec {
            port: port.to_string(),
            from: from.to_string(),
            port_span: None,
            from_span: None,
        });
        self
    }
}

impl Graph {
    /// An empty graph whose relative paths resolve against `base_dir`.
    pub fn new(base_dir: impl Into<PathBuf>) -> Self {
        Graph {
            base_dir: base_dir.into(),
            ..Default::default()
        }
    }

    /// Adds a graph param (value as RON text, e.g. `"\"mesh.off\""` or `"3"`).
    pub fn param(&mut self, name: &str, ron_value: &str) -> &mut Self {
        self.params.push(GraphParam {
            name: name.into(),
            value: ron_value.into(),
            span: None,
        });
        self
    }

    /// Adds a node; `params` is RON text such as `"(rings: 2)"` (`""` means all defaults).
    pub fn node(&mut self, name: &str, kind: &str, params: &str) -> NodeBuilder<'_> {
        self.nodes.push(NodeSpec {
            name: name.into(),
            kind: kind.into(),
            params: if params.trim().is_empty() {
                "()".into()
            } else {
                params.into()
            },
            inputs: Vec::new(),
            name_span: None,
            kind_span: None,
            params_span: None,
        });
        let node = self.nodes.last_mut().expect("just pushed");
        NodeBuilder { node }
    }

    /// Reads and parses a pipeline file.
    pub fn from_file(path: &Path) -> Result<Graph, LoadError> {
        let text = crate::cache::ensure_regular_file(path)
            .and_then(|()| std::fs::read_to_string(path))
            .map_err(|e| LoadError {
                file: Some(path.to_path_buf()),
                source_text: None,
                diagnostics: vec![Diagnostic::new(
                    DiagKind::Io,
                    format!("cannot read {}: {e}", path.display()),
                )],
            })?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let base = if base.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            base
        };
        // A byte-order mark (some Windows editors write one) is not part of the RON.
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        Graph::from_ron(text, Some(path), &base)
    }

    /// Parses pipeline text. Structural problems are all reported, each with its location.
    pub fn from_ron(text: &str, file: Option<&Path>, base_dir: &Path) -> Result<Graph, LoadError> {
        let mut diags = Vec::new();
        let mut g = Graph {
            base_dir: base_dir.to_path_buf(),
            file: file.map(Path::to_path_buf),
            source: Some(text.to_string()),
            ..Default::default()
        };
        match spanned::parse(text) {
            Err(e) => diags.push(
                Diagnostic::new(DiagKind::Syntax, format!("RON syntax error: {}", e.message))
                    .at(Some(e.offset..e.offset), "here"),
            ),
            Ok(root) => read_graph(&root, text, &mut g, &mut diags),
        }
        if diags.is_empty() {
            Ok(g)
        } else {
            Err(g.error(diags))
        }
    }

    /// Wraps diagnostics with this graph's file and text, filling in lines and columns.
    pub fn error(&self, mut diagnostics: Vec<Diagnostic>) -> LoadError {
        if let Some(src) = &self.source {
            for d in &mut diagnostics {
                if let Some(s) = &d.span {
                    let (l, c) = spanned::line_col(src, s.start);
                    d.line = l;
                    d.column = c;
                }
            }
        }
        diagnostics.sort_by_key(|d| (d.span.is_none(), d.span.as_ref().map(|s| s.start)));
        LoadError {
            file: self.file.clone(),
            source_text: self.source.clone(),
            diagnostics,
        }
    }

    pub fn find(&self, name: &str) -> Option<&NodeSpec> {
        self.nodes.iter().find(|n| n.name == name)
    }
}

fn structure(span: &Range<usize>, message: impl Into<String>) -> Diagnostic {
    Diagnostic::new(DiagKind::Structure, message).at(Some(span.clone()), "here")
}

fn read_graph(root: &SValue, text: &str, g: &mut Graph, diags: &mut Vec<Diagnostic>) {
    let SKind::Struct { name, fields } = &root.kind else {
        diags.push(structure(
            &root.span,
            "a pipeline file is `Graph(params: {…}, nodes: {…})`",
        ));
        return;
    };
    if let Some(n) = name {
        if n != "Graph" {
            diags.push(structure(
                &root.span,
                format!("expected `Graph(…)`, found `{n}(…)`"),
            ));
        }
    }
    let mut saw_nodes = false;
    for f in fields {
        match f.name.as_str() {
            "params" => read_params(&f.value, text, g, diags),
            "nodes" => {
                saw_nodes = true;
                read_nodes(&f.value, text, g, diags);
            }
            other => diags.push(
                Diagnostic::new(
                    DiagKind::Structure,
                    format!("unknown graph field `{other}`"),
                )
                .at(Some(f.name_span.clone()), "not a graph field")
                .help(crate::diag::did_you_mean(other, ["params", "nodes"])),
            ),
        }
    }
    if !saw_nodes {
        diags.push(structure(
            &(root.span.start..root.span.start),
            "the graph has no `nodes: { … }`",
        ));
    }
}

/// A map's entries with string keys; reports non-string keys and duplicates.
fn string_map<'v>(
    v: &'v SValue,
    what: &str,
    diags: &mut Vec<Diagnostic>,
) -> Vec<(String, Range<usize>, &'v SValue)> {
    let SKind::Map(entries) = &v.kind else {
        diags.push(structure(
            &v.span,
            format!("{what} must be a map `{{ \"name\": … }}`"),
        ));
        return Vec::new();
    };
    let mut out: Vec<(String, Range<usize>, &SValue)> = Vec::new();
    for (k, val) in entries {
        let name = match &k.kind {
            SKind::Str(s) => s.clone(),
            _ => {
                diags.push(structure(
                    &k.span,
                    format!("{what}: keys are strings (\"name\")"),
                ));
                key_text(k)
            }
        };
        if out.iter().any(|(n, _, _)| *n == name) {
            diags.push(
                Diagnostic::new(
                    DiagKind::Duplicate,
                    format!("{what}: `{name}` is defined twice"),
                )
                .at(Some(k.span.clone()), "second definition")
                .help(Some(
                    "names must be unique; serde would silently keep only one".into(),
                )),
            );
            continue;
        }
        out.push((name, k.span.clone(), val));
    }
    out
}

fn read_params(v: &SValue, text: &str, g: &mut Graph, diags: &mut Vec<Diagnostic>) {
    for (name, span, val) in string_map(v, "graph params", diags) {
        g.params.push(GraphParam {
            name,
            value: text[val.span.clone()].to_string(),
            span: Some(span),
        });
    }
}

fn read_nodes(v: &SValue, text: &str, g: &mut Graph, diags: &mut Vec<Diagnostic>) {
    for (name, name_span, val) in string_map(v, "nodes", diags) {
        if name.contains('.') || name.is_empty() {
            diags.push(
                Diagnostic::new(
                    DiagKind::Structure,
                    format!("node name `{name}` must be non-empty and without dots"),
                )
                .at(Some(name_span.clone()), "bad name"),
            );
        }
        let SKind::Struct { fields, .. } = &val.kind else {
            diags.push(structure(
                &val.span,
                format!("node `{name}` must be `(kind: \"…\", params: (…), inputs: {{…}})`"),
            ));
            continue;
        };
        let mut node = NodeSpec {
            name: name.clone(),
            kind: String::new(),
            params: "()".into(),
            inputs: Vec::new(),
            name_span: Some(name_span.clone()),
            kind_span: None,
            params_span: None,
        };
        let mut has_kind = false;
        for f in fields {
            match f.name.as_str() {
                "kind" => match f.value.as_str() {
                    Some(k) => {
                        has_kind = true;
                        node.kind = k.to_string();
                        node.kind_span = Some(f.value.span.clone());
                    }
                    None => diags.push(structure(
                        &f.value.span,
                        "`kind` is a string such as \"io.load_mesh\"",
                    )),
                },
                "params" => {
                    node.params = text[f.value.span.clone()].to_string();
                    node.params_span = Some(f.value.span.clone());
                }
                "inputs" => {
                    for (port, port_span, from) in
                        string_map(&f.value, &format!("inputs of `{name}`"), diags)
                    {
                        match from.as_str() {
                            Some(s) => node.inputs.push(InputSpec {
                                port,
                                from: s.to_string(),
                                port_span: Some(port_span),
                                from_span: Some(from.span.clone()),
                            }),
                            None => diags
                                .push(structure(&from.span, "an input is a string \"node.port\"")),
                        }
                    }
                }
                other => diags.push(
                    Diagnostic::new(DiagKind::Structure, format!("unknown node field `{other}`"))
                        .at(Some(f.name_span.clone()), "not a node field")
                        .help(crate::diag::did_you_mean(
                            other,
                            ["kind", "params", "inputs"],
                        )),
                ),
            }
        }
        if !has_kind {
            diags.push(structure(
                &name_span,
                format!("node `{name}` has no `kind`"),
            ));
        }
        g.nodes.push(node);
    }
}
