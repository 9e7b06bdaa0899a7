//! Loading: parse -> resolve -> type-check every edge -> plan (DESIGN §3). Every problem is
//! collected and returned at once, each located in the pipeline file when there is one.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::ops::Range;
use std::path::{Path, PathBuf};

use petgraph::algo::{tarjan_scc, toposort};
use petgraph::graph::{DiGraph, NodeIndex};

use crate::diag::{did_you_mean, DiagKind, Diagnostic, LoadError};
use crate::graph::{Graph, NodeSpec};
use crate::node::{Port, PortType};
use crate::registry::{DynNode, ParamError, PreparedParams, Registry};
use crate::spanned::{self, SKind, SValue};

/// A checked graph, ready to run: nodes with their kinds and prepared params, typed edges and
/// a topological order.
pub struct Plan<'r> {
    /// Nodes in the order of the pipeline file.
    pub nodes: Vec<PlannedNode<'r>>,
    /// A topological order (indices into `nodes`); ties keep file order, so it is stable.
    pub order: Vec<usize>,
    pub base_dir: PathBuf,
    pub file: Option<PathBuf>,
}

/// One node of a [`Plan`].
pub struct PlannedNode<'r> {
    pub name: String,
    pub kind: &'r dyn DynNode,
    pub params: PreparedParams,
    /// The params text after `$name` substitution.
    pub params_text: String,
    pub inputs: Vec<Edge>,
    pub outputs: Vec<Port>,
    /// Nodes that read one of this node's outputs.
    pub dependents: Vec<usize>,
    /// 1-based line and column of the node's name in the pipeline file, when it has one.
    pub location: Option<(usize, usize)>,
}

/// An input edge: `port` reads `from_port` of node `from`.
#[derive(Clone, Debug)]
pub struct Edge {
    pub port: String,
    pub from: usize,
    pub from_port: String,
    pub ty: PortType,
}

/// Reads, parses and checks a pipeline file. `overrides` are `(name, RON text)` pairs from
/// `--set` (see [`parse_set`]).
pub fn load_file<'r>(
    path: &Path,
    registry: &'r Registry,
    overrides: &[(String, String)],
) -> Result<Plan<'r>, LoadError> {
    let graph = Graph::from_file(path)?;
    load(&graph, registry, overrides)
}

