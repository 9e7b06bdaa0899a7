//! `remesh.isotropic`: feature-constrained isotropic remeshing, thesis §5.1.1 after Botsch &
//! Kobbelt 2004 ("A remeshing approach to multiresolution modeling"); the features that
//! constrain it are the (scale-conforming, §4.3) feature curve network, sharp edges and
//! boundaries.
//!
//! Each of `iterations` rounds, at target edge length L:
//! 1. split every edge longer than 4/3 L at its midpoint (repeated until none is left);
//! 2. collapse every edge shorter than 4/5 L (into its midpoint when both ends are free)
//!    unless that creates an edge longer than 4/3 L, breaks the link condition, turns a
//!    surviving triangle by more than 60°, or creates an angle below both 20° and the
//!    smallest angle of the triangles it changes; within one sweep a vertex takes part in
//!    one collapse only (the next sweep continues), so a coarse target thins a dense input
//!    evenly instead of merging one growing vertex again and again;
//! 3. flip edges when that brings the valences of the four vertices closer to their targets
//!    (6 inside, including crease vertices; at corners and on the boundary one triangle per
//!    60° of each sector between feature edges, 4 on a straight boundary), in squared
//!    deviation, unless the pair of triangles gets an angle below both 30° and its old
//!    smallest angle; and flip any edge whose pair has an angle below 30° when that raises
//!    the pair's smallest angle. Inside the rounds a flip that leaves the deviation of an
//!    irregular quad unchanged is made as well ("sideways", where the pair folds by less
//!    than 25°, its corners' normals agree within 40° and no corner or neighbour of one is a
//!    feature vertex): it moves a 5–7 pair by one edge, and pairs that meet one of the
//!    opposite orientation cancel, which flips that must lower the deviation never do (the
//!    bunny's valence-6 share 0.79 → 0.80–0.83 with limits of 5° / 10°, 0.85–0.88 with
//!    25° / 40°). Each sweep visits every edge once. In the last round and after it no
//!    split follows: there a flip may not make an edge longer than
//!    the split length whose middle lies farther than `FAR_POINT`·L from the input (and than
//!    the old edge's), a chord across a curved pair. No flip crosses a fold steeper than 60°
//!    unless the pair spans a crease of the input that the other diagonal follows (its
//!    middle farther than `FAR_POINT`·L from the input, the other's within half that
//!    distance): that flip is made whatever the valences, under the angle rule (on the
//!    armadillo at 1 % such chords were the largest distance, 0.35–0.48 L off); where the
//!    projection walk gives up on one of the two middles, no such flip (the BVH is not built
//!    for it);
//! 4. tangential relaxation: every free vertex moves to the area-weighted centroid of its
//!    incident triangles' centroids, projected onto its tangent plane (feature vertices slide
//!    along their chain, see below); with `relaxation: Lloyd`, to the centroid of its Voronoi
//!    cell instead (the part of each incident triangle nearer to it than to the other two
//!    corners, with the middle of the longest side in place of the circumcentre of an obtuse
//!    triangle), in every round but the last. A closed part collapsed to a tetrahedron (four
//!    vertices of valence 3) is drawn together by these moves, to a single point on a coarse
//!    part or toward a fixed vertex: there no move may bring a vertex within 0.5 L of a
//!    neighbour and closer than it was;
//! 5. projection onto the input surface: a walk over the input triangles from the face the
//!    vertex was last projected onto, to a local minimum of the distance, with the exact
//!    closest point of a BVH as the fallback ([`crate::project`]; the start face is kept
//!    through splits and collapses);
//!
//! step 4 repeats `smoothing_steps` times per round, step 5 follows the last of them. After the
//! last round, an edge between two free vertices collapses when that lowers the squared valence
//! deviation of the four corners of its pair (a 5–5 edge between two 7s becomes one regular vertex
//! between two regular ones, where a flip would make 4s and 8s), under the tests of step 2 with
//! edges up to 1.5 L and angles down to 30° instead of 20°, and only where both removed vertices
//! lie within 0.1 L of the triangles that replace them, with the merged vertex at the edge's
//! middle or, where that fails, at its ring's centroid on the input (report
//! `valence_collapses_recentred`; the sphere's valence-6 share 0.883 → 0.887); two relaxation
//! steps follow (bunny at 2 %: valence-6 share 0.801 → 0.821, ellipsoid 0.866 → 0.883). Before
//! those steps, the inverse: a free vertex of valence 7 or more splits into two joined vertices
//! when that lowers the squared valence deviation of it and the two ring vertices that gain an
//! edge (a 7 with two 5s becomes a 5 and a 6 beside two 6s, an 8 two 6s), with the two vertices
//! at their rings' centroids on the input, their triangles at 30° or more (or no smaller than
//! before), turned by at most 60°, sides of 0.6–4/3 of the local target, and no input vertex
//! nearby left farther than before and than 0.15 L (bunny at
//! 2 %: 0.869 → 0.878; cgal_fandisk_large at 2 %, every sharp edge kept: 0.538 → 0.551 and smallest
//! angle 17.25° → 18.89°). Then a triangle still below 30° loses its shortest edge when that
//! collapse raises the smallest angle around it, allowing edges up to 2 L (under the feature rules
//! of step 2): a vertex left near a corner or a feature, whose collapse every round refused for an
//! edge just over 4/3 L, goes. A cap (an angle of 150° or more) whose shortest side fails the link
//! condition, as beside a fixed tip of valence 3, loses its middle vertex along one of its other
//! two sides instead, where both vertices' old places stay within 0.1 L of the new triangles (the
//! subdivided armadillo at 2 % without features: 0.47° → 30.02°). A boundary edge has one
//! half-edge, and a collapse removes its origin; where that is refused, the sliver collapses
//! also try removing its target into its origin (a boundary chain vertex beside a boundary
//! corner). Then one more flip sweep (step 3) runs, since relaxation moved the
//! vertices, and a free vertex of a triangle still below 30° moves to the best of a few nearby
//! positions on the input surface when that raises the smallest angle of its triangles and they
//! stay within 15° of their mean normal (beside curved features, whose bends pin short feature
//! edges); where they spread wider, only when the move lifts their smallest angle to 30° (on curved
//! patches small gains are not worth the change of surface; the armadillo's conforming remesh kept
//! one triangle of 27.5–28.6°). The vertices to move are coloured greedily in face order so that no
//! two of a colour are neighbours; the moves of one colour do not change what the others of it
//! find, so they are planned on the pool and made colour by colour (the default fandisk_large at 2
//! %, where most of these moves are made, about 6 % faster on two threads). Those moves change
//! which flips raise a pair's smallest angle (a free vertex fanning over short feature edges ends
//! up beside them), so the flip sweep and the moves run once more. Where a triangle is still below
//! 30°, its free corners may move onto an input vertex up to 0.8 L away for any gain in their fans'
//! smallest angle (no turn over 60°, no chord off the surface), each round followed by the nearby
//! moves again; the vertices so moved go back in groups (joined by edges) unless every triangle
//! around a group ends at 30° or more and no group vertex is next to a feature chain (a vertex
//! inside one, or a corner where two feature edges meet; such vertices do not take these moves
//! either). That takes a claw thinner than L, whose fixed tip has its three neighbours on one side
//! of it, to 30° (the subdivided armadillo at 2 % with its axes as `zxy`: 3.10° before). Beside
//! feature chains the moves left the smallest angles as they were and moved the Hausdorff distance
//! by up to 12 %, and trying them there made the armadillo at 2 % a third slower. Last, where the
//! output cuts off a tip or a thin rim of the input by more than 0.3 L (the bunny's ears at 2 %, by
//! 0.84 L before this step), an edge of the closest output triangle is flipped when that brings the
//! input vertex within 0.7 times its distance without worse valences (an edge across a crease),
//! else a free vertex of that triangle moves onto the cut-off input vertex (or, when all three
//! corners are feature vertices, a free neighbour of them) when its triangles keep angles of at
//! least 30° and no point around them ends up farther from the input than 0.3 L, than before, or
//! than 0.7 times the distance of the point pulled in. Where no vertex may move, an edge of that
//! triangle is split with the new vertex on the input point, under the same tests; a new triangle
//! below 30° may be flipped with its neighbour across the side opposite the new vertex (the only
//! way between two rows of fixed vertices). Where neither is allowed, a free corner moves three
//! quarters, half or a quarter of the way (projected onto the input) when that brings the input
//! vertex within 0.3 L, keeps its triangles at 30° or more, and leaves every point around them
//! within 0.3 L of the input or as near as before. Where no vertex moves part of the way either,
//! an edge of that triangle is split part of the way under the same tests: the new vertex three
//! quarters or half of the way from the edge's middle to the input point (on the input), or, on
//! an inner feature chain, at the point of its crease farthest from the edge, then at the
//! crease's middle (cgal_fandisk_large, scale conforming at 1 %: an input vertex 0.44 L from the
//! output before, 0.34 L after). Those moves can leave chords of the output off the input: last,
//! an edge whose middle lies farther than 0.3 L from the input, where the other diagonal of its
//! pair lies within half that, is flipped when the angle rule of step 3 allows, whatever the
//! valences (report `far_chord_flips`; the subdivided armadillo at 1 %, scale conforming: 6
//! flips, Hausdorff distance 0.00505 → 0.00362 of the diagonal).
//!
//! With `feature_grading` > 0 the target is local: L, except near stretches of feature chain
//! whose bends only allow shorter edges (their [`Chain::edge_capacity`] under the tolerance),
//! where it is that capacity, growing by `feature_grading` times the distance over mesh edges;
//! steps 1 and 2 then compare each edge with the mean local target of its two ends.
//!
//! Feature constraints (thesis §5.1.1, items 1–2): feature edges are never flipped; a feature
//! vertex is only removed by collapsing along its own chain into a vertex of the same chain or
//! a corner; corners (see [`crate::features`]) never move and are never removed (except that
//! the two corners at the ends of a curve chain shorter than 0.3 L merge: one network
//! junction whose curves reach the input's edges at two vertices); other feature
//! vertices slide along their chain (the arc-length parametrised polyline of input feature
//! edges, [`crate::chain`]; for a chain of curve edges, the network's own polyline, onto which
//! the relaxation moves its vertices, or the edge path without relaxation; a network edge
//! that strays more than L from the surface gives way to its edge path) to the middle of
//! their two chain neighbours, or, where that would cut a bend, onto the sharpest bend
//! between them (not where both neighbours stand for one end of the chain); split feature
//! edges get their new vertex at the middle of their stretch of chain. Every output feature edge
//! stays within `feature_tolerance` · L of the stretch of chain it replaces: a slide or a
//! collapse that would cut a bend of the chain is not made, so the bends of a feature (and
//! its input vertices there) are kept exactly while straight stretches are resampled freely.
//! Boundary edges are features, so boundaries are preserved, but not edge for edge: a boundary
//! chain's tolerance is `boundary_tolerance` (default 0.25 L), and a boundary vertex is a corner
//! only where the boundary turns by more than `corner_angle_deg` at the scale of L
//! and not within L of a corner by its feature edges
//! ([`crate::features::mark_boundary_corners`]), so a scan's ragged boundary, which turns by a
//! right angle at nearly every input vertex, is resampled at the target length
//! (pymeshlab_face000_rangemap at 2 %, scale conforming: 3,808 output boundary edges before,
//! 603 after, and angles below 30° 19.9 % → 2.1 %). A boundary vertex slides only where its
//! triangles keep their orientation and angles of 30° (or their old smallest angle): a
//! boundary that folds back on itself (a crack the repair of a non-manifold mesh leaves) would
//! otherwise bring its two sides' vertices together. On a loop of few vertices the stretch a
//! vertex slides along is the one through it, even when that is the longer way round
//! ([`Chain::interval_through`]). Curve chains that stand for a boundary (both ends on it, every
//! point within `boundary_tolerance` · L of it: the boundaries in a network of sharp edges) give
//! way to it ([`crate::features::drop_curves_along_boundaries`], report
//! `curve_edges_along_boundaries`): kept beside the resampled boundary, a curve vertex slid
//! onto the boundary edge between two corners. A hole bounded by three edges shorter than
//! L / 2 cannot be resampled at all; it is closed by a triangle first ([`crate::holes`],
//! report `holes_closed`). How curves become mesh edges is in
//! [`crate::features`]; sharp-edge chains that end freely at both ends and are shorter than
//! `min_feature_length` target lengths are dropped (a feature below the scale, thesis §4.3).
//! Tips narrower than L and corners of the part where creases meet ([`crate::tips`]) stay
//! fixed like feature corners, also when the creases themselves are not features: without
//! that, which of a box's corners the output cuts off (by up to 0.64 L on cgal_fandisk at
//! 2 %, curves only) depends on the order of the sweeps. Two fixed vertices closer than the
//! collapse length would pin an edge no collapse may remove: a curve ending within 4/5 L of
//! a tip is trimmed back to that distance ([`crate::features::trim_curve_ends_near`]), a tip
//! that close to a fixed feature corner is dropped, and so is a part corner that close to
//! any feature vertex.
//!
//! Termination: a fixed number of rounds, at most 64 split and 4 collapse sweeps per round,
//! and a vertex cap (local targets are never below L / 20). A target below 1/20 of the input's
//! mean edge length is rejected.
//! Locality: after each round's sweeps the mesh is compacted; when splits have grown it past
//! 1.5 times its size at the last numbering (a target finer than the input's edges), it is
//! also renumbered with every vertex beside the input vertex it descends from
//! ([`HalfEdgeMesh::compact_by_key`]), since split vertices are appended at the end of the
//! arrays. Meshes that do not grow keep their numbering.
//! Determinism: every sweep visits edges in slot order; relaxation and projection compute new
//! positions from old ones (Jacobi) with [`Par::map_collect`], while chain vertices slide one
//! after the other in vertex order (reading only chain parameters and fixed corners), so the
//! output is bit for bit the same at any thread count. Called from outside a rayon pool with
//! `Par::Rayon`, the whole run moves onto a pool thread ([`Par::install`]).

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::bvh::Aabb;
use crestflow_geom::halfedge::{self, HalfEdgeError, HalfEdgeMesh, NONE};
use crestflow_geom::locality::{median_corner_spread, spatially_ordered_with};
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{FeatureCurveNetwork, TriMesh};

