//! The explicit registry of node kinds. Node-family crates expose `pub fn register(&mut Registry)`
//! and the binary calls each of them; nothing registers itself behind the user's back.

use std::any::Any;
use std::collections::BTreeMap;
use std::path::PathBuf;

use crate::node::{Ctx, Inputs, NodeError, NodeKind, Outputs, ParamIssue, Port, Validate};

/// Parameters parsed, defaulted and validated for one node of a graph.
pub struct PreparedParams {
    /// The params in canonical RON (every field, defaults filled in): part of the cache key.
    pub canonical: String,
    /// Files the node reads, as written (unresolved).
    pub input_files: Vec<PathBuf>,
    /// Files the node writes, as written (unresolved).
    pub output_files: Vec<PathBuf>,
    value: Box<dyn Any + Send + Sync>,
}

/// Why a node's params were rejected.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamError {
    /// RON did not parse or did not fit the params struct. `line`/`column` are 1-based and
    /// relative to the params text handed to [`DynNode::prepare`].
    Parse {
        message: String,
        line: usize,
        column: usize,
    },
    /// Parsed, but [`Validate`] found problems (ranges, consistency).
    Invalid(Vec<ParamIssue>),
}

/// A node kind with its types erased, as the engine sees it.
pub trait DynNode: Send + Sync {
    fn kind(&self) -> &'static str;
    fn version(&self) -> u32;
    fn doc(&self) -> &'static str;
    fn inputs(&self) -> Vec<Port>;
    fn outputs(&self) -> Vec<Port>;
    /// The default params as pretty RON, for `crestflow nodes KIND`.
    fn default_params(&self) -> String;
    /// Parses `ron_text` (a RON struct or `()`), fills defaults, validates.
    fn prepare(&self, ron_text: &str) -> Result<PreparedParams, ParamError>;
    fn run(
        &self,
        params: &PreparedParams,
        inputs: &Inputs,
        ctx: &Ctx,
    ) -> Result<Outputs, NodeError>;
}

struct Adapter<N: NodeKind>(std::marker::PhantomData<fn() -> N>);

fn ron_options() -> ron::Options {
    ron::Options::default()
}

impl<N: NodeKind> DynNode for Adapter<N> {
    fn kind(&self) -> &'static str {
        N::KIND
    }
    fn version(&self) -> u32 {
        N::VERSION
    }
    fn doc(&self) -> &'static str {
        N::DOC
    }
    fn inputs(&self) -> Vec<Port> {
        N::inputs()
    }
    fn outputs(&self) -> Vec<Port> {
        N::outputs()
    }
    fn default_params(&self) -> String {
        let pretty = ron::ser::PrettyConfig::new().struct_names(false);
        ron_options()
            .to_string_pretty(&N::Params::default(), pretty)
            .unwrap_or_else(|e| format!("<cannot show defaults: {e}>"))
    }
    fn prepare(&self, ron_text: &str) -> Result<PreparedParams, ParamError> {
        let params: N::Params =
            ron_options()
                .from_str(ron_text)
                .map_err(|e| ParamError::Parse {
                    message: e.code.to_string(),
                    line: e.span.start.line,
                    column: e.span.start.col,
                })?;
        let issues = params.validate();
        if !issues.is_empty() {
            return Err(ParamError::Invalid(issues));
        }
        let canonical = ron_options()
            .to_string(&params)
            .map_err(|e| ParamError::Parse {
                message: format!("params cannot be serialised: {e}"),
                line: 1,
                column: 1,
            })?;
        Ok(PreparedParams {
            canonical,
            input_files: N::input_files(&params),
            output_files: N::output_files(&params),
            value: Box::new(params),
        })
    }
    fn run(
        &self,
        params: &PreparedParams,
        inputs: &Inputs,
        ctx: &Ctx,
    ) -> Result<Outputs, NodeError> {
        let params = params.value.downcast_ref::<N::Params>().ok_or_else(|| {
            NodeError::internal(format!("params of {} have the wrong type", N::KIND))
        })?;
        N::run(params, inputs, ctx)
    }
}

/// All node kinds a program knows, by kind name.
#[derive(Default)]
pub struct Registry {
    kinds: BTreeMap<&'static str, Box<dyn DynNode>>,
}

impl Registry {
    pub fn new() -> Self {
        Self::default()
    }
    /// Adds a node kind. A second kind with the same name replaces the first (so a program can
    /// override a built-in node).
    pub fn add<N: NodeKind>(&mut self) -> &mut Self {
        self.kinds
            .insert(N::KIND, Box::new(Adapter::<N>(std::marker::PhantomData)));
        self
    }
    pub fn get(&self, kind: &str) -> Option<&dyn DynNode> {
        self.kinds.get(kind).map(|b| b.as_ref())
    }
    /// Kind names in alphabetical order.
    pub fn kinds(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.kinds.keys().copied()
    }
    pub fn len(&self) -> usize {
        self.kinds.len()
    }
    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }
}