/// Checks a graph against a registry and plans it.
pub fn load<'r>(
    graph: &Graph,
    registry: &'r Registry,
    overrides: &[(String, String)],
) -> Result<Plan<'r>, LoadError> {
    let mut diags = Vec::new();

    // Graph params with overrides applied.
    let mut vars: BTreeMap<String, String> = BTreeMap::new();
    for p in &graph.params {
        vars.insert(p.name.clone(), p.value.clone());
    }
    for (name, value) in overrides {
        if vars.contains_key(name) {
            vars.insert(name.clone(), value.clone());
        } else {
            diags.push(
                Diagnostic::new(
                    DiagKind::UnknownGraphParam,
                    format!("--set {name}=…: the graph has no param `{name}`"),
                )
                .help(did_you_mean(name, vars.keys().map(String::as_str))),
            );
        }
    }

    // Duplicate names in a graph built in code (files report them while parsing).
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, n) in graph.nodes.iter().enumerate() {
        if index.insert(n.name.as_str(), i).is_some() {
            diags.push(
                Diagnostic::new(
                    DiagKind::Duplicate,
                    format!("node `{}` is defined twice", n.name),
                )
                .at(n.name_span.clone(), "second definition"),
            );
        }
    }
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, n) in graph.nodes.iter().enumerate() {
        index.entry(n.name.as_str()).or_insert(i);
    }

    // Resolve kinds and params.
    let mut resolved: Vec<Option<Resolved<'r>>> = Vec::new();
    for n in &graph.nodes {
        let Some(kind) = registry.get(&n.kind) else {
            diags.push(
                Diagnostic::new(
                    DiagKind::UnknownKind,
                    format!("node `{}`: unknown node kind `{}`", n.name, n.kind),
                )
                .at(n.kind_span.clone(), "no such kind")
                .help(
                    did_you_mean(&n.kind, registry.kinds())
                        .or_else(|| Some("`crestflow nodes` lists the kinds".to_string())),
                ),
            );
            resolved.push(None);
            continue;
        };
        let (prepared, text) = prepare_params(n, kind, &vars, &mut diags);
        resolved.push(Some((kind, prepared, text)));
    }

    // Edges.
    let mut edges: Vec<Vec<Edge>> = vec![Vec::new(); graph.nodes.len()];
    for (i, n) in graph.nodes.iter().enumerate() {
        let Some((kind, _, _)) = &resolved[i] else {
            continue;
        };
        let in_ports = kind.inputs();
        for inp in &n.inputs {
            let Some(port) = in_ports.iter().find(|p| p.name == inp.port) else {
                diags.push(
                    Diagnostic::new(
                        DiagKind::UnknownPort,
                        format!("node `{}` ({}) has no input `{}`", n.name, n.kind, inp.port),
                    )
                    .at(inp.port_span.clone(), "no such input")
                    .help(
                        did_you_mean(&inp.port, in_ports.iter().map(|p| p.name))
                            .or_else(|| Some(format!("inputs: {}", port_list(&in_ports)))),
                    ),
                );
                continue;
            };
            let Some((src_name, src_port)) = inp.source() else {
                diags.push(
                    Diagnostic::new(
                        DiagKind::Structure,
                        format!(
                            "input `{}` of `{}`: expected \"node.port\", found \"{}\"",
                            inp.port, n.name, inp.from
                        ),
                    )
                    .at(inp.from_span.clone(), "not node.port"),
                );
                continue;
            };
            let Some(&src) = index.get(src_name) else {
                diags.push(
                    Diagnostic::new(
                        DiagKind::UnknownNode,
                        format!("input `{}` of `{}` reads from `{src_name}`, which is not a node of this graph", inp.port, n.name),
                    )
                    .at(inp.from_span.clone(), "no such node")
                    .help(did_you_mean(src_name, index.keys().copied())),
                );
                continue;
            };
            let Some((src_kind, _, _)) = &resolved[src] else {
                continue;
            };
            let out_ports = src_kind.outputs();
            let Some(out) = out_ports.iter().find(|p| p.name == src_port) else {
                diags.push(
                    Diagnostic::new(
                        DiagKind::UnknownPort,
                        format!(
                            "node `{src_name}` ({}) has no output `{src_port}`",
                            src_kind.kind()
                        ),
                    )
                    .at(inp.from_span.clone(), "no such output")
                    .help(
                        did_you_mean(src_port, out_ports.iter().map(|p| p.name))
                            .or_else(|| Some(format!("outputs: {}", port_list(&out_ports)))),
                    ),
                );
                continue;
            };
            if out.ty != port.ty {
                diags.push(
                    Diagnostic::new(
                        DiagKind::TypeMismatch,
                        format!(
                            "{}.{} expects {}, got {} from {}.{} (node `{}` reads node `{src_name}` of kind {})",
                            n.kind, port.name, port.ty.name, out.ty.name, src_name, src_port, n.name, src_kind.kind()
                        ),
                    )
                    .at(inp.from_span.clone(), format!("this is a {}", out.ty.name)),
                );
                continue;
            }
            edges[i].push(Edge {
                port: inp.port.clone(),
                from: src,
                from_port: src_port.to_string(),
                ty: port.ty.clone(),
            });
        }
        for p in in_ports.iter().filter(|p| p.required) {
            if !n.inputs.iter().any(|i| i.port == p.name) {
                diags.push(
                    Diagnostic::new(
                        DiagKind::MissingInput,
                        format!(
                            "node `{}` ({}) needs input `{}` ({}), which is not connected",
                            n.name, n.kind, p.name, p.ty.name
                        ),
                    )
                    .at(n.name_span.clone(), "missing input")
                    .help(Some(format!(
                        "add `inputs: {{ \"{}\": \"<node>.<port>\" }}`",
                        p.name
                    ))),
                );
            }
        }
    }

    // Cycles and order.
    let mut pg: DiGraph<usize, ()> = DiGraph::new();
    let ids: Vec<NodeIndex> = (0..graph.nodes.len()).map(|i| pg.add_node(i)).collect();
    for (i, es) in edges.iter().enumerate() {
        for e in es {
            pg.update_edge(ids[e.from], ids[i], ());
        }
    }
    {
        if toposort(&pg, None).is_err() {
            for scc in tarjan_scc(&pg) {
                let self_loop = scc.len() == 1 && pg.contains_edge(scc[0], scc[0]);
                if scc.len() < 2 && !self_loop {
                    continue;
                }
                let mut members: Vec<usize> = scc.iter().map(|ix| pg[*ix]).collect();
                members.sort_unstable();
                let names: Vec<&str> = members
                    .iter()
                    .map(|&i| graph.nodes[i].name.as_str())
                    .collect();
                let first = &graph.nodes[members[0]];
                diags.push(
                    Diagnostic::new(
                        DiagKind::Cycle,
                        format!(
                            "the edges form a cycle through nodes {}",
                            names.join(" -> ")
                        ),
                    )
                    .at(first.name_span.clone(), "part of a cycle"),
                );
            }
        }
    }

    file_conflicts(graph, &resolved, &mut diags);

    if !diags.is_empty() {
        return Err(graph.error(diags));
    }

    // Stable topological order: Kahn's algorithm taking the lowest file index first.
    let order = stable_order(graph.nodes.len(), &edges);

    let mut nodes = Vec::with_capacity(graph.nodes.len());
    for ((n, r), es) in graph.nodes.iter().zip(resolved).zip(edges) {
        let (kind, prepared, text) = r.ok_or_else(|| graph.error(vec![internal(&n.name)]))?;
        let params = prepared.ok_or_else(|| graph.error(vec![internal(&n.name)]))?;
        nodes.push(PlannedNode {
            name: n.name.clone(),
            kind,
            params,
            params_text: text,
            inputs: es,
            outputs: kind.outputs(),
            dependents: Vec::new(),
            location: match (&graph.source, &n.name_span) {
                (Some(src), Some(span)) => Some(spanned::line_col(src, span.start)),
                _ => None,
            },
        });
    }
    for i in 0..nodes.len() {
        let froms: Vec<usize> = nodes[i].inputs.iter().map(|e| e.from).collect();
        for f in froms {
            if !nodes[f].dependents.contains(&i) {
                nodes[f].dependents.push(i);
            }
        }
    }
    Ok(Plan {
        nodes,
        order,
        base_dir: graph.base_dir.clone(),
        file: graph.file.clone(),
    })
}