use crate::chain::Chain;
use crate::features::{
    build_chains, drop_curves_along_boundaries, mark_boundary_corners, mark_features,
    prune_short_sharp_chains, trim_curve_ends_near, FeatureError,
};
use crate::holes::close_small_triangular_holes;
use crate::project::Projector;
use crate::tips::{clear_of_fixed, part_corners, TipField};

mod collapse;
mod far_points;
mod feature_rules;
mod flip;
mod relax;
mod slivers;
mod split;
mod valence;

use relax::Slide;

/// Parameters of `remesh.isotropic`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IsotropicParams {
    /// Target edge length: a fraction of the input's bounding-box diagonal when `relative`
    /// (default 0.01 = 1 %), else an absolute length. In (0, 1e12].
    pub target: f64,
    /// Whether `target` is relative to the bounding-box diagonal (default true).
    pub relative: bool,
    /// Rounds of split / collapse / flip / relax / project (default 10, range 0..=1000).
    pub iterations: usize,
    /// Keep edges whose dihedral angle exceeds `sharp_angle_deg` as features (default true).
    pub sharp_edges: bool,
    /// Angle between the two face normals above which an edge is sharp, in degrees (default
    /// 30, range [1, 179]).
    pub sharp_angle_deg: f64,
    /// A feature vertex with two feature edges that turn by more than this (degrees) is a
    /// corner and stays fixed (default 60, range [0, 180]).
    pub corner_angle_deg: f64,
    /// Refuse targets that would create more vertices than this (estimated from the area;
    /// default 20 000 000).
    pub max_vertices: usize,
    /// Tangential relaxation sweeps per round, followed by one projection onto the input
    /// (default 5, range 0..=100; 0 turns both off). More sweeps give rounder triangles. With
    /// 0, curves from `curves` follow their path over the input's edges instead of the
    /// network's polyline, since nothing moves the path's vertices onto it.
    pub smoothing_steps: usize,
    /// Chains of sharp edges that end freely at both ends and are shorter than this many
    /// target lengths are not kept (default 1, range [0, 1e6]; 0 keeps all). Boundaries and
    /// curves from `curves` are always kept.
    pub min_feature_length: f64,
    /// How far (a fraction of the target length) an output feature edge may stray from the
    /// feature polyline it replaces (default 0.002, range [0, 1]). Feature vertices slide
    /// along their chain and chain vertices are collapsed only while every input point of the
    /// chain stays this close to the output edges, so bends of a feature are kept exactly.
    pub feature_tolerance: f64,
    /// How far (a fraction of the target length) an output boundary edge may stray from the
    /// input boundary it replaces (default 0.25, range [0, 1]): `feature_tolerance` for
    /// boundaries. Boundary vertices slide along the input boundary and are collapsed
    /// while every input boundary point stays this close to the output's boundary edges, and
    /// a boundary vertex is a corner only where the boundary turns by more than
    /// `corner_angle_deg` at the scale of the target (see
    /// [`crate::features::mark_boundary_corners`]), so a scan's ragged boundary is resampled
    /// at the target length instead of being kept edge for edge.
    pub boundary_tolerance: f64,
    /// Local refinement along features (default 0 = off: one target length everywhere). A
    /// curved feature kept within `feature_tolerance` needs edges shorter than the target;
    /// when this is positive, the local target length near such a stretch is the longest edge
    /// the feature allows there, growing away from it by this fraction of the distance (range
    /// [0, 100]; 0.3 grades over a few rings), so the triangles along short feature edges are
    /// not needles. More vertices, fewer small angles, smaller Hausdorff distance.
    pub feature_grading: f64,
    /// Where relaxation moves a free vertex (default `Centroids`). `Lloyd` moves it to the
    /// centroid of its Voronoi cell in all rounds but the last, which makes the cells
    /// hexagonal: more vertices of valence 6 (on cgal_fandisk_large at 2 %, scale-conforming
    /// curves, 0.775 → 0.798), at the price of a few corners and tips that the last passes
    /// then cannot repair (docs/scale-remesh-log.md, version 22).
    pub relaxation: Relaxation,
}

