//! The `crestflow` binary's library side: the registry of every built-in node family, shared by
//! the CLI, the end-to-end tests and the examples, and the command line itself ([`app`]).

use crestflow_flow::Registry;

pub mod app;
pub mod batch;
pub mod experiment;
pub mod watch;

/// A registry with every built-in node kind.
pub fn registry() -> Registry {
    let mut reg = Registry::new();
    crestflow_nodes_io::register(&mut reg);
    crestflow_nodes_curvature::register(&mut reg);
    crestflow_nodes_ridges::register(&mut reg);
    crestflow_nodes_render::register(&mut reg);
    crestflow_nodes_eval::register(&mut reg);
    crestflow_nodes_shapes::register(&mut reg);
    crestflow_nodes_smooth::register(&mut reg);
    crestflow_nodes_symmetry::register(&mut reg);
    crestflow_nodes_geodesic::register(&mut reg);
    crestflow_nodes_descriptors::register(&mut reg);
    crestflow_nodes_remesh::register(&mut reg);
    crestflow_nodes_spectral::register(&mut reg);
    crestflow_nodes_selection::register(&mut reg);
    crestflow_nodes_scale::register(&mut reg);
    crestflow_nodes_fmap::register(&mut reg);
    reg
}