/// Two nodes that write one file race (which one is left depends on the thread timing), and a
/// node that writes a file the graph reads destroys its own input (`--set out=.` beside the
/// mesh, with a save node's `$out/mesh.ply` the mesh itself): both are load errors, located
/// at the second node.
fn file_conflicts(graph: &Graph, resolved: &[Option<Resolved<'_>>], diags: &mut Vec<Diagnostic>) {
    let key = |f: &Path| crate::node::file_identity(&crate::node::resolve_path(&graph.base_dir, f));
    let mut writers: BTreeMap<PathBuf, usize> = BTreeMap::new();
    let mut readers: BTreeMap<PathBuf, usize> = BTreeMap::new();
    for (i, r) in resolved.iter().enumerate() {
        if let Some((_, Some(p), _)) = r {
            for f in &p.input_files {
                readers.entry(key(f)).or_insert(i);
            }
        }
    }
    for (i, r) in resolved.iter().enumerate() {
        let Some((_, Some(p), _)) = r else { continue };
        let n = &graph.nodes[i];
        for f in &p.output_files {
            let k = key(f);
            if let Some(&w) = writers.get(&k) {
                if w != i {
                    diags.push(
                        Diagnostic::new(
                            DiagKind::FileConflict,
                            format!(
                                "nodes `{}` and `{}` both write {}",
                                graph.nodes[w].name,
                                n.name,
                                k.display()
                            ),
                        )
                        .at(n.name_span.clone(), "writes the same file")
                        .help(Some("give one of them another path".into())),
                    );
                }
                continue;
            }
            writers.insert(k.clone(), i);
            if let Some(&r) = readers.get(&k) {
                diags.push(
                    Diagnostic::new(
                        DiagKind::FileConflict,
                        format!(
                            "node `{}` would write {}, which node `{}` reads",
                            n.name,
                            k.display(),
                            graph.nodes[r].name
                        ),
                    )
                    .at(n.name_span.clone(), "overwrites an input")
                    .help(Some(
                        "write the outputs to another folder (`--set out=…`)".into(),
                    )),
                );
            }
        }
    }
}

/// A node's kind, its params when they prepared cleanly, and the substituted params text.
type Resolved<'r> = (&'r dyn DynNode, Option<PreparedParams>, String);