/// How tangential relaxation moves a free vertex (`IsotropicParams::relaxation`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Relaxation {
    /// To the area-weighted centroid of its triangles' centroids (Botsch & Kobbelt 2004).
    #[default]
    Centroids,
    /// To the centroid of its Voronoi cell within its triangles (a Lloyd step towards a
    /// centroidal Voronoi tessellation, as in Alliez et al. 2003 and Yan et al. 2009), except
    /// in the last round, which takes the triangles' centroids.
    Lloyd,
}

impl Default for IsotropicParams {
    fn default() -> Self {
        IsotropicParams {
            target: 0.01,
            relative: true,
            iterations: 10,
            sharp_edges: true,
            sharp_angle_deg: 30.0,
            corner_angle_deg: 60.0,
            max_vertices: 20_000_000,
            smoothing_steps: 5,
            min_feature_length: 1.0,
            feature_tolerance: 0.002,
            boundary_tolerance: 0.25,
            feature_grading: 0.0,
            relaxation: Relaxation::Centroids,
        }
    }
}

impl Validate for IsotropicParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "target", self.target, f64::MIN_POSITIVE, 1e12);
        check_range(&mut v, "iterations", self.iterations, 0, 1000);
        check_range(&mut v, "sharp_angle_deg", self.sharp_angle_deg, 1.0, 179.0);
        check_range(
            &mut v,
            "corner_angle_deg",
            self.corner_angle_deg,
            0.0,
            180.0,
        );
        check_range(&mut v, "max_vertices", self.max_vertices, 4, 1_000_000_000);
        check_range(&mut v, "smoothing_steps", self.smoothing_steps, 0, 100);
        check_range(
            &mut v,
            "min_feature_length",
            self.min_feature_length,
            0.0,
            1e6,
        );
        check_range(
            &mut v,
            "feature_tolerance",
            self.feature_tolerance,
            0.0,
            1.0,
        );
        check_range(
            &mut v,
            "boundary_tolerance",
            self.boundary_tolerance,
            0.0,
            1.0,
        );
        check_range(&mut v, "feature_grading", self.feature_grading, 0.0, 100.0);
        v
    }
}

/// Why remeshing could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RemeshError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("cancelled")]
    Cancelled,
    #[error("the mesh has no faces ({vertices} vertices)")]
    Empty { vertices: usize },
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinite { vertex: usize, position: V3 },
    #[error("the mesh cannot be remeshed: {0}")]
    Topology(#[from] HalfEdgeError),
    #[error("feature curves: {0}")]
    Features(#[from] FeatureError),
    #[error(
        "target edge length {} is below 1/20 of the mesh's mean edge length {}: \
         raise `target`",
        short(*target),
        short(*mean)
    )]
    TargetTooSmall { target: f64, mean: f64 },
    #[error(
        "target edge length {} would give about {estimate} vertices, more than \
         max_vertices = {max}",
        short(*target)
    )]
    TooManyVertices {
        target: f64,
        estimate: usize,
        max: usize,
    },
}

/// A length for a message: six significant digits, in exponent form when very small or large
/// (a target of 1e-300 used to print three hundred zeros).
fn short(x: f64) -> String {
    if x != 0.0 && !(1e-4..1e6).contains(&x.abs()) {
        format!("{x:.5e}")
    } else {
        let digits = (5 - x.abs().log10().floor().max(-10.0) as i32).clamp(0, 15) as usize;
        let s = format!("{x:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    }
}

/// The remeshed surface and what happened.
#[derive(Clone, Debug)]
pub struct RemeshOutput {
    pub mesh: TriMesh,
    /// Counts and the absolute target (see [`IsotropicNode`] for the names).
    pub report: Report,
}

/// The role of a working-mesh vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Free,
    /// Inside feature chain `id`: slides along it.
    Chain(u32),
    Corner,
}

/// Remeshes `mesh` (see the module docs).
pub fn isotropic(
    mesh: &TriMesh,
    curves: Option<&FeatureCurveNetwork>,
    params: &IsotropicParams,
    par: Par,
) -> Result<RemeshOutput, RemeshError> {
    par.install(|| isotropic_with(mesh, curves, params, par, &mut || Ok(())))
}

struct State<'a> {
    he: HalfEdgeMesh,
    role: Vec<Role>,
    /// Input face each vertex was last projected onto (where its next projection starts).
    hint: Vec<u32>,
    proj: &'a Projector<'a>,
    /// Projections the walk could not answer (the BVH did).
    fallbacks: usize,
    projections: usize,
    chains: Vec<Chain>,
    /// Per chain: made of curve edges and shorter than [`CORNER_MERGE`] · L between two
    /// corners; its ends may merge (see [`State::removable_into`]).
    mergeable: Vec<bool>,
    /// Arc-length parameter of each chain vertex on its chain (unused for other vertices).
    param: Vec<f64>,
    /// Per chain, the largest distance of a chain point from the output edge that replaces
    /// it (`boundary_tolerance` · L on boundaries, `feature_tolerance` · L elsewhere).
    tol: Vec<f64>,
    /// Per chain: made of boundary edges.
    boundary_chain: Vec<bool>,
    /// Per chain point, the longest edge the chain allows around it ([`Chain::edge_capacity`]).
    chain_cap: Vec<Vec<f64>>,
    /// Local target edge length of each vertex (see [`State::update_sizes`]).
    size: Vec<f64>,
    /// How fast the local target length may grow with the distance from a shorter one.
    grading: f64,
    l: f64,
    max_turn: f64,
    /// Cosine of `max_turn`.
    cos_turn: f64,
    splits: usize,
    collapses: usize,
    /// Corners merged at the ends of short curve chains.
    corners_merged: usize,
    /// Collapses made for the valences after the rounds ([`State::collapse_for_valence`]).
    valence_collapses: usize,
    /// Of those, the ones whose merged vertex went to the centroid of its ring, where the
    /// middle of the edge failed the tests.
    valence_collapses_recentred: usize,
    /// Vertex splits made for the valences after the rounds ([`State::split_for_valence`]).
    valence_splits: usize,
    /// Far points reached by moving a vertex part of the way ([`State::pull_partway`]).
    far_pulls_partway: usize,
    /// Far points reached by a split part of the way ([`State::split_toward`]).
    far_splits_partway: usize,
    /// Flips of chords far off the input after the far-point step.
    far_chord_flips: usize,
    /// Vertices that kept a wider move ([`State::end_slivers_by_wider_moves`]).
    sliver_moves_onto_input: usize,
    flips: usize,
    /// Set for the flips after which no split runs (the last round and after it): see
    /// [`State::long_flip_leaves_surface`].
    no_split_follows: bool,
    /// Whether relaxation moves free vertices to their Voronoi cells' centroids (Lloyd)
    /// rather than to the area-weighted centroid of their triangles' centroids.
    lloyd: bool,
    /// The fewest live vertices since the last renumbering (or the input's count): see
    /// [`State::compact`].
    numbered_vertices: usize,
    /// Per vertex, the input vertex it descends from (a split vertex: the lower of its edge's
    /// two origins): the order of the renumbering in [`State::compact`].
    origin: Vec<u32>,
    /// Per vertex, the last chain slide computed for it ([`State::slide_chain_params`]).
    slides: Vec<Slide>,
    /// The relaxation's second buffer of positions ([`State::relax_and_project`]).
    spare_positions: Vec<V3>,
}