fn internal(name: &str) -> Diagnostic {
    Diagnostic::new(
        DiagKind::Structure,
        format!("node `{name}` could not be prepared"),
    )
}

fn port_list(ports: &[Port]) -> String {
    if ports.is_empty() {
        return "none".into();
    }
    ports
        .iter()
        .map(|p| format!("{} ({})", p.name, p.ty.name))
        .collect::<Vec<_>>()
        .join(", ")
}

fn stable_order(n: usize, edges: &[Vec<Edge>]) -> Vec<usize> {
    let mut indeg = vec![0usize; n];
    let mut outs: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (i, es) in edges.iter().enumerate() {
        let mut froms: Vec<usize> = es.iter().map(|e| e.from).collect();
        froms.sort_unstable();
        froms.dedup();
        for f in froms {
            indeg[i] += 1;
            outs[f].push(i);
        }
    }
    let mut ready: std::collections::BTreeSet<usize> = (0..n).filter(|&i| indeg[i] == 0).collect();
    let mut order = Vec::with_capacity(n);
    while let Some(i) = ready.pop_first() {
        order.push(i);
        for &d in &outs[i] {
            indeg[d] -= 1;
            if indeg[d] == 0 {
                ready.insert(d);
            }
        }
    }
    order
}

/// Maps offsets in substituted text back to the original text.
struct PosMap {
    /// (start in substituted text, start in original, length in substituted, maps 1:1)
    segs: Vec<(usize, usize, usize, bool)>,
}

impl PosMap {
    fn to_orig(&self, off: usize) -> usize {
        for &(s, o, len, exact) in &self.segs {
            if off >= s && off < s + len {
                return if exact { o + (off - s) } else { o };
            }
        }
        self.segs
            .last()
            .map(|&(s, o, len, exact)| {
                if exact {
                    o + off.saturating_sub(s).min(len)
                } else {
                    o
                }
            })
            .unwrap_or(off)
    }
}

/// The text a `$name` inside a longer string expands to: a string's content, else its RON text.
fn var_text(ron_text: &str) -> String {
    match spanned::parse(ron_text) {
        Ok(SValue {
            kind: SKind::Str(s),
            ..
        }) => s,
        _ => ron_text.trim().to_string(),
    }
}

fn is_ident(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(ch) if ch.is_ascii_alphabetic() || ch == '_')
        && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
}

/// Expands `$name`, `${name}` and `$$` in a string's content. Err(name) for an undefined var.
fn interpolate(s: &str, vars: &BTreeMap<String, String>) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find('$') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        if let Some(a) = after.strip_prefix('$') {
            out.push('$');
            rest = a;
        } else if let Some(a) = after.strip_prefix('{') {
            let end = a.find('}').ok_or_else(|| a.to_string())?;
            let name = &a[..end];
            out.push_str(&var_text(vars.get(name).ok_or_else(|| name.to_string())?));
            rest = &a[end + 1..];
        } else {
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            if len == 0 {
                out.push('$');
                rest = after;
                continue;
            }
            let name = &after[..len];
            out.push_str(&var_text(vars.get(name).ok_or_else(|| name.to_string())?));
            rest = &after[len..];
        }
    }
    out.push_str(rest);
    Ok(out)
}

fn collect_strings<'a>(v: &'a SValue, out: &mut Vec<&'a SValue>) {
    match &v.kind {
        SKind::Str(s) if s.contains('$') => out.push(v),
        SKind::Struct { fields, .. } => fields.iter().for_each(|f| collect_strings(&f.value, out)),
        SKind::Tuple { items, .. } | SKind::List(items) => {
            items.iter().for_each(|i| collect_strings(i, out))
        }
        SKind::Map(es) => es.iter().for_each(|(k, v)| {
            collect_strings(k, out);
            collect_strings(v, out)
        }),
        _ => {}
    }
}

fn shift(span: &Range<usize>, base: Option<&Range<usize>>) -> Option<Range<usize>> {
    base.map(|b| b.start + span.start..b.start + span.end)
}

/// Substitutes graph params into a node's params text and prepares them with the node kind.
fn prepare_params(
    n: &NodeSpec,
    kind: &dyn DynNode,
    vars: &BTreeMap<String, String>,
    diags: &mut Vec<Diagnostic>,
) -> (Option<PreparedParams>, String) {
    let base = n.params_span.as_ref();
    let tree = match spanned::parse(&n.params) {
        Ok(t) => t,
        Err(e) => {
            diags.push(
                Diagnostic::new(
                    DiagKind::Syntax,
                    format!("params of `{}`: RON syntax error: {}", n.name, e.message),
                )
                .at(shift(&(e.offset..e.offset), base), "here"),
            );
            return (None, n.params.clone());
        }
    };
    let mut strings = Vec::new();
    collect_strings(&tree, &mut strings);
    strings.sort_by_key(|s| s.span.start);
    let mut text = String::new();
    let mut segs = Vec::new();
    let mut pos = 0;
    let mut ok = true;
    for s in strings {
        let content = s.as_str().unwrap_or_default();
        let whole = content
            .strip_prefix('$')
            .map(|r| {
                r.strip_prefix('{')
                    .and_then(|r| r.strip_suffix('}'))
                    .unwrap_or(r)
            })
            .filter(|name| is_ident(name));
        let replacement = match whole {
            Some(name) => vars.get(name).cloned().ok_or_else(|| name.to_string()),
            None => interpolate(content, vars).map(|t| spanned::quote(&t)),
        };
        match replacement {
            Ok(r) => {
                segs.push((text.len(), pos, s.span.start - pos, true));
                text.push_str(&n.params[pos..s.span.start]);
                segs.push((text.len(), s.span.start, r.len(), false));
                text.push_str(&r);
                pos = s.span.end;
            }
            Err(name) => {
                ok = false;
                diags.push(
                    Diagnostic::new(DiagKind::UndefinedVar, format!("node `{}`: `${name}` is not a graph param", n.name))
                        .at(shift(&s.span, base), "undefined")
                        .help(did_you_mean(&name, vars.keys().map(String::as_str)).or_else(|| {
                            Some(format!("declare it in `params: {{ \"{name}\": … }}` or escape the dollar as `$$`"))
                        })),
                );
            }
        }
    }
    segs.push((text.len(), pos, n.params.len() - pos, true));
    text.push_str(&n.params[pos..]);
    if !ok {
        return (None, text);
    }
    let map = PosMap { segs };
    match kind.prepare(&text) {
        Ok(p) => (Some(p), text),
        Err(ParamError::Parse {
            message,
            line,
            column,
        }) => {
            let unknown = message.starts_with("Unexpected field");
            let field = message.split('`').nth(1).unwrap_or("").to_string();
            let span = if unknown {
                match &tree.kind {
                    SKind::Struct { fields, .. } => fields
                        .iter()
                        .find(|f| f.name == field)
                        .map(|f| f.name_span.clone()),
                    _ => None,
                }
            } else {
                None
            }
            .or_else(|| {
                let off = map.to_orig(spanned::offset_of(&text, line, column));
                // ron points at or just after the offending value: underline that whole value.
                Some(value_at(&tree, off).unwrap_or(off..off))
            });
            let (dk, label) = if unknown {
                (DiagKind::UnknownParam, "unknown parameter")
            } else {
                (DiagKind::BadParam, "here")
            };
            let defaults = kind.default_params();
            diags.push(
                Diagnostic::new(dk, format!("node `{}` ({}): {message}", n.name, n.kind))
                    .at(span.and_then(|s| shift(&s, base)), label)
                    .help(Some(format!(
                        "parameters and defaults: {}",
                        one_line(&defaults)
                    ))),
            );
            (None, text)
        }
        Err(ParamError::Invalid(issues)) => {
            for issue in issues {
                let span = tree
                    .find_path(&issue.field)
                    .map(|(v, _)| v.span.clone())
                    .unwrap_or(tree.span.clone());
                diags.push(
                    Diagnostic::new(
                        DiagKind::InvalidParam,
                        format!(
                            "node `{}` ({}): parameter `{}`: {}",
                            n.name, n.kind, issue.field, issue.message
                        ),
                    )
                    .at(
                        shift(&span, base).or_else(|| n.name_span.clone()),
                        issue.message.clone(),
                    ),
                );
            }
            (None, text)
        }
    }
}