fn isotropic_with(
    mesh: &TriMesh,
    curves: Option<&FeatureCurveNetwork>,
    params: &IsotropicParams,
    par: Par,
    check: &mut dyn FnMut() -> Result<(), RemeshError>,
) -> Result<RemeshOutput, RemeshError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let t: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(RemeshError::Params(t.join("; ")));
    }
    if mesh.n_faces() == 0 {
        return Err(RemeshError::Empty {
            vertices: mesh.n_vertices(),
        });
    }
    if let Some((vertex, p)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
    {
        return Err(RemeshError::NonFinite {
            vertex,
            position: *p,
        });
    }
    // Holes of three edges far below the target are closed first (see `holes`). The closed
    // mesh keeps the input's vertex and face indices (the new faces come last).
    let hole_edge = HOLE_EDGE
        * if params.relative {
            params.target * mesh.bbox_diagonal()
        } else {
            params.target
        };
    let closed = if mesh.topology().boundary_edge_count() > 0 {
        close_small_triangular_holes(mesh, hole_edge)
    } else {
        None
    };
    let (mesh, holes_closed) = match &closed {
        Some((m, k)) => (m, *k),
        None => (mesh, 0),
    };
    // Work on a spatially coherent numbering when the input's is not: the sweeps walk
    // one-rings in index order, and on inputs numbered in scan or subdivision order nearly
    // every walk misses the cache. A coherent numbering is kept as it is: it costs nothing
    // to walk, and it is often structured (CAD parts built sector by sector), so that the
    // sweeps treat repeated parts alike and the output keeps their symmetry.
    let original = mesh;
    let reordered = if median_corner_spread(original) > INCOHERENT_SPREAD {
        spatially_ordered_with(original, par == Par::Rayon)
    } else {
        None
    };
    let moved_curves = match (&reordered, curves) {
        (Some(r), Some(net)) => Some(r.network(net)),
        _ => None,
    };
    let (mesh, curves) = match &reordered {
        Some(r) => (&r.mesh, moved_curves.as_ref()),
        None => (original, curves),
    };
    let diag = mesh.bbox_diagonal();
    let l = if params.relative {
        params.target * diag
    } else {
        params.target
    };
    // The half-edge structure with the input's edge table (which it builds, and which the
    // statistics below, the projector and the features read), beside the tip search's field:
    // each is a good part of the set-up. The field's boundary test waits for the edge table,
    // its angle deficits do not.
    let ((he, (mean, area)), tip_field) = par.join(
        || {
            let he = HalfEdgeMesh::from_trimesh(mesh);
            (he, (mesh.mean_edge_length(), mesh.total_area()))
        },
        || TipField::new(mesh, l, par),
    );
    let he = match he {
        Ok(he) => he,
        // Name the defect with the input's own indices.
        Err(e) => {
            return Err(HalfEdgeMesh::from_trimesh(original)
                .err()
                .unwrap_or(e)
                .into())
        }
    };
    if !(l >= mean / 20.0) {
        return Err(RemeshError::TargetTooSmall { target: l, mean });
    }
    // A regular triangulation with edge L has about A / (√3/2 · L²) vertices.
    let estimate = area / (0.75f64.sqrt() * l * l);
    if estimate > params.max_vertices as f64 {
        return Err(RemeshError::TooManyVertices {
            target: l,
            estimate: estimate as usize,
            max: params.max_vertices,
        });
    }

    let proj = Projector::new_with(mesh, par);
    let sharp = params.sharp_edges.then_some(params.sharp_angle_deg);
    let mut fe = mark_features(mesh, sharp, curves, &proj, CHORD_STRAY * l)?;
    // Only the relaxation moves a curve's path vertices onto the network's polyline. Without
    // it they would stay off the points their parameters stand for, and a split of a path
    // edge at the middle of its stretch of curve could land anywhere near it (on a coarse
    // input, 2 L away: folds and piles of vertices); the curve then follows the path.
    fe.curves_on_path = params.smoothing_steps == 0;
    mark_boundary_corners(mesh, &mut fe, l, params.corner_angle_deg);
    let chains = build_chains(mesh, &fe, params.corner_angle_deg);
    let chains = prune_short_sharp_chains(
        mesh,
        &mut fe,
        chains,
        params.min_feature_length * l,
        params.corner_angle_deg,
    );
    // Curves that stand for a boundary give way to it (the boundary is resampled within the
    // same tolerance).
    let (chains, curve_edges_along_boundaries) = drop_curves_along_boundaries(
        mesh,
        &mut fe,
        chains,
        params.boundary_tolerance * l,
        l,
        params.corner_angle_deg,
    );
    let topo = mesh.topology();
    // Tips narrower than the target become fixed vertices (see `tips`), unless they are
    // feature vertices already. Curves ending beside one give up their end to it; a tip
    // still within 4/5 L of a fixed feature vertex gives way to that vertex.
    let on_feature_of = |chains: &crate::features::Chains| -> Vec<bool> {
        (0..mesh.n_vertices())
            .map(|v| chains.is_corner[v] || chains.vertex_chain[v] != u32::MAX)
            .collect()
    };
    let tips = tip_field.tips(mesh, &on_feature_of(&chains), par);
    let tip_points: Vec<V3> = tips.iter().map(|&t| mesh.positions[t as usize]).collect();
    let chains = trim_curve_ends_near(
        mesh,
        &mut fe,
        chains,
        &tip_points,
        0.8 * l,
        params.corner_angle_deg,
    );
    let on_feature = on_feature_of(&chains);
    let tips = clear_of_fixed(mesh, &tips, &chains.is_corner, l);
    // So do the corners of a part where creases meet, when the creases are not features.
    let corners = part_corners(
        mesh,
        l,
        params.sharp_angle_deg,
        &on_feature,
        &on_feature,
        &tips,
    );
    let mut is_tip = vec![false; mesh.n_vertices()];
    for &t in tips.iter().chain(&corners) {
        is_tip[t as usize] = true;
    }

    let mut st = State {
        he,
        role: (0..mesh.n_vertices())
            .map(|v| {
                if chains.is_corner[v] || is_tip[v] {
                    Role::Corner
                } else if chains.vertex_chain[v] != u32::MAX {
                    Role::Chain(chains.vertex_chain[v])
                } else {
                    Role::Free
                }
            })
            .collect(),
        hint: vec![u32::MAX; mesh.n_vertices()],
        proj: &proj,
        fallbacks: 0,
        projections: 0,
        chains: chains
            .points
            .iter()
            .zip(&chains.closed)
            .map(|(p, &c)| Chain::new(p.clone(), c))
            .collect(),
        mergeable: Vec::new(),
        param: chains.vertex_param.clone(),
        tol: (0..chains.points.len())
            .map(|c| {
                if chains.on_boundary[c] {
                    params.boundary_tolerance * l
                } else {
                    params.feature_tolerance * l
                }
            })
            .collect(),
        boundary_chain: chains.on_boundary.clone(),
        chain_cap: Vec::new(),
        size: vec![l; mesh.n_vertices()],
        grading: params.feature_grading,
        l,
        max_turn: 60f64.to_radians(),
        no_split_follows: false,
        lloyd: false,
        cos_turn: 60f64.to_radians().cos(),
        splits: 0,
        collapses: 0,
        corners_merged: 0,
        valence_collapses: 0,
        valence_collapses_recentred: 0,
        valence_splits: 0,
        far_pulls_partway: 0,
        far_splits_partway: 0,
        far_chord_flips: 0,
        sliver_moves_onto_input: 0,
        flips: 0,
        numbered_vertices: mesh.n_vertices(),
        origin: (0..mesh.n_vertices() as u32).collect(),
        slides: Vec::new(),
        spare_positions: Vec::new(),
    };
    st.mergeable = (0..st.chains.len())
        .map(|c| {
            chains.from_curves[c] && !chains.closed[c] && st.chains[c].total() < CORNER_MERGE * l
        })
        .collect();
    for (f, t) in mesh.triangles.iter().enumerate() {
        for &v in t {
            st.hint[v as usize] = f as u32;
        }
    }
    if params.feature_grading > 0.0 {
        st.chain_cap = st
            .chains
            .iter()
            .zip(&st.tol)
            .map(|(c, &tol)| c.edge_capacity(tol, l))
            .collect();
    }
    // The corner table keeps the input's faces and corners in order: half-edge 3f + i is side
    // i of face f.
    for h in 0..st.he.n_halfedge_slots() as u32 {
        if st.he.is_canonical(h) {
            let e = topo.face_edges[(h / 3) as usize][(h % 3) as usize];
            debug_assert_eq!(topo.find_edge(st.he.from(h), st.he.to(h)), Some(e));
            let c = chains.edge_chain[e as usize];
            if c != u32::MAX {
                st.he.set_tag(h, c);
            }
        }
    }

    for round in 0..params.iterations {
        check()?;
        // The flips of the last round and after it are not followed by splits.
        st.no_split_follows = round + 1 == params.iterations;
        // Lloyd steps make the cells hexagonal, hence valence 6; the last round takes the
        // triangles' centroids instead, which on the bench meshes left fewer cut-off tips for
        // the final passes (bunny at 2 %: Hausdorff 0.0078 against 0.0097 with Lloyd steps
        // throughout).
        st.lloyd = params.relaxation == Relaxation::Lloyd && round + 1 < params.iterations;
        if params.feature_grading > 0.0 {
            st.update_sizes();
        }
        st.split_long(params.max_vertices, par)?;
        check()?;
        st.collapse_short();
        st.equalize_valences(par, true);
        check()?;
        st.compact();
        for step in 0..params.smoothing_steps {
            // Free vertices return to the input surface after the last sweep only (chain
            // vertices after every one, so that they keep sliding along their chain).
            st.relax_and_project(par, step + 1 == params.smoothing_steps);
        }
    }
    if params.iterations > 0 {
        st.valence_collapses = st.collapse_for_valence(par);
        st.valence_splits = st.split_for_valence(mesh, par);
        if st.valence_collapses + st.valence_splits > 0 {
            // Two relaxation steps spread the vertices over the gaps the collapses and the
            // splits left.
            st.compact();
            st.relax_and_project(par, false);
            st.relax_and_project(par, true);
        }
        st.collapse_slivers(par);
        // Relaxation moved the vertices since the last flips: one more flip sweep.
        check()?;
        st.equalize_valences(par, false);
        st.improve_sliver_vertices(par);
        // The vertex moves change which flips raise the smallest angle of a pair (a free
        // vertex fanning over short feature edges ends up beside them): flip once more and
        // move again.
        st.equalize_valences(par, false);
        st.improve_sliver_vertices(par);
        // Slivers that no nearby move ends: wider moves onto input vertices, each followed
        // by the nearby moves again (a thin part's slivers take several vertices).
        st.sliver_moves_onto_input = st.end_slivers_by_wider_moves(mesh, par);
        check()?;
        st.pull_to_far_points(mesh, par);
        st.far_chord_flips = st.flip_far_chords(par);
    }

    let tagged = (0..st.he.n_halfedge_slots() as u32)
        .filter(|&h| st.he.is_halfedge_alive(h) && st.he.is_canonical(h) && st.he.tag(h) != NONE)
        .count();
    let (out, _) = st.he.to_trimesh();
    let mut r = Report::new();
    r.set("target_abs", l)
        .set("target_rel", if diag > 0.0 { l / diag } else { 0.0 })
        .set("vertices_in", mesh.n_vertices())
        .set("vertices_out", out.n_vertices())
        .set("faces_out", out.n_faces())
        .set("feature_edges_in", fe.count())
        .set("feature_edges_sharp", fe.sharp)
        .set("feature_edges_pruned", fe.pruned)
        .set("feature_edges_trimmed", fe.trimmed)
        .set("feature_edges_boundary", fe.boundary)
        .set("curve_edges_along_boundaries", curve_edges_along_boundaries)
        .set("holes_closed", holes_closed)
        .set("feature_edges_from_curves", fe.from_curves)
        .set("feature_segments_unjoined", fe.segments_unjoined)
        .set("feature_edges_out", tagged)
        .set("feature_chains", chains.points.len())
        .set(
            "feature_chains_from_curves",
            chains.from_curves.iter().filter(|&&c| c).count(),
        )
        .set(
            "feature_corners",
            chains.is_corner.iter().filter(|&&c| c).count(),
        )
        .set("tip_vertices", tips.len())
        .set("part_corners", corners.len())
        .set("splits", st.splits)
        .set("collapses", st.collapses)
        .set("corners_merged", st.corners_merged)
        .set("valence_collapses", st.valence_collapses)
        .set(
            "valence_collapses_recentred",
            st.valence_collapses_recentred,
        )
        .set("valence_splits", st.valence_splits)
        .set("far_pulls_partway", st.far_pulls_partway)
        .set("far_splits_partway", st.far_splits_partway)
        .set("far_chord_flips", st.far_chord_flips)
        .set("sliver_moves_onto_input", st.sliver_moves_onto_input)
        .set("flips", st.flips)
        .set("projections", st.projections)
        .set("projection_fallbacks", st.fallbacks);
    Ok(RemeshOutput {
        mesh: out,
        report: r,
    })
}