/// The smallest struct-field value whose span contains or ends at `off`.
fn value_at(v: &SValue, off: usize) -> Option<Range<usize>> {
    let mut best: Option<Range<usize>> = None;
    let mut stack = vec![v];
    while let Some(v) = stack.pop() {
        match &v.kind {
            SKind::Struct { fields, .. } => {
                for f in fields {
                    let s = &f.value.span;
                    if s.start <= off
                        && off <= s.end
                        && best.as_ref().is_none_or(|b| s.len() < b.len())
                    {
                        best = Some(s.clone());
                    }
                    stack.push(&f.value);
                }
            }
            SKind::Tuple { items, .. } | SKind::List(items) => stack.extend(items.iter()),
            SKind::Map(es) => stack.extend(es.iter().map(|(_, v)| v)),
            _ => {}
        }
    }
    best
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Parses a `--set name=value` argument into `(name, RON text)`. The value is taken as RON when
/// it parses as a RON value (numbers stay numbers), else as a string. A string that names an
/// existing relative path, or a relative path with a folder part whose folder exists, is made
/// absolute against `cwd`: users type paths relative to their shell, while paths written in a
/// graph file are relative to the file. When the graph is known, use [`parse_set_for`], which
/// also resolves paths that do not exist yet.
pub fn parse_set(arg: &str, cwd: &Path) -> Result<(String, String), String> {
    parse_set_in(arg, cwd, &BTreeSet::new())
}

/// [`parse_set`] for `graph`: a relative string set for one of its [`path_params`] is made
/// absolute against `cwd` whether or not it exists yet. Without that, `--set out=results`
/// named `results` beside the graph file on the first run (the folder did not exist) and in
/// the current folder once it did, so the second run had other keys and ran again.
pub fn parse_set_for(arg: &str, cwd: &Path, graph: &Graph) -> Result<(String, String), String> {
    parse_set_in(arg, cwd, &path_params(graph))
}

/// The graph params that hold paths: a string default with a folder part or a file extension
/// (`"../data/fandisk.off"`, `"scan.ply"`), or a param that node params use as a folder
/// (`"$out/render.png"`, `"${out}/x"`).
pub fn path_params(graph: &Graph) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for p in &graph.params {
        let default_is_path = match spanned::parse(&p.value) {
            Ok(SValue {
                kind: SKind::Str(s),
                ..
            }) => looks_like_path(&s),
            _ => false,
        };
        let used_as_folder = graph.nodes.iter().any(|n| {
            [format!("${}/", p.name), format!("${{{}}}/", p.name)]
                .iter()
                .any(|pat| n.params.contains(pat.as_str()))
        });
        if default_is_path || used_as_folder {
            out.insert(p.name.clone());
        }
    }
    out
}

/// Whether a string reads as a path by its form alone: a folder separator, or a file
/// extension of one to five characters that is not all digits (`mesh.off`, not `1.5`).
fn looks_like_path(s: &str) -> bool {
    if s.contains('/') || s.contains('\\') {
        return true;
    }
    match s.rsplit_once('.') {
        Some((stem, ext)) => {
            !stem.is_empty()
                && (1..=5).contains(&ext.len())
                && ext.chars().all(|c| c.is_ascii_alphanumeric())
                && !ext.chars().all(|c| c.is_ascii_digit())
        }
        None => false,
    }
}

fn parse_set_in(
    arg: &str,
    cwd: &Path,
    path_params: &BTreeSet<String>,
) -> Result<(String, String), String> {
    let (name, value) = arg
        .split_once('=')
        .ok_or_else(|| format!("--set expects name=value, got `{arg}`"))?;
    let name = name.trim();
    if !is_ident(name) {
        return Err(format!("--set: `{name}` is not a param name"));
    }
    let as_string = match spanned::parse(value) {
        Ok(SValue {
            kind: SKind::Str(s),
            ..
        }) => Some(s),
        Ok(SValue {
            kind: SKind::Ident(id),
            ..
        }) if !matches!(id.as_str(), "true" | "false" | "None" | "inf" | "NaN") => {
            Some(value.to_string())
        }
        Ok(_) => None,
        Err(_) => Some(value.to_string()),
    };
    let ron_text = match as_string {
        None => value.to_string(),
        Some(s) => {
            let p = Path::new(&s);
            let looks_like_path = !s.is_empty()
                && p.is_relative()
                && (path_params.contains(name)
                    || cwd.join(p).exists()
                    || (p.parent().is_some_and(|d| !d.as_os_str().is_empty())
                        && cwd.join(p).parent().is_some_and(Path::is_dir)));
            if looks_like_path {
                spanned::quote(&cwd.join(p).to_string_lossy())
            } else {
                spanned::quote(&s)
            }
        }
    };
    Ok((name.to_string(), ron_text))
}