impl State<'_> {
    /// Drops deleted elements so that the sweeps stay proportional to the live mesh. When
    /// splits have grown the mesh to more than 1.5 times its size at the last numbering (a
    /// target finer than the input), the vertices are also renumbered, each beside the input
    /// vertex it descends from: each split appends its vertex at the end, so after refinement
    /// one-rings are scattered over the arrays and the relaxation misses the cache
    /// (cgal_fandisk at 0.2 %, 6.5k → 290k vertices, spent half its time there). Following
    /// the input's order rather than a space-filling curve keeps what a structured input
    /// numbering gives (a CAD part built sector by sector is swept alike in every sector, and
    /// its remesh keeps the part's symmetry). A mesh that does not grow keeps its order, and
    /// its output is what it was without this.
    ///
    /// Without renumbering, compaction keeps the order of the live elements, and every sweep
    /// skips deleted slots, so it changes no decision; it is skipped while few slots are
    /// deleted (at most 1/32 of the vertex and of the face slots), unless the live count
    /// still holds vertices without a face (unused input vertices), which compaction drops
    /// and which would otherwise count towards the renumbering above. Later rounds collapse a
    /// few edges each, and their compactions cost more than the deleted slots they remove.
    fn compact(&mut self) {
        let live = self.he.n_live_vertices();
        let renumber = 2 * live > 3 * self.numbered_vertices;
        let (vertex_slots, face_slots) = (self.he.n_vertex_slots(), self.he.n_halfedge_slots() / 3);
        if !renumber
            && 32 * (vertex_slots - live) <= vertex_slots
            && 32 * (face_slots - self.he.n_live_faces()) <= face_slots
            && (0..vertex_slots as u32)
                .filter(|&v| self.he.is_vertex_alive(v))
                .count()
                == live
        {
            self.numbered_vertices = self.numbered_vertices.min(live);
            return;
        }
        let map = if renumber {
            let key: Vec<u64> = self.origin.iter().map(|&o| o as u64).collect();
            self.he.compact_by_key(&key)
        } else {
            self.he.compact()
        };
        self.numbered_vertices = if renumber {
            live
        } else {
            self.numbered_vertices.min(live)
        };
        let mut origin = vec![0u32; self.he.n_vertex_slots()];
        for (old, &m) in map.iter().enumerate() {
            if m != NONE {
                origin[m as usize] = self.origin[old];
            }
        }
        self.origin = origin;
        let n = self.he.n_vertex_slots();
        let mut role = vec![Role::Free; n];
        let mut hint = vec![u32::MAX; n];
        let mut param = vec![0.0; n];
        let mut size = vec![self.l; n];
        let mut slides = vec![Slide::NONE; n];
        for (old, &m) in map.iter().enumerate() {
            if m != NONE {
                size[m as usize] = self.size[old];
                role[m as usize] = self.role[old];
                hint[m as usize] = self.hint[old];
                param[m as usize] = self.param[old];
                if let Some(&w) = self.slides.get(old) {
                    slides[m as usize] = w;
                }
            }
        }
        self.slides = slides;
        self.role = role;
        self.hint = hint;
        self.param = param;
        self.size = size;
    }

    fn len2(&self, a: u32, b: u32) -> f64 {
        let d = vec3::sub(self.he.position(a), self.he.position(b));
        vec3::dot(d, d)
    }

    /// Squared length above which the edge between vertices of local target lengths `ha` and
    /// `hb` is split: (4/3 h)² with h their mean.
    fn split_len2(ha: f64, hb: f64) -> f64 {
        (4.0 / 3.0 * (0.5 * (ha + hb))).powi(2)
    }

    /// The local target length of each vertex: the target L, except near stretches of feature
    /// chain that only allow shorter edges (bends kept within the tolerance): there, the
    /// chain's edge capacity, growing away from it by `grading` times the distance over mesh
    /// edges (Dijkstra from those vertices, in (length, vertex) order), so that the triangles
    /// along a short feature edge get short sides too instead of needle angles.
    fn update_sizes(&mut self) {
        let n = self.he.n_vertex_slots();
        let mut size = vec![self.l; n];
        let mut heap = std::collections::BinaryHeap::new();
        for v in 0..n as u32 {
            if !self.he.is_vertex_alive(v) {
                continue;
            }
            let h = match self.role[v as usize] {
                Role::Free => continue,
                Role::Chain(c) => self.chain_size(c, self.param[v as usize]),
                Role::Corner => {
                    let mut h = self.l;
                    for k in self.incident_halfedges(v) {
                        let t = self.he.tag(k);
                        if t != NONE {
                            h = h.min(self.chain_size(t, self.param_on(v, t, f64::NAN)));
                        }
                    }
                    h
                }
            };
            // Never below the smallest target accepted at all (L / 20 of the mean input edge
            // is checked up front; here, L / 20).
            let h = h.max(self.l / 20.0);
            if h < self.l {
                size[v as usize] = h;
                heap.push(std::cmp::Reverse((h.to_bits(), v)));
            }
        }
        let g = self.grading;
        while let Some(std::cmp::Reverse((bits, v))) = heap.pop() {
            let h = f64::from_bits(bits);
            if h > size[v as usize] {
                continue;
            }
            let p = self.he.position(v);
            for k in self.incident_halfedges(v) {
                let u = if self.he.from(k) == v {
                    self.he.to(k)
                } else {
                    self.he.from(k)
                };
                let cand = h + g * vec3::dist(p, self.he.position(u));
                if cand < size[u as usize] {
                    size[u as usize] = cand;
                    heap.push(std::cmp::Reverse((cand.to_bits(), u)));
                }
            }
        }
        self.size = size;
    }

    /// The outgoing half-edges of `v`, plus the boundary half-edge that ends at `v`.
    fn incident_halfedges(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        let mut last = NONE;
        let mut out: Vec<u32> = Vec::with_capacity(8);
        for k in self.he.outgoing(v) {
            out.push(k);
            last = k;
        }
        if last != NONE {
            let q = halfedge::prev(last);
            if self.he.opp(q) == NONE {
                out.push(q);
            }
        }
        out.into_iter()
    }

    /// Capacity of chain `c` at arc length `s`: the smaller of its two points around `s`.
    fn chain_size(&self, c: u32, s: f64) -> f64 {
        let cap = &self.chain_cap[c as usize];
        let ch = &self.chains[c as usize];
        let i = ch.segment_at(s);
        cap[i].min(cap[(i + 1).min(cap.len() - 1)])
    }

    /// Where the merged vertex of collapsing `h` goes: the midpoint of two free vertices,
    /// else the target, which is at least as constrained as the origin.
    fn merged_position(&self, h: u32) -> V3 {
        self.merged_position_into(self.he.from(h), self.he.to(h))
    }

    /// Whether the triangles around `v` that do not contain `other` keep their orientation
    /// (normal turn at most `max_turn`) and some area when `v` moves to `p`; raises `new` to
    /// the cosine of their smallest angle after the move.
    fn fan_ok(&self, v: u32, other: u32, p: V3, new: &mut f64) -> bool {
        self.fan_ok_with_old(v, other, p, new, None, f64::INFINITY)
    }

    /// [`Self::fan_ok`], also raising `old` (when given) to the cosine of the smallest angle
    /// of those triangles before the move ([`Self::fan_min_angle_cos`] in the same sweep).
    /// Answers false as soon as `new` reaches `stop` (it only grows along the fan).
    #[inline]
    fn fan_ok_with_old(
        &self,
        v: u32,
        other: u32,
        p: V3,
        new: &mut f64,
        mut old: Option<&mut f64>,
        stop: f64,
    ) -> bool {
        let cos_max = self.cos_turn;
        for k in self.he.outgoing(v) {
            let f = halfedge::face_of(k);
            let t = self.he.face_vertices(f);
            if t.contains(&other) {
                continue;
            }
            let [x, y, z] = t.map(|u| self.he.position(u));
            let q = |u: u32, at: V3| if u == v { p } else { at };
            let moved = [q(t[0], x), q(t[1], y), q(t[2], z)];
            let n_old = vec3::cross(vec3::sub(y, x), vec3::sub(z, x));
            if !keeps_orientation(n_old, moved, cos_max) {
                return false;
            }
            *new = new.max(min_angle_cos(moved[0], moved[1], moved[2]));
            if *new >= stop {
                return false;
            }
            if let Some(o) = old.as_deref_mut() {
                *o = o.max(min_angle_cos(x, y, z));
            }
        }
        true
    }

    /// [`Self::fan_ok`] for `v` moved to `p` (all its triangles), when the cosine of their
    /// smallest angle stays below `bound`: that cosine, else `None`. Stops at the first
    /// triangle that turns over or reaches the bound (the cosine only grows along the fan).
    fn fan_below(&self, v: u32, p: V3, bound: f64) -> Option<f64> {
        let mut new = -1.0;
        self.fan_ok_with_old(v, NONE, p, &mut new, None, bound)
            .then_some(new)
    }

    /// The neighbours of `v` (as [`HalfEdgeMesh::neighbors`], without allocating).
    fn neighbor_iter(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        let he = &self.he;
        let mut it = he.outgoing(v);
        let mut last = NONE;
        let mut done = false;
        std::iter::from_fn(move || {
            if done {
                return None;
            }
            match it.next() {
                Some(k) => {
                    last = k;
                    Some(he.to(k))
                }
                None => {
                    done = true;
                    if last != NONE {
                        let q = halfedge::prev(last);
                        if he.opp(q) == NONE {
                            return Some(he.from(q));
                        }
                    }
                    None
                }
            }
        })
    }

    /// Cosine of the smallest angle of the triangles around `v` that do not contain `other`.
    fn fan_min_angle_cos(&self, v: u32, other: u32) -> f64 {
        let mut worst: f64 = -1.0;
        for k in self.he.outgoing(v) {
            let t = self.he.face_vertices(halfedge::face_of(k));
            if !t.contains(&other) {
                let [x, y, z] = t.map(|u| self.he.position(u));
                worst = worst.max(min_angle_cos(x, y, z));
            }
        }
        worst
    }

    /// Whether the far-point step may move `v` (a free vertex off the boundary).
    fn movable(&self, v: u32) -> bool {
        self.role[v as usize] == Role::Free && !self.he.is_boundary_vertex(v)
    }

    /// Where `a` and `b` meet when `a` goes into `b`: their middle between two free vertices,
    /// else `b`.
    fn merged_position_into(&self, a: u32, b: u32) -> V3 {
        if self.role[a as usize] == Role::Free && self.role[b as usize] == Role::Free {
            vec3::lerp(self.he.position(a), self.he.position(b), 0.5)
        } else {
            self.he.position(b)
        }
    }
}

/// How far, in target lengths, the two vertices of a collapse for the valences may lie from
/// the triangles that replace them.
const VALENCE_COLLAPSE_OFF: f64 = 0.1;

/// `found` (input vertices stamped with `generation`) and every input vertex reached from
/// them over input edges through vertices whose position is `inside`, in breadth-first order.
fn grow_over_input(
    input: &TriMesh,
    mut found: Vec<u32>,
    stamp: &mut [u32],
    generation: u32,
    inside: impl Fn(V3) -> bool,
) -> Vec<u32> {
    let topo = input.topology();
    let mut k = 0;
    while k < found.len() {
        let a = found[k];
        k += 1;
        for &b in topo.neighbors(a) {
            if stamp[b as usize] != generation && inside(input.positions[b as usize]) {
                stamp[b as usize] = generation;
                found.push(b);
            }
        }
    }
    found
}

/// Distance from the output, in target lengths, beyond which an input vertex pulls the
/// output onto itself ([`State::pull_to_far_points`]).
const FAR_POINT: f64 = 0.3;

/// Distance from the input surface, in target lengths, beyond which a straight network edge
/// is not followed but its edge path is ([`crate::features::mark_features`]). At
/// [`FAR_POINT`] it fired on the scale-conforming networks (at 1 % and 2 %) of 7 of 25 corpus
/// meshes and of the subdivided armadillo, whose benchmark figures would have to be measured
/// again; at L, on none of the 28 corpus meshes.
const CHORD_STRAY: f64 = 1.0;

/// Curve chains shorter than this times L between two corners let the corners merge (see
/// `State::mergeable`).
const CORNER_MERGE: f64 = 0.3;

/// Median index distance between a face's corners above which the input is renumbered
/// (`crestflow_geom::locality`): 512 positions are 12 KB, within the first-level caches.
/// Scans and subdivided meshes measured 1064–46815, generated CAD parts 11–102.
const INCOHERENT_SPREAD: u32 = 512;

/// Cosine of 30°, the smallest angle a vertex pulled onto a far input point may leave in
/// its triangles (unless it was smaller before).
const COS_FAR_MOVE_MIN_ANGLE: f64 = 0.866_025_403_784_438_6;