impl Plan<'_> {
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    /// Parallel stages: stage k holds the nodes whose longest path from a source has k edges.
    pub fn stages(&self) -> Vec<Vec<usize>> {
        let mut level = vec![0usize; self.nodes.len()];
        for &i in &self.order {
            for e in &self.nodes[i].inputs {
                level[i] = level[i].max(level[e.from] + 1);
            }
        }
        let max = level.iter().copied().max().map(|m| m + 1).unwrap_or(0);
        let mut stages = vec![Vec::new(); max];
        for &i in &self.order {
            stages[level[i]].push(i);
        }
        stages
    }

    /// The plan as text (`crestflow explain`).
    pub fn explain(&self) -> String {
        let mut s = String::new();
        let file = self
            .file
            .as_ref()
            .map(|f| f.display().to_string())
            .unwrap_or_else(|| "<graph>".into());
        let _ = writeln!(
            s,
            "plan for {file}: {} nodes, paths relative to {}",
            self.nodes.len(),
            self.base_dir.display()
        );
        for (k, stage) in self.stages().iter().enumerate() {
            let _ = writeln!(
                s,
                "stage {k} ({} node{} can run in parallel)",
                stage.len(),
                if stage.len() == 1 { "" } else { "s" }
            );
            for &i in stage {
                let n = &self.nodes[i];
                let _ = writeln!(s, "  {} [{} v{}]", n.name, n.kind.kind(), n.kind.version());
                let _ = writeln!(s, "      params  {}", n.params.canonical);
                for e in &n.inputs {
                    let _ = writeln!(
                        s,
                        "      in      {} <- {}.{} ({})",
                        e.port, self.nodes[e.from].name, e.from_port, e.ty.name
                    );
                }
                for o in &n.outputs {
                    let readers: Vec<String> = n
                        .dependents
                        .iter()
                        .flat_map(|&d| {
                            self.nodes[d]
                                .inputs
                                .iter()
                                .filter(|e| e.from == i && e.from_port == o.name)
                                .map(move |e| format!("{}.{}", self.nodes[d].name, e.port))
                        })
                        .collect();
                    let to = if readers.is_empty() {
                        String::from("(unused)")
                    } else {
                        format!("-> {}", readers.join(", "))
                    };
                    let _ = writeln!(s, "      out     {} ({}) {to}", o.name, o.ty.name);
                }
                for f in &n.params.input_files {
                    let _ = writeln!(
                        s,
                        "      reads   {}",
                        crate::node::resolve_path(&self.base_dir, f).display()
                    );
                }
                for f in &n.params.output_files {
                    let _ = writeln!(
                        s,
                        "      writes  {}",
                        crate::node::resolve_path(&self.base_dir, f).display()
                    );
                }
            }
        }
        s
    }

    /// Graphviz dot.
    pub fn to_dot(&self) -> String {
        let mut s = String::from(
            "digraph crestflow {\n  rankdir=LR;\n  node [shape=box, fontname=\"monospace\"];\n",
        );
        for n in &self.nodes {
            let _ = writeln!(
                s,
                "  \"{}\" [label=\"{}\\n{}\"];",
                esc(&n.name),
                esc(&n.name),
                esc(n.kind.kind())
            );
        }
        for (i, n) in self.nodes.iter().enumerate() {
            let _ = i;
            for e in &n.inputs {
                let _ = writeln!(
                    s,
                    "  \"{}\" -> \"{}\" [label=\"{} -> {}\\n{}\"];",
                    esc(&self.nodes[e.from].name),
                    esc(&n.name),
                    esc(&e.from_port),
                    esc(&e.port),
                    esc(&e.ty.name)
                );
            }
        }
        s.push_str("}\n");
        s
    }

    /// Mermaid flowchart.
    pub fn to_mermaid(&self) -> String {
        let mut s = String::from("flowchart LR\n");
        for (i, n) in self.nodes.iter().enumerate() {
            let _ = writeln!(s, "  n{i}[\"{}<br/>{}\"]", mer(&n.name), mer(n.kind.kind()));
        }
        for (i, n) in self.nodes.iter().enumerate() {
            for e in &n.inputs {
                let _ = writeln!(
                    s,
                    "  n{} -->|\"{} → {}: {}\"| n{i}",
                    e.from,
                    mer(&e.from_port),
                    mer(&e.port),
                    mer(&e.ty.name)
                );
            }
        }
        s
    }
}

fn esc(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}
fn mer(s: &str) -> String {
    s.replace('"', "#quot;")
        .replace('<', "#lt;")
        .replace('>', "#gt;")
}

impl std::fmt::Debug for Plan<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let nodes: Vec<String> = self
            .nodes
            .iter()
            .map(|n| format!("{} [{}]", n.name, n.kind.kind()))
            .collect();
        f.debug_struct("Plan")
            .field("file", &self.file)
            .field("nodes", &nodes)
            .field("order", &self.order)
            .finish()
    }
}