/// Holes bounded by three edges shorter than this many target lengths are closed before
/// remeshing ([`close_small_triangular_holes`]): a triangle with one side of 0.5 L and two of
/// L has angles of about 29°.
const HOLE_EDGE: f64 = 0.5;

/// Valence-improving flips may not create an angle below both the old smallest angle of the
/// pair and 30° (its cosine).
const COS_FLIP_MIN_ANGLE: f64 = 0.866_025_403_784_438_6;

/// Collapses may not create an angle below both the old smallest angle around them and 20°
/// (its cosine).
const COS_COLLAPSE_MIN_ANGLE: f64 = 0.939_692_620_785_908_4;

/// Whether triangle `t` keeps a non-degenerate area and turns by at most the angle whose
/// cosine is `cos_max` (at least 0: turns up to 90°) from the (unnormalised) normal `n_old`
/// of the face it replaces.
#[inline]
fn keeps_orientation(n_old: V3, t: [V3; 3], cos_max: f64) -> bool {
    let n_new = vec3::cross(vec3::sub(t[1], t[0]), vec3::sub(t[2], t[0]));
    let (lo2, ln2) = (vec3::dot(n_old, n_old), vec3::dot(n_new, n_new));
    let dot = vec3::dot(n_old, n_new);
    // Squared forms of `|n_new| > 1e-12 |n_old|` and `dot ≥ cos_max |n_old| |n_new|`: no
    // square roots on the collapse path (`cos_max ≥ 0`, so `dot ≥ 0` comes first).
    debug_assert!(cos_max >= 0.0);
    ln2 > 1e-24 * lo2 && dot >= 0.0 && dot * dot >= cos_max * cos_max * lo2 * ln2
}

/// Squared distance from `x` to the nearest of the triangles `tris` (infinite for none).
fn dist2_to_triangles(x: V3, tris: impl IntoIterator<Item = [V3; 3]>) -> f64 {
    dist2_within(x, tris, f64::NEG_INFINITY)
}

/// [`dist2_to_triangles`] for a test against `bound2`: it stops at the first triangle within
/// `bound2`, so the answer is exact above the bound and at most `bound2` otherwise (most
/// input points near a changed fan are within the limit, and then which triangle is nearest
/// does not matter).
fn dist2_within(x: V3, tris: impl IntoIterator<Item = [V3; 3]>, bound2: f64) -> f64 {
    let mut d = f64::INFINITY;
    for t in tris {
        d = d.min(crestflow_geom::bvh::closest_point_on_triangle(x, t[0], t[1], t[2]).0);
        if d <= bound2 {
            break;
        }
    }
    d
}

/// Cosine of the smallest interior angle of triangle (a, b, c) (1 when degenerate): the angle
/// opposite the shortest side, by the law of cosines.
fn min_angle_cos(a: V3, b: V3, c: V3) -> f64 {
    let d2 = |x: V3, y: V3| {
        let d = vec3::sub(x, y);
        vec3::dot(d, d)
    };
    let (ab, bc, ca) = (d2(a, b), d2(b, c), d2(c, a));
    // The shortest side s and the two others u, w.
    let (s, u, w) = if ab <= bc && ab <= ca {
        (ab, bc, ca)
    } else if bc <= ca {
        (bc, ab, ca)
    } else {
        (ca, ab, bc)
    };
    let uw = (u * w).sqrt();
    if !(uw > 0.0) {
        return 1.0;
    }
    ((u + w - s) / (2.0 * uw)).min(1.0)
}

/// The `remesh.isotropic` node.
pub struct IsotropicNode;

impl NodeKind for IsotropicNode {
    type Params = IsotropicParams;
    const KIND: &'static str = "remesh.isotropic";
    const VERSION: u32 = 44;
    const DOC: &'static str = "Isotropic remeshing at a target edge length (Botsch & Kobbelt \
        2004, thesis §5.1.1): splits > 4/3 L, collapses < 4/5 L, valence-improving flips, \
        tangential relaxation (relaxation: Centroids, or Lloyd for Voronoi-cell centroids and \
        more vertices of valence 6) and projection onto the input surface, for `iterations` \
        rounds; then collapses of free edges and splits of free vertices that lower the \
        valence deviation where no flip can (report valence_collapses, valence_splits). \
        Feature edges are kept: the optional feature curve network (snapped to mesh edges), \
        sharp edges (dihedral > sharp_angle_deg; free-ended sharp chains shorter than \
        min_feature_length targets are dropped) and boundaries; corners stay fixed (the two \
        ends of a curve shorter than 0.3 L merge into one), other \
        feature vertices slide along their feature polyline (for curves, the network's own \
        polyline, not the zig-zag edge path they snap to), feature edges are never flipped \
        and collapse only along themselves, and no output feature edge strays more than \
        feature_tolerance · L from the polyline it replaces (bends are kept); boundaries are \
        resampled within boundary_tolerance · L (default 0.25) instead, with corners only \
        where they turn by more than corner_angle_deg at the scale of L; with \
        feature_grading > 0 the target shrinks near bends that need shorter edges. Tips \
        narrower than the target (a disk of radius L/2 closing the surface by at least pi, \
        e.g. the end of a finger) keep a fixed vertex at their apex (a curve ending within \
        0.8 L of one gives its end up to it; a tip that close to a fixed feature corner is \
        dropped), and so do corners where \
        three or more edges sharper than sharp_angle_deg meet and the surface turns by at \
        least 0.4 pi (a box corner; also with sharp_edges off). Flips and \
        collapses do not create angles below 30° / 20° unless the old ones were smaller. \
        A free vertex of a triangle still below 30° at the end moves to a nearby place on the \
        input that widens it (on a curved fan only to 30° or more); where that is not enough \
        and no feature chain is next to it, free vertices move up to 0.8 L onto input vertices \
        and keep their new places where their triangles all reach 30° (report \
        sliver_moves_onto_input). Last, an input vertex \
        more than 0.3 L from the output pulls a vertex, a flip or a split onto it, or a \
        vertex part of the way when that alone keeps 30° (report far_pulls_partway), or \
        else a split part of the way (report far_splits_partway); then an edge whose middle \
        lies more than 0.3 L off the input is flipped where the other diagonal lies within \
        half that and the angles allow (report far_chord_flips). \
        Vertices return to the input by a walk from their last face (BVH fallback). `target` \
        is a fraction of the bbox diagonal (relative: true) or absolute. Outputs the mesh and \
        a Report (vertices_out, feature_edges_in/out, feature_chains_from_curves, tip_vertices, part_corners, \
        splits, \
        collapses, flips, projections, projection_fallbacks, target_abs).";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the surface to remesh (manifold, oriented)"),
            Port::optional::<FeatureCurveNetwork>(
                "curves",
                "feature curves to keep (e.g. a scale-conforming network, thesis §4.3)",
            ),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the remeshed surface"),
            Port::of::<Report>("report", "counts: vertices, feature edges, operations"),
        ]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let curves = inputs.opt::<FeatureCurveNetwork>("curves")?;
        let mut check = || {
            if ctx.cancel.is_cancelled() {
                Err(RemeshError::Cancelled)
            } else {
                Ok(())
            }
        };
        match isotropic_with(mesh, curves, params, ctx.par, &mut check) {
            Ok(out) => Ok(Outputs::new()
                .with("mesh", out.mesh)
                .with("report", out.report)),
            Err(RemeshError::Cancelled) => Err(NodeError::cancelled()),
            Err(e) => Err(NodeError::from_source(ErrorKind::InvalidInput, e)),
        }
    }
}
