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
//! lie within 0.1 L of the triangles that replace them; two relaxation steps follow (bunny at 2 %:
//! valence-6 share 0.801 → 0.821, ellipsoid 0.866 → 0.883). Before those steps, the inverse: a free
//! vertex of valence 7 or more splits into two joined vertices when that lowers the squared valence
//! deviation of it and the two ring vertices that gain an edge (a 7 with two 5s becomes a 5 and a 6
//! beside two 6s, an 8 two 6s), with the two vertices at their rings' centroids on the input, their
//! triangles at 30° or more (or no smaller than before), turned by at most 60°, sides of 0.6–4/3 of
//! the local target, and no input vertex nearby left farther than before and than 0.15 L (bunny at
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
//! output before, 0.34 L after).
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
//! its vertices move) to the middle of their two chain neighbours, or, where that would cut
//! a bend, onto the sharpest bend between them; split feature edges
//! get their new vertex at the middle of their stretch of chain. Every output feature edge
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
    /// (default 5, range 0..=100; 0 turns both off). More sweeps give rounder triangles.
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
    /// Vertex splits made for the valences after the rounds ([`State::split_for_valence`]).
    valence_splits: usize,
    /// Far points reached by moving a vertex part of the way ([`State::pull_partway`]).
    far_pulls_partway: usize,
    /// Far points reached by a split part of the way ([`State::split_toward`]).
    far_splits_partway: usize,
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

/// One chain vertex's slide: where a vertex at parameter `s` of chain `chain`, between
/// neighbours at `sx` and `sy`, goes (parameter `to`, point `p`). Away from boundaries the
/// slide depends on nothing else, so a vertex whose three parameters did not change since
/// (bit for bit) takes the same slide without computing it: once a stretch has settled, most
/// of the 50 relaxation steps of a run find it so.
#[derive(Clone, Copy)]
struct Slide {
    chain: u32,
    key: [u64; 3],
    to: f64,
    p: V3,
}

impl Slide {
    const NONE: Slide = Slide {
        chain: NONE,
        key: [0; 3],
        to: 0.0,
        p: [0.0; 3],
    };
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
    let mut fe = mark_features(mesh, sharp, curves, &proj)?;
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
        valence_splits: 0,
        far_pulls_partway: 0,
        far_splits_partway: 0,
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
        .set("valence_splits", st.valence_splits)
        .set("far_pulls_partway", st.far_pulls_partway)
        .set("far_splits_partway", st.far_splits_partway)
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

    fn split_long(&mut self, max_vertices: usize, par: Par) -> Result<(), RemeshError> {
        // The vertices the last pass made: after a pass, only edges of their faces (either
        // half-edge: a split moves the far side of its triangles to new half-edges, which can
        // make the half-edge across it canonical) can be long. Elsewhere no end moved, no
        // size changed, and an edge long before the pass was split.
        let mut made: Option<Vec<u32>> = None;
        for _ in 0..64 {
            let mut any = false;
            // Longest edges first (ties by slot): longest-edge bisection never makes a
            // triangle thinner than half its smallest angle, while splitting in slot order
            // can bisect the short sides of a triangle again and again, making needles whose
            // long sides never get shorter (the sweep then only stops at the vertex cap).
            let st = &*self;
            let long_edge = |h: u32| {
                if !(st.he.is_halfedge_alive(h) && st.he.is_canonical(h)) {
                    return None;
                }
                let (a, b) = (st.he.from(h), st.he.to(h));
                let l2 = st.len2(a, b);
                let hi2 = Self::split_len2(st.size[a as usize], st.size[b as usize]);
                (l2 > hi2).then_some((l2, h))
            };
            // All of them, found in parallel over fixed slot chunks (the sort fixes the order
            // anyway).
            let all =
                || par.filter_map_collect(st.he.n_halfedge_slots(), 8192, |h| long_edge(h as u32));
            let mut long: Vec<(f64, u32)> = match &made {
                None => all(),
                Some(made) => {
                    let mut long: Vec<(f64, u32)> = made
                        .iter()
                        .flat_map(|&m| st.he.outgoing(m))
                        .flat_map(|k| {
                            let f = halfedge::face_of(k);
                            [3 * f, 3 * f + 1, 3 * f + 2]
                        })
                        .flat_map(|k| [k, st.he.opp(k)])
                        .filter(|&k| k != NONE)
                        .filter_map(long_edge)
                        .collect();
                    long.sort_by_key(|&(_, h)| h);
                    long.dedup_by_key(|&mut (_, h)| h);
                    debug_assert_eq!(
                        {
                            let mut a = all();
                            a.sort_by_key(|&(_, h)| h);
                            a
                        },
                        long,
                        "a long edge away from the last pass's splits"
                    );
                    long
                }
            };
            long.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
            let mut new_vertices = Vec::new();
            for (_, h) in long {
                if !self.he.is_halfedge_alive(h) || !self.he.is_canonical(h) {
                    continue;
                }
                let (a, b) = (self.he.from(h), self.he.to(h));
                let (ha, hb) = (self.size[a as usize], self.size[b as usize]);
                if self.len2(a, b) <= Self::split_len2(ha, hb) {
                    continue;
                }
                if self.he.n_live_vertices() >= max_vertices {
                    return Err(RemeshError::TooManyVertices {
                        target: self.l,
                        estimate: self.he.n_live_vertices(),
                        max: max_vertices,
                    });
                }
                let t = self.he.tag(h);
                // A feature edge is split at the middle of its stretch of chain.
                let (mid, s) = if t != NONE {
                    let s = self.stretch_middle(t, a, b);
                    (self.chains[t as usize].point_at(s), s)
                } else {
                    (
                        vec3::lerp(self.he.position(a), self.he.position(b), 0.5),
                        0.0,
                    )
                };
                let m = self.he.split_edge(h, mid);
                self.role.push(if t != NONE {
                    Role::Chain(t)
                } else {
                    Role::Free
                });
                self.param.push(s);
                self.hint.push(self.hint[a as usize]);
                self.size.push(0.5 * (ha + hb));
                self.origin
                    .push(self.origin[a as usize].min(self.origin[b as usize]));
                self.splits += 1;
                any = true;
                new_vertices.push(m);
                debug_assert_eq!(m as usize + 1, self.role.len());
            }
            if !any {
                break;
            }
            made = Some(new_vertices);
        }
        Ok(())
    }

    /// The parameter halfway along the stretch of chain `t` that its edge a → b stands for.
    fn stretch_middle(&self, t: u32, a: u32, b: u32) -> f64 {
        let (lo, hi) = self.stretch(t, a, b);
        self.chains[t as usize].wrap(0.5 * (lo + hi))
    }

    /// The stretch of chain `t` that its edge from `a` to `b` stands for, as `(lo, hi)`.
    fn stretch(&self, t: u32, a: u32, b: u32) -> (f64, f64) {
        let c = &self.chains[t as usize];
        let (sa, sb) = self.edge_params(t, a, b);
        // On a loop the edge stands for the stretch away from a's other chain neighbour (the
        // longer way round on a loop of few vertices).
        let x = if c.is_closed() {
            self.chain_neighbor(a, t, b)
        } else {
            NONE
        };
        if x != NONE && x != b {
            c.interval_avoiding(sa, sb, self.param[x as usize])
        } else {
            c.interval(sa, sb)
        }
    }

    /// Arc-length parameter of vertex `u` on chain `c` (an edge of `u` is tagged `c`): its own
    /// for a vertex inside the chain; for a corner, the end of the chain it sits at (on a
    /// chain from a corner back to itself, the end nearer to `near`).
    fn param_on(&self, u: u32, c: u32, near: f64) -> f64 {
        self.param_on_in(&self.param, u, c, near)
    }

    /// [`Self::param_on`] with the chain vertices' parameters taken from `param`.
    fn param_on_in(&self, param: &[f64], u: u32, c: u32, near: f64) -> f64 {
        if self.role[u as usize] == Role::Chain(c) {
            return param[u as usize];
        }
        let ch = &self.chains[c as usize];
        let (first, last) = ch.ends();
        let p = self.he.position(u);
        let (d0, d1) = (vec3::dist(p, first), vec3::dist(p, last));
        if d0 < d1 || (d0 == d1 && !(near > 0.5 * ch.total())) {
            0.0
        } else {
            ch.total()
        }
    }

    /// Parameters of `x` and `y` on chain `c`, the ends of a stretch that holds the parameter
    /// `inner` (of the chain vertex between them). A corner at both ends of its chain (a loop
    /// through one corner) stands at the end beyond `inner` as seen from the other vertex:
    /// which end is nearer to `inner` does not tell on a loop of few vertices.
    fn stretch_params(&self, param: &[f64], c: u32, x: u32, y: u32, inner: f64) -> (f64, f64) {
        let total = self.chains[c as usize].total();
        let beyond = |other: u32| {
            let so = param[other as usize];
            if self.role[other as usize] != Role::Chain(c) || inner == so {
                inner
            } else if inner > so {
                total
            } else {
                0.0
            }
        };
        (
            self.param_on_in(param, x, c, beyond(y)),
            self.param_on_in(param, y, c, beyond(x)),
        )
    }

    /// Parameters of the ends of edge a–b of chain `c`: a corner at both ends of its chain
    /// stands at the end away from the chain vertex's other chain neighbour.
    fn edge_params(&self, c: u32, a: u32, b: u32) -> (f64, f64) {
        let total = self.chains[c as usize].total();
        // Where the corner `u` stands, seen from its chain neighbour `v`.
        let side = |u: u32, v: u32| {
            if self.role[v as usize] != Role::Chain(c) {
                return f64::NAN;
            }
            let w = self.chain_neighbor(v, c, u);
            if w == NONE || self.role[w as usize] != Role::Chain(c) {
                return f64::NAN;
            }
            let (sw, sv) = (self.param[w as usize], self.param[v as usize]);
            if sw > sv {
                0.0
            } else if sw < sv {
                total
            } else {
                f64::NAN
            }
        };
        let sa = self.param_on(a, c, side(a, b));
        let sb = self.param_on(b, c, side(b, a));
        if side(a, b).is_nan() && side(b, a).is_nan() {
            // Neither end tells (two corners, or a chain of two edges): the nearer end.
            let sb = self.param_on(b, c, sa);
            return (self.param_on(a, c, sb), sb);
        }
        (sa, sb)
    }

    /// The neighbour of chain vertex `v` across its chain-`c` edge other than to `not`.
    fn chain_neighbor(&self, v: u32, c: u32, not: u32) -> u32 {
        for k in self.he.outgoing(v) {
            let x = self.he.to(k);
            if x != not && self.he.tag(k) == c {
                return x;
            }
        }
        // The boundary edge ending at `v` (not in the outgoing sweep).
        let last = self.he.outgoing(v).last().unwrap_or(NONE);
        if last != NONE {
            let p = halfedge::prev(last);
            if self.he.opp(p) == NONE && self.he.tag(p) == c && self.he.from(p) != not {
                return self.he.from(p);
            }
        }
        NONE
    }

    /// Whether the chain between `x` and `y` (both on chain `c`, `near` a parameter between
    /// them) stays within the tolerance of the segment joining their places on the chain.
    fn chain_straight(&self, c: u32, x: u32, y: u32, near: f64) -> bool {
        let (sx, sy) = self.stretch_params(&self.param, c, x, y, near);
        let ch = &self.chains[c as usize];
        let (lo, hi) = ch.interval_through(sx, sy, near);
        self.replaces(c, lo, hi, ch.point_at(sx), ch.point_at(sy))
    }

    /// Whether the output edge `pa`–`pb` may replace the stretch `(lo, hi)` of chain `c`: no
    /// point of the stretch farther from it than the chain's tolerance.
    fn replaces(&self, c: u32, lo: f64, hi: f64, pa: V3, pb: V3) -> bool {
        self.chains[c as usize].deviation_over(lo, hi, pa, pb) <= self.tol[c as usize]
    }

    /// Whether vertex `a` may disappear into `b` along the edge of `h` (feature rules only):
    /// a chain vertex only along its chain, into the next vertex of the chain, and only where
    /// the chain is straight between its other neighbour and `b`.
    fn removable_into(&self, h: u32, a: u32, b: u32) -> bool {
        match self.role[a as usize] {
            // Two corners at the ends of a short curve chain are one network vertex whose
            // curves reach the input's edges at different vertices (their edge paths share
            // their first edge): kept apart, they pin triangles of a few degrees.
            Role::Corner => {
                let c = self.he.tag(h);
                c != NONE
                    && self.mergeable[c as usize]
                    && self.role[b as usize] == Role::Corner
                    && self.merged_chains_apart(a, b)
            }
            Role::Free => true,
            Role::Chain(c) => {
                if self.he.tag(h) != c
                    || !(matches!(self.role[b as usize], Role::Corner)
                        || self.role[b as usize] == Role::Chain(c))
                {
                    return false;
                }
                let x = self.chain_neighbor(a, c, b);
                if x == NONE || x == b {
                    return false;
                }
                let s = self.param[a as usize];
                self.chain_straight(c, x, b, s)
            }
        }
    }

    /// Whether the feature edges of corner `a`, moved onto corner `b`, belong to other chains
    /// than those of `b` and keep 30° from them. A chain joining both would become a loop
    /// through one vertex, and two chains leaving in (nearly) the same direction would keep
    /// only a sliver between them that no flip may remove.
    fn merged_chains_apart(&self, a: u32, b: u32) -> bool {
        let pb = self.he.position(b);
        // (far end, chain) of the feature edges at `v`, but the one joining a and b.
        let chain_ends = |v: u32| {
            self.incident_halfedges(v).filter_map(move |k| {
                let (x, y) = (self.he.from(k), self.he.to(k));
                let far = if x == v { y } else { x };
                (self.he.tag(k) != NONE && far != a && far != b).then(|| (far, self.he.tag(k)))
            })
        };
        chain_ends(a).all(|(x, ca)| {
            let u = vec3::sub(self.he.position(x), pb);
            chain_ends(b).all(|(y, cb)| {
                if ca == cb {
                    return false;
                }
                let w = vec3::sub(self.he.position(y), pb);
                let d = vec3::dot(u, w);
                d <= 0.0
                    || d * d
                        <= COS_FLIP_MIN_ANGLE
                            * COS_FLIP_MIN_ANGLE
                            * vec3::dot(u, u)
                            * vec3::dot(w, w)
            })
        })
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

    /// Whether boundary vertex `v` may slide to `p`: its triangles keep their orientation and
    /// none gets an angle below both 30° and the smallest angle of the fan before. A boundary
    /// vertex may slide far (its tolerance lets bends go), over an inner neighbour or onto
    /// the chord between its chain neighbours (a small part whose boundary loop is down to
    /// one triangle).
    fn boundary_slide_ok(&self, v: u32, p: V3) -> bool {
        let (mut new, mut old) = (-1.0f64, -1.0f64);
        self.fan_ok_with_old(v, NONE, p, &mut new, Some(&mut old), f64::INFINITY)
            && new <= old.max(COS_FAR_MOVE_MIN_ANGLE)
    }

    /// [`HalfEdgeMesh::collapse_topology_ok`] without allocating: no boundary pinch, the link
    /// condition (a and b share no neighbour but the apexes of the edge's triangles), the
    /// apexes keep enough edges, and something is left.
    fn collapse_topology_ok(&self, h: u32) -> bool {
        let he = &self.he;
        let g = he.opp(h);
        let (a, b) = (he.from(h), he.to(h));
        let c = he.from(halfedge::prev(h));
        let d = if g == NONE {
            NONE
        } else {
            he.from(halfedge::prev(g))
        };
        if g != NONE && he.is_boundary_vertex(a) && he.is_boundary_vertex(b) {
            return false;
        }
        let mut nb = [NONE; 64];
        let mut n = 0;
        for x in self.neighbor_iter(b) {
            if n == nb.len() {
                return he.collapse_topology_ok(h).is_ok();
            }
            nb[n] = x;
            n += 1;
        }
        let nb = &nb[..n];
        for x in self.neighbor_iter(a) {
            if x != b && x != c && x != d && nb.contains(&x) {
                return false;
            }
        }
        let min_val = |v: u32| if he.is_boundary_vertex(v) { 3 } else { 4 };
        if he.valence(c) < min_val(c) || (d != NONE && he.valence(d) < min_val(d)) {
            return false;
        }
        he.n_live_faces() > 2
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

    /// No edge longer than 4/3 L may appear at the merged vertex `p`. For a chain vertex only
    /// the chain's own edges count: off-chain edges that grow are split again, while a chain
    /// that keeps short edges would pin thin triangles along the feature.
    fn lengths_ok(&self, v: u32, p: V3, hp: f64, chain_only: bool, stretch2: f64) -> bool {
        let far = |x: u32| {
            let d = vec3::sub(self.he.position(x), p);
            vec3::dot(d, d) > stretch2 * Self::split_len2(self.size[x as usize], hp)
        };
        let mut last = NONE;
        for h in self.he.outgoing(v) {
            last = h;
            if (!chain_only || self.he.tag(h) != NONE) && far(self.he.to(h)) {
                return false;
            }
        }
        // The boundary edge ending at `v` (not in the outgoing sweep).
        if last != NONE {
            let q = halfedge::prev(last);
            if self.he.opp(q) == NONE
                && (!chain_only || self.he.tag(q) != NONE)
                && far(self.he.from(q))
            {
                return false;
            }
        }
        true
    }

    /// Whether collapsing `h` (origin into target) is allowed: feature rules, no long edges,
    /// no two feature edges fused, topology and geometry.
    fn collapse_allowed(&self, h: u32) -> bool {
        self.collapse_allowed_with(h, 1.0, false)
    }

    /// [`Self::collapse_allowed`] with new edges up to `stretch2` times the squared split
    /// length; with `improve`, the smallest angle of every triangle around the edge (the
    /// removed ones included) must grow instead of staying above 20°.
    fn collapse_allowed_with(&self, h: u32, stretch2: f64, improve: bool) -> bool {
        self.collapse_allowed_at(h, stretch2, improve, COS_COLLAPSE_MIN_ANGLE)
    }

    /// [`Self::collapse_allowed_with`] where a collapse may leave no angle smaller than the
    /// one of cosine `cos_min` (unless a smaller one was there before).
    fn collapse_allowed_at(&self, h: u32, stretch2: f64, improve: bool, cos_min: f64) -> bool {
        self.merge_allowed(h, false, stretch2, improve, cos_min)
    }

    /// [`Self::collapse_allowed_at`] for the edge of `h`, with its origin `a` removed into its
    /// target `b`, or with `into_origin` the other way round (a boundary edge has only this
    /// one half-edge; see [`HalfEdgeMesh::collapse_keeping_origin`]).
    fn merge_allowed(
        &self,
        h: u32,
        into_origin: bool,
        stretch2: f64,
        improve: bool,
        cos_min: f64,
    ) -> bool {
        let (mut a, mut b) = (self.he.from(h), self.he.to(h));
        if into_origin {
            std::mem::swap(&mut a, &mut b);
        }
        if !self.removable_into(h, a, b) {
            return false;
        }
        // The two sides of each removed triangle fuse into one edge: never two features.
        let g = self.he.opp(h);
        for k in [h, g] {
            if k != NONE
                && self.he.tag(halfedge::next(k)) != NONE
                && self.he.tag(halfedge::prev(k)) != NONE
            {
                return false;
            }
        }
        let p = self.merged_position_into(a, b);
        let chain = matches!(self.role[a as usize], Role::Chain(_));
        let hm = self.size[a as usize].min(self.size[b as usize]);
        self.lengths_ok(a, p, hm, chain, stretch2)
            && self.lengths_ok(b, p, hm, chain, stretch2)
            && self.collapse_topology_ok(h)
            && {
                // Smallest angle of the surviving triangles around a and b, before and after
                // (as cosines): a collapse may not create an angle below both the old one
                // and 20°.
                let mut new = -1.0;
                if improve {
                    self.fan_ok(a, b, p, &mut new)
                        && self.fan_ok(b, a, p, &mut new)
                        && new
                            < self
                                .fan_min_angle_cos(a, NONE)
                                .max(self.fan_min_angle_cos(b, NONE))
                } else {
                    // The old angles come with the same sweeps (most collapses need them).
                    let (mut old_a, mut old_b) = (-1.0f64, -1.0f64);
                    self.fan_ok_with_old(a, b, p, &mut new, Some(&mut old_a), f64::INFINITY)
                        && self.fan_ok_with_old(b, a, p, &mut new, Some(&mut old_b), f64::INFINITY)
                        && (new <= cos_min || new <= old_a || new <= old_b)
                }
            }
    }

    /// After the rounds: a triangle with an angle below 30° loses its shortest edge when the
    /// collapse raises the smallest angle around it, even if that leaves an edge up to 2 L.
    /// Such slivers remain where a vertex sits close to a corner or a feature and every
    /// collapse would have made an edge just over 4/3 L. A cap whose shortest side fails the
    /// link condition loses its middle vertex instead ([`Self::cap_apex_collapse`]).
    fn collapse_slivers(&mut self, par: Par) {
        const STRETCH2: f64 = 1.5 * 1.5;
        // A vertex takes part in one collapse per sweep; a few sweeps reach neighbouring
        // slivers.
        for _ in 0..3 {
            if !self.collapse_slivers_sweep(STRETCH2, par) {
                break;
            }
        }
    }

    /// After the last flips: a free vertex of a triangle still below 30° moves to the best of
    /// a few nearby positions (towards the centroid of its neighbours, and a ring of tangent
    /// steps; each projected onto the input surface) when that raises the smallest angle of
    /// its triangles and keeps them nearly flat, or on a curved fan lifts it to 30°. A few
    /// sweeps.
    fn improve_sliver_vertices(&mut self, par: Par) {
        self.improve_sliver_vertices_among(None, par);
    }

    /// [`Self::improve_sliver_vertices`] for the vertices marked in `only` (all when `None`).
    fn improve_sliver_vertices_among(&mut self, only: Option<&[bool]>, par: Par) {
        // What `plan_vertex` finds depends only on the positions (and hints) of the vertex
        // and its neighbours (connectivity does not change here): a vertex that found no
        // better place is not tried again until one of them has moved. Moves are numbered
        // from 1; `failed[v]` is the number of moves made when v last found nothing (0:
        // never).
        let nv = self.he.n_vertex_slots();
        let mut moved_at = vec![0u32; nv];
        let mut failed = vec![0u32; nv];
        let mut moves = 1u32;
        // Class of each vertex in this sweep's colouring (u32::MAX: none yet).
        let mut class = vec![u32::MAX; nv];
        for _ in 0..3 {
            // The vertices to try, in face order, coloured greedily so that no two of a class
            // are neighbours: the moves of one class do not change what the others of it
            // find, so each class is planned on the pool and then moved, class by class.
            let mut tried: Vec<u32> = Vec::new();
            let mut classes = 0u32;
            for f in self.sliver_faces(par) {
                for v in self.he.face_vertices(f) {
                    if class[v as usize] != u32::MAX
                        || self.role[v as usize] != Role::Free
                        || self.he.is_boundary_vertex(v)
                        || only.is_some_and(|m| !m[v as usize])
                    {
                        continue;
                    }
                    let f = failed[v as usize];
                    if f > 0
                        && moved_at[v as usize] < f
                        && self.neighbor_iter(v).all(|u| moved_at[u as usize] < f)
                    {
                        continue;
                    }
                    let mut c = 0u32;
                    while self.neighbor_iter(v).any(|u| class[u as usize] == c) {
                        c += 1;
                    }
                    class[v as usize] = c;
                    classes = classes.max(c + 1);
                    tried.push(v);
                }
            }
            let mut any = false;
            for c in 0..classes {
                let members: Vec<u32> = tried
                    .iter()
                    .copied()
                    .filter(|&v| class[v as usize] == c)
                    .collect();
                let plans = {
                    let st = &*self;
                    par.map_collect(members.len(), |i| st.plan_vertex(members[i]))
                };
                for (&v, plan) in members.iter().zip(plans) {
                    if self.apply_plan(v, plan) {
                        moves += 1;
                        moved_at[v as usize] = moves;
                        any = true;
                    } else {
                        failed[v as usize] = moves + 1;
                    }
                }
            }
            for &v in &tried {
                class[v as usize] = u32::MAX;
            }
            if !any {
                break;
            }
        }
    }

    /// After [`Self::improve_sliver_vertices`], for the triangles still below 30°: up to three
    /// rounds of [`Self::move_sliver_vertices_onto_input`], each followed by the nearby moves
    /// again. Then the vertices moved are grouped by edges, and a group whose triangles do not
    /// all reach 30° goes back where it was: a thin part (a claw) may need two or three
    /// vertices to move round it, each by a partial gain, but beside fixed feature vertices
    /// such moves only bend the surface for a few degrees. Returns the number of vertices
    /// that kept a new place.
    fn end_slivers_by_wider_moves(&mut self, input: &TriMesh, par: Par) -> usize {
        let nv = self.he.n_vertex_slots();
        let before: Vec<(V3, u32)> = (0..nv as u32)
            .map(|v| (self.he.position(v), self.hint[v as usize]))
            .collect();
        // Each round looks at what the last one moved and its neighbours only: elsewhere
        // nothing changed since a vertex found no gain.
        let mut only: Option<Vec<bool>> = None;
        let mut any = false;
        for _ in 0..3 {
            let moved = self.move_sliver_vertices_onto_input(input, only.as_deref());
            if moved.is_empty() {
                break;
            }
            any = true;
            let mut near = vec![false; nv];
            for &v in &moved {
                near[v as usize] = true;
                for u in self.neighbor_iter(v) {
                    near[u as usize] = true;
                }
            }
            let at: Vec<V3> = (0..nv as u32).map(|v| self.he.position(v)).collect();
            self.improve_sliver_vertices_among(Some(&near), par);
            for v in 0..nv as u32 {
                if self.he.position(v) != at[v as usize] {
                    near[v as usize] = true;
                    for u in self.neighbor_iter(v) {
                        near[u as usize] = true;
                    }
                }
            }
            only = Some(near);
        }
        if !any {
            return 0;
        }
        let moved: Vec<bool> = (0..nv as u32)
            .map(|v| self.he.is_vertex_alive(v) && self.he.position(v) != before[v as usize].0)
            .collect();
        let mut seen = vec![false; nv];
        let mut kept = 0;
        for s in 0..nv as u32 {
            if !moved[s as usize] || seen[s as usize] {
                continue;
            }
            seen[s as usize] = true;
            let mut group = vec![s];
            let mut k = 0;
            while k < group.len() {
                let v = group[k];
                k += 1;
                for u in self.neighbor_iter(v) {
                    if moved[u as usize] && !seen[u as usize] {
                        seen[u as usize] = true;
                        group.push(u);
                    }
                }
            }
            let ends = group
                .iter()
                .all(|&v| self.fan_min_angle_cos(v, NONE) <= COS_FLIP_MIN_ANGLE);
            if ends && !group.iter().any(|&v| self.next_to_chain(v)) {
                kept += group.len();
            } else {
                for &v in &group {
                    let (p, f) = before[v as usize];
                    self.he.set_position(v, p);
                    self.hint[v as usize] = f;
                }
            }
        }
        kept
    }

    /// Whether a neighbour of `v` lies on a feature chain: inside it, or a corner where two
    /// or more feature edges meet (a tip, a part corner or the free end of a curve is not).
    fn next_to_chain(&self, v: u32) -> bool {
        self.neighbor_iter(v).any(|u| match self.role[u as usize] {
            Role::Chain(_) => true,
            Role::Corner => {
                self.he
                    .outgoing(u)
                    .filter(|&k| self.he.tag(k) != NONE)
                    .count()
                    >= 2
            }
            Role::Free => false,
        })
    }

    /// A free vertex of a triangle below 30° moves onto the input vertex within
    /// [`SLIVER_MOVE_REACH`]·L of it that raises the smallest angle of its triangles most,
    /// when its triangles turn by at most 60° and no edge becomes a chord off the surface
    /// (not next to a feature chain; only the vertices marked in `only`, when given). One
    /// sweep in face order; returns the vertices moved.
    fn move_sliver_vertices_onto_input(
        &mut self,
        input: &TriMesh,
        only: Option<&[bool]>,
    ) -> Vec<u32> {
        let topo = input.topology();
        let mut stamp = vec![0u32; input.n_vertices()];
        let mut generation = 0u32;
        let mut moves = Vec::new();
        for f in 0..(self.he.n_halfedge_slots() / 3) as u32 {
            let Some(t) = self.sliver_corners(f) else {
                continue;
            };
            for v in t {
                if !self.movable(v) || only.is_some_and(|m| !m[v as usize]) || self.next_to_chain(v)
                {
                    continue;
                }
                let Some(seed) = input.triangles.get(self.hint[v as usize] as usize) else {
                    continue;
                };
                // The input vertices within reach, by a breadth-first search over the input's
                // edges from the face v was projected onto.
                let p = self.he.position(v);
                let reach = SLIVER_MOVE_REACH * self.size[v as usize];
                generation += 1;
                let mut seeds: Vec<u32> = Vec::new();
                for &i in seed {
                    if stamp[i as usize] != generation {
                        stamp[i as usize] = generation;
                        seeds.push(i);
                    }
                }
                let near = grow_over_input(input, seeds, &mut stamp, generation, |x| {
                    vec3::dist(x, p) <= reach
                });
                // The best gain; ties to the first found (the search's order is the input's).
                let mut best = (self.fan_min_angle_cos(v, NONE), NONE);
                for &i in &near {
                    let x = input.positions[i as usize];
                    if let Some(new) = self.fan_below(v, x, best.0) {
                        if !topo.vertex_faces(i).is_empty() && !self.move_leaves_surface(v, x) {
                            best = (new, i);
                        }
                    }
                }
                if best.1 != NONE {
                    let i = best.1;
                    self.he.set_position(v, input.positions[i as usize]);
                    self.hint[v as usize] = topo.vertex_faces(i)[0];
                    moves.push(v);
                }
            }
        }
        moves
    }

    /// The faces for which [`State::sliver_corners`] answers, in face order (found on the pool
    /// over fixed chunks).
    fn sliver_faces(&self, par: Par) -> Vec<u32> {
        par.filter_map_collect(self.he.n_halfedge_slots() / 3, 4096, |f| {
            let f = f as u32;
            self.sliver_corners(f).map(|_| f)
        })
    }

    /// The corners of face `f` when it is alive and has an angle below 30°.
    fn sliver_corners(&self, f: u32) -> Option<[u32; 3]> {
        if !self.he.is_face_alive(f) {
            return None;
        }
        let t = self.he.face_vertices(f);
        let [x, y, z] = t.map(|u| self.he.position(u));
        (min_angle_cos(x, y, z) > COS_FLIP_MIN_ANGLE).then_some(t)
    }

    /// Whether the far-point step may move `v` (a free vertex off the boundary).
    fn movable(&self, v: u32) -> bool {
        self.role[v as usize] == Role::Free && !self.he.is_boundary_vertex(v)
    }

    /// Where the output cuts off a tip or a thin rim of the input (an input vertex farther
    /// than [`FAR_POINT`]·L from the output), a free corner of the output face closest to that
    /// input vertex moves onto it (nearest corner first, then the corners' free neighbours,
    /// nearest first, for a face whose corners are all feature vertices) when
    /// - its triangles turn by at most 60° and their smallest angle stays at least
    ///   30° ([`COS_FAR_MOVE_MIN_ANGLE`]) or does not get smaller, and
    /// - nothing near it ends up farther than before or than the limit: no input vertex near
    ///   its triangles gets farther from them than it was or than FAR_POINT·L (unless it stays
    ///   within [`FAR_TRADE`] times the distance of the point pulled in), and neither do
    ///   seven points on each triangle from the input surface (moving a vertex uncovers the
    ///   place it leaves; without this test the armadillo's largest distance grew).
    ///
    /// Where no vertex qualifies, an edge of that face is split and its new vertex put on the
    /// point under the same conditions ([`State::split_toward`]; e.g. between chains of
    /// feature vertices, or across a strip whose vertices all lie on its boundary); where
    /// no other edge may be split, an edge of an inner feature chain.
    ///
    /// The second condition makes the far points a shrinking set: after the first pass (up
    /// to three; a moved vertex and its neighbours wait for the next) only the far points
    /// left are looked at again, against the triangles that moved. A fourth pass pulls a
    /// vertex part of the way toward the far points still left ([`State::pull_partway`]), and
    /// a last one splits an edge part of the way toward those still left after it
    /// ([`State::split_toward`] with `partway`).
    fn pull_to_far_points(&mut self, input: &TriMesh, par: Par) {
        let n_in = input.n_vertices();
        let topo = input.topology();
        // A face of each input vertex (its first; u32::MAX for an unreferenced vertex).
        let input_face: Vec<u32> = (0..n_in as u32)
            .map(|v| topo.vertex_faces(v).first().copied().unwrap_or(u32::MAX))
            .collect();
        let limit = FAR_POINT * self.l;
        let limit2 = limit * limit;
        let tri = |st: &Self, g: u32| st.he.face_vertices(g).map(|u| st.he.position(u));
        let dist2_to_face = |st: &Self, x: V3, g: u32| {
            let [a, b, c] = tri(st, g);
            crestflow_geom::bvh::closest_point_on_triangle(x, a, b, c).0
        };
        // Most input vertices lie within the limit of the triangles around the output vertex
        // nearest to them (in steps over the input's faces from the faces the output
        // vertices were projected onto) or around its neighbours; only the others ask a BVH
        // of the output.
        let mut owner = vec![NONE; input.n_faces()];
        let mut queue: Vec<u32> = Vec::new();
        for v in 0..self.he.n_vertex_slots() as u32 {
            let f = self.hint[v as usize] as usize;
            if self.he.is_vertex_alive(v) && f < owner.len() && owner[f] == NONE {
                owner[f] = v;
                queue.push(f as u32);
            }
        }
        let mut k = 0;
        while k < queue.len() {
            let f = queue[k] as usize;
            k += 1;
            for e in topo.face_edges[f] {
                for g in topo.edge_faces[e as usize] {
                    if g != crestflow_geom::mesh::NO_FACE && owner[g as usize] == NONE {
                        owner[g as usize] = owner[f];
                        queue.push(g);
                    }
                }
            }
        }
        let maybe_far = par.map_collect(n_in, |i| {
            let f = input_face[i];
            if f == u32::MAX {
                return false;
            }
            let v = owner[f as usize];
            if v == NONE {
                return true;
            }
            // The triangles around v, then those around its neighbours; a corner well within
            // the limit settles a fan without its triangles.
            let x = input.positions[i];
            let near_corner = |u: u32| {
                let d = vec3::sub(self.he.position(u), x);
                vec3::dot(d, d) <= NEAR_CORNER * limit2
            };
            let close = |u: u32| {
                self.he
                    .outgoing(u)
                    .any(|k| dist2_to_face(self, x, halfedge::face_of(k)) <= limit2)
            };
            let near = |u: u32| {
                let n = near_corner(u);
                debug_assert!(!n || close(u), "a corner within the limit but no triangle");
                n || close(u)
            };
            !(near(v) || self.neighbor_iter(v).any(near))
        });
        let maybe_far: Vec<u32> = (0..n_in as u32)
            .filter(|&i| maybe_far[i as usize])
            .collect();
        if maybe_far.is_empty() {
            return;
        }
        // Exact distances of those: (distance², input vertex, working-mesh face).
        let (out, _) = self.he.to_trimesh();
        let alive_faces: Vec<u32> = (0..(self.he.n_halfedge_slots() / 3) as u32)
            .filter(|&g| self.he.is_face_alive(g))
            .collect();
        let bvh = crestflow_geom::bvh::TriangleBvh::new_with(&out, par == Par::Rayon);
        let mut far: Vec<(f64, u32, u32)> = par
            .map_collect(maybe_far.len(), |k| {
                let c = bvh.closest(input.positions[maybe_far[k] as usize]);
                (c.dist2, maybe_far[k], alive_faces[c.face as usize])
            })
            .into_iter()
            .filter(|h| h.0 > limit2)
            .collect();
        drop(bvh);
        let mut stamp = vec![0u32; n_in];
        let mut generation = 0u32;
        let mut far_face = vec![NONE; n_in];
        // Up to three passes of full pulls (moves, flips, splits), then one in which far
        // points left may pull a vertex part of the way, and one in which those still left
        // may split an edge part of the way: a partial pull earlier would move vertices that
        // a later full pull of a farther point needs, and a partial split would block the
        // partial moves around it (on the subdivided armadillo at 2 % one did, and a point
        // that such a move brought from 0.52 L to 0.43 L stayed at 0.52 L).
        let mut pass = 0;
        while pass < 5 {
            far.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            for &(_, i, f) in &far {
                far_face[i as usize] = f;
            }
            let mut blocked = vec![false; self.he.n_vertex_slots()];
            let mut moved: Vec<u32> = Vec::new();
            for &(far_d2, i, f) in &far {
                let corners = self.he.face_vertices(f);
                if corners.iter().any(|&v| blocked[v as usize]) {
                    continue;
                }
                let p = input.positions[i as usize];
                let by_distance = |a: &u32, b: &u32| {
                    let da = vec3::dist(self.he.position(*a), p);
                    let db = vec3::dist(self.he.position(*b), p);
                    da.total_cmp(&db).then(a.cmp(b))
                };
                let mut order = corners.to_vec();
                order.sort_by(by_distance);
                // Where the closest triangle's corners all lie on features, a free vertex
                // next to them may still reach the point: the corners' other neighbours,
                // nearest first.
                if !corners.iter().any(|&v| self.movable(v)) {
                    let mut ring: Vec<u32> = corners
                        .iter()
                        .flat_map(|&c| self.neighbor_iter(c))
                        .filter(|u| !corners.contains(u) && !blocked[*u as usize])
                        .collect();
                    ring.sort_by(by_distance);
                    ring.dedup();
                    order.extend(ring);
                }
                let mut pull = FarPull {
                    p,
                    i,
                    p_face: input_face[i as usize],
                    far_d2,
                    limit,
                    far_face: &far_face,
                    input,
                    stamp: &mut stamp,
                    generation: &mut generation,
                };
                if pass == 3 {
                    if let Some(v) = self.pull_partway(&order, &blocked, &mut pull) {
                        self.block_around(&mut blocked, v);
                        moved.push(v);
                    }
                    continue;
                }
                if pass < 3 {
                    if let Some([c, d]) = self.flip_toward(f, &blocked, &mut pull) {
                        for v in [c, d] {
                            self.block_around(&mut blocked, v);
                        }
                        moved.extend([c, d]);
                        continue;
                    }
                    let mut pulled = false;
                    for &v in &order {
                        if !self.movable(v) {
                            continue;
                        }
                        let p_face = pull.p_face;
                        if !self.move_for_far_point(v, p, p_face, false, &mut pull) {
                            continue;
                        }
                        self.block_around(&mut blocked, v);
                        moved.push(v);
                        pulled = true;
                        break;
                    }
                    if pulled {
                        continue;
                    }
                }
                // A split: on the far point in the full passes, part of the way in the last.
                if let Some(m) = self.split_toward(f, &blocked, &mut pull, pass == 4) {
                    blocked.resize(self.he.n_vertex_slots(), false);
                    self.block_around(&mut blocked, m);
                    moved.push(m);
                }
            }
            if pass == 4 || far.is_empty() {
                break;
            }
            if moved.is_empty() {
                // Nothing changed: the next full pass would do the same.
                pass = if pass >= 3 { pass + 1 } else { 3 };
                continue;
            }
            // Only the moved triangles changed: each far point keeps its face (at its new
            // distance) unless one of them is closer now. (Where its own face moved away, a
            // face that did not move may be closer still: then the distance is overstated.)
            let moved_faces: Vec<u32> = moved
                .iter()
                .flat_map(|&v| {
                    self.he
                        .outgoing(v)
                        .map(halfedge::face_of)
                        .collect::<Vec<_>>()
                })
                .collect();
            // A moved face can only be closer than a far point's current face if its box is;
            // the test keeps a relative margin, so that rounding in the exact distance cannot
            // make a face skipped here the closer one. Far points are independent: each is
            // updated on its own, on the pool.
            let boxes: Vec<Aabb> = moved_faces
                .iter()
                .map(|&g| Aabb::around(&tri(self, g)))
                .collect();
            far = {
                let st = &*self;
                let (far, moved_faces, boxes) = (&far, &moved_faces, &boxes);
                // The nearest of its face and the moved ones, skipping those whose box is
                // farther when `boxed`.
                let nearest = |(_, i, f): (f64, u32, u32), boxed: bool| {
                    let x = input.positions[i as usize];
                    let mut h = (dist2_to_face(st, x, f), i, f);
                    for (&g, b) in moved_faces.iter().zip(boxes) {
                        if boxed && b.dist2(x) > h.0 * (1.0 + 1e-9) {
                            continue;
                        }
                        let d2 = dist2_to_face(st, x, g);
                        if d2 < h.0 {
                            h = (d2, i, g);
                        }
                    }
                    h
                };
                // (A few far points are not worth a parallel loop.)
                let par = if far.len() >= 256 { par } else { Par::Seq };
                par.map_collect(far.len(), |j| {
                    let h = nearest(far[j], true);
                    debug_assert!(
                        {
                            // (Below the limit the point is dropped whichever face it
                            // keeps, and the margin may not cover rounding that small.)
                            let all = nearest(far[j], false);
                            all == h || (all.0 <= limit2 && h.0 <= limit2)
                        },
                        "a moved face skipped by its box is the closer one"
                    );
                    h
                })
            };
            for &(_, i, _) in &far {
                far_face[i as usize] = NONE;
            }
            far.retain(|h| h.0 > limit2);
            pass += 1;
        }
    }

    /// Marks `v` and its neighbours as moved in this far-point pass.
    fn block_around(&self, blocked: &mut [bool], v: u32) {
        blocked[v as usize] = true;
        for u in self.neighbor_iter(v) {
            blocked[u as usize] = true;
        }
    }

    /// Moves free vertex `v` to `x` (on input face `x_face`) for the far point of `pull` when
    /// its triangles turn by at most 60°, keep their area, make no long chord off the input,
    /// and keep their smallest angle at 30° or more or no smaller than before (`partway`:
    /// both), and nothing near ends up farther ([`State::move_keeps_distances`]; `partway`:
    /// without the [`FAR_TRADE`] a full pull may make). Returns whether it moved.
    fn move_for_far_point(
        &mut self,
        v: u32,
        x: V3,
        x_face: u32,
        partway: bool,
        pull: &mut FarPull<'_>,
    ) -> bool {
        let old = self.fan_min_angle_cos(v, NONE);
        // The smallest angle may not fall below 30° and the fan's before (part of the way),
        // or below both (the whole way): the new cosine at most `allowed`.
        let allowed = if partway {
            COS_FAR_MOVE_MIN_ANGLE.min(old)
        } else {
            COS_FAR_MOVE_MIN_ANGLE.max(old)
        };
        if self.fan_below(v, x, allowed.next_up()).is_none() || self.move_leaves_surface(v, x) {
            return false;
        }
        let ring: Vec<u32> = self.neighbor_iter(v).collect();
        let (q, q_hint) = (self.he.position(v), self.hint[v as usize]);
        let (tris, hints, faces) = self.fan_move(v, x, x_face);
        if partway && !pull.within_limit_of(tris[1].iter().copied()) {
            return false;
        }
        // A partial pull makes no trade.
        if !self.replacement_keeps_distances(
            q,
            &ring,
            q_hint,
            [&tris[0], &tris[1]],
            [&hints[0], &hints[1]],
            &faces,
            pull,
            !partway,
        ) {
            return false;
        }
        self.he.set_position(v, x);
        self.hint[v as usize] = x_face;
        true
    }

    /// Where no full pull reached the far point, a free vertex of `order` (its face's corners,
    /// nearest first, then their neighbours) moves three quarters, half or a quarter of the
    /// way toward it, projected onto the input, when that brings the point within
    /// [`FAR_POINT`]·L under the tests of [`State::move_for_far_point`] with `partway`.
    /// Returns the vertex moved.
    fn pull_partway(
        &mut self,
        order: &[u32],
        blocked: &[bool],
        pull: &mut FarPull<'_>,
    ) -> Option<u32> {
        for &v in order {
            if !self.movable(v) || blocked[v as usize] {
                continue;
            }
            let q = self.he.position(v);
            for t in [0.75, 0.5, 0.25] {
                let r = self
                    .proj
                    .project(vec3::lerp(q, pull.p, t), self.hint[v as usize], self.l);
                if self.move_for_far_point(v, r.hit.point, r.hit.face, true, pull) {
                    self.far_pulls_partway += 1;
                    return Some(v);
                }
            }
        }
        None
    }

    /// Where the far input point `p` (input vertex `i`, closest to output face `f`) lies
    /// beyond an edge of `f` that cuts across a crease of the input, that edge is flipped:
    /// the edges that are neither features nor on the boundary, the one whose middle is
    /// farthest from `p` first, when the flip brings `p` within [`FAR_TRADE`] times its
    /// distance, the two new triangles keep 30° (or do not lower the pair's smallest angle)
    /// and do not turn over, and nothing near ends up farther
    /// ([`State::move_keeps_distances`]). Returns the new edge's ends.
    fn flip_toward(
        &mut self,
        f: u32,
        blocked: &[bool],
        pull: &mut FarPull<'_>,
    ) -> Option<[u32; 2]> {
        let (p, far_d2) = (pull.p, pull.far_d2);
        let x = |u: u32| self.he.position(u);
        let mut edges: Vec<(f64, u32)> = (0..3)
            .map(|k| 3 * f + k)
            .filter(|&h| self.he.tag(h) == NONE && !self.he.is_boundary_edge(h))
            .map(|h| {
                let mid = vec3::lerp(x(self.he.from(h)), x(self.he.to(h)), 0.5);
                (vec3::dist(mid, p), h)
            })
            .collect();
        edges.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for &(_, h) in &edges {
            let g = self.he.opp(h);
            let (a, b) = (self.he.from(h), self.he.to(h));
            let c = self.he.from(halfedge::prev(h));
            let d = self.he.from(halfedge::prev(g));
            if [a, b, c, d].iter().any(|&u| blocked[u as usize]) || !self.he.flip_ok(h) {
                continue;
            }
            // Not at the cost of the valences (on the bunny at 2 % the valence-6 share fell
            // from 0.802 to 0.798 without this test).
            let dev = |v: u32, delta: i64| {
                let x = self.he.valence(v) as i64 + delta - self.target_valence(v);
                x * x
            };
            let deviation = dev(a, 0) + dev(b, 0) + dev(c, 0) + dev(d, 0);
            if dev(a, -1) + dev(b, -1) + dev(c, 1) + dev(d, 1) > deviation {
                continue;
            }
            let before = [[x(a), x(b), x(c)], [x(b), x(a), x(d)]];
            let after = [[x(a), x(d), x(c)], [x(b), x(c), x(d)]];
            let bound2 = FAR_TRADE * FAR_TRADE * far_d2;
            if dist2_within(p, after, bound2) > bound2 {
                continue;
            }
            let old = min_angle_cos(x(a), x(b), x(c)).max(min_angle_cos(x(b), x(a), x(d)));
            let new = min_angle_cos(x(a), x(d), x(c)).max(min_angle_cos(x(b), x(c), x(d)));
            if new > old.max(COS_FAR_MOVE_MIN_ANGLE) {
                continue;
            }
            let hint = |u: u32| self.hint[u as usize];
            let hints_before = [[hint(a), hint(b), hint(c)], [hint(b), hint(a), hint(d)]];
            let hints_after = [[hint(a), hint(d), hint(c)], [hint(b), hint(c), hint(d)]];
            if !self.replacement_keeps_distances(
                vec3::lerp(x(a), x(b), 0.5),
                &[a, b, c, d],
                hint(a),
                [&before, &after],
                [&hints_before, &hints_after],
                &[h / 3, g / 3],
                pull,
                true,
            ) {
                continue;
            }
            self.he.flip(h);
            self.flips += 1;
            return Some([c, d]);
        }
        None
    }

    /// Where no vertex may move onto the far input point `p` (input vertex `i`, closest to
    /// output face `f`), an edge of `f` is split and the new vertex put on `p`: the edges
    /// that are neither features nor on the boundary, the one whose middle is nearest first,
    /// then those of inner feature chains (a chain edge is a chord of the crease it stands
    /// for; where the crease bends tightly, the input bulges beyond it, and the new chain
    /// vertex goes onto the crease), under the same conditions as a moved vertex (the four
    /// triangles turn by at most 60° from the two they replace, their smallest angle is at
    /// least 30°, nothing near ends up farther). A new triangle below that angle may instead
    /// be flipped with its neighbour across its side opposite the new vertex (the new vertex
    /// then reaches one vertex further; between two rows of fixed vertices that is the only
    /// way to keep the angles). With `partway`, the new vertex goes part of the way instead
    /// (three quarters or half of the way from the edge's middle to `p`, projected onto the
    /// input; on a chain edge, the crease's point farthest from the edge, then its middle),
    /// where that brings `p` within the limit, and the split makes no trade (as for
    /// [`State::pull_partway`]). Returns the new vertex.
    fn split_toward(
        &mut self,
        f: u32,
        blocked: &[bool],
        pull: &mut FarPull<'_>,
        partway: bool,
    ) -> Option<u32> {
        let far = pull.p;
        // Edges of inner feature chains after the others.
        let mut edges: Vec<(bool, f64, u32)> = (0..3)
            .map(|k| 3 * f + k)
            .filter(|&h| {
                let t = self.he.tag(h);
                !self.he.is_boundary_edge(h) && (t == NONE || !self.boundary_chain[t as usize])
            })
            .map(|h| {
                let mid = vec3::lerp(
                    self.he.position(self.he.from(h)),
                    self.he.position(self.he.to(h)),
                    0.5,
                );
                (self.he.tag(h) != NONE, vec3::dist(mid, far), h)
            })
            .collect();
        edges.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
        // Where the new vertex goes (and its chain parameter): on the far point; part of the
        // way, three quarters or half of the way there from the edge's middle, on the input,
        // or on a chain the point of its crease farthest from the edge, then the crease's
        // middle (a chain vertex stays on its crease).
        let mut tries: Vec<(u32, V3, Option<f64>)> = Vec::new();
        for &(_, _, h) in &edges {
            let (a, b) = (self.he.from(h), self.he.to(h));
            let c = self.he.tag(h);
            if !partway {
                // A chain edge's new vertex takes the stretch's middle, found once it splits.
                tries.push((h, far, None));
            } else if c != NONE {
                let chain = &self.chains[c as usize];
                let (lo, hi) = self.stretch(c, a, b);
                let s_mid = chain.wrap(0.5 * (lo + hi));
                let (pa, pb) = (self.he.position(a), self.he.position(b));
                if let Some((_, s)) = chain.farthest_over(lo, hi, pa, pb) {
                    tries.push((h, chain.point_at(s), Some(s)));
                }
                tries.push((h, chain.point_at(s_mid), Some(s_mid)));
            } else {
                let mid = vec3::lerp(self.he.position(a), self.he.position(b), 0.5);
                for t in [0.75, 0.5] {
                    tries.push((h, vec3::lerp(mid, far, t), None));
                }
            }
        }
        for (h, at, s) in tries {
            let (p, p_face) = if partway {
                let r = self
                    .proj
                    .project(at, self.hint[self.he.from(h) as usize], self.l);
                (if s.is_some() { at } else { r.hit.point }, r.hit.face)
            } else {
                (far, pull.p_face)
            };
            let Some(plan) = self.plan_split(h, p, blocked) else {
                continue;
            };
            let hint = |u: u32| self.hint[u as usize];
            let hints_of = |t: &[u32; 3]| t.map(|u| if u == NONE { p_face } else { hint(u) });
            let x = |u: u32| if u == NONE { p } else { self.he.position(u) };
            let (a, b) = (self.he.from(h), self.he.to(h));
            let mid = vec3::lerp(x(a), x(b), 0.5);
            // Before: the two faces (as split at the middle of the edge, the same surface)
            // and the flipped neighbours; after: the planned triangles.
            let before: Vec<[V3; 3]> = plan
                .before
                .iter()
                .map(|t| t.map(|u| if u == NONE { mid } else { x(u) }))
                .collect();
            let hints_before: Vec<[u32; 3]> = plan
                .before
                .iter()
                .map(|t| t.map(|u| if u == NONE { hint(a) } else { hint(u) }))
                .collect();
            let after: Vec<[V3; 3]> = plan.after.iter().map(|t| t.map(x)).collect();
            let hints_after: Vec<[u32; 3]> = plan.after.iter().map(hints_of).collect();
            if partway && !pull.within_limit_of(after.iter().copied()) {
                continue;
            }
            let corners: Vec<u32> = plan
                .after
                .iter()
                .flatten()
                .copied()
                .filter(|&u| u != NONE)
                .collect();
            if !self.replacement_keeps_distances(
                mid,
                &corners,
                hint(a),
                [&before, &after],
                [&hints_before, &hints_after],
                &plan.faces,
                pull,
                !partway,
            ) {
                continue;
            }
            let t = self.he.tag(h);
            // On a chain the new vertex takes the middle of the edge's stretch as its
            // parameter (or that of its place on the crease, part of the way); it sits on the
            // input, off the chain's chord, and no later step slides it.
            let s = match s {
                Some(s) => s,
                None if t != NONE => self.stretch_middle(t, a, b),
                None => 0.0,
            };
            let m = self.he.split_edge(h, p);
            self.role.push(if t != NONE {
                Role::Chain(t)
            } else {
                Role::Free
            });
            self.param.push(s);
            self.hint.push(p_face);
            self.size
                .push(0.5 * (self.size[a as usize] + self.size[b as usize]));
            self.origin
                .push(self.origin[a as usize].min(self.origin[b as usize]));
            self.splits += 1;
            self.far_splits_partway += partway as usize;
            for (u, w) in plan.flips {
                let e = self.he.find_edge(u, w);
                if e != NONE && self.he.flip_ok(e) {
                    self.he.flip(e);
                    self.flips += 1;
                }
            }
            return Some(m);
        }
        None
    }

    /// The triangles that splitting the edge of `h` at `p` would make (the new vertex written
    /// `NONE`), with the outer sides of those below 30° flipped (see [`State::split_toward`]);
    /// `None` when they cannot all keep 30° and turn by at most 60°.
    fn plan_split(&self, h: u32, p: V3, blocked: &[bool]) -> Option<SplitPlan> {
        let g = self.he.opp(h);
        let (a, b) = (self.he.from(h), self.he.to(h));
        let c = self.he.from(halfedge::prev(h));
        let d = self.he.from(halfedge::prev(g));
        if [a, b, c, d].iter().any(|&u| blocked[u as usize]) {
            return None;
        }
        let x = |u: u32| if u == NONE { p } else { self.he.position(u) };
        let (nf, ng) = (
            self.he.face_normal_raw(h / 3),
            self.he.face_normal_raw(g / 3),
        );
        let mut plan = SplitPlan {
            before: vec![[a, b, c], [b, a, d]],
            after: Vec::new(),
            faces: vec![h / 3, g / 3],
            flips: Vec::new(),
        };
        // (m, u, w) with the side u → w opposite the new vertex m, and that side's half-edge
        // in the faces being split: (a, m, c), (m, b, c), (b, m, d), (m, a, d).
        let sides = [
            (c, a, halfedge::prev(h), nf),
            (b, c, halfedge::next(h), nf),
            (d, b, halfedge::prev(g), ng),
            (a, d, halfedge::next(g), ng),
        ];
        // Keeps the orientation of the face of normal `n` and the 30° of the rule.
        let shape = |t: [u32; 3], n: V3| {
            let q = t.map(x);
            keeps_orientation(n, q, self.cos_turn)
                && min_angle_cos(q[0], q[1], q[2]) <= COS_FAR_MOVE_MIN_ANGLE
        };
        for (u, w, o, n_old) in sides {
            let t = [NONE, u, w];
            if shape(t, n_old) {
                plan.after.push(t);
                continue;
            }
            // Flip u–w: (m, u, w) and (w, u, e) become (m, u, e) and (m, e, w).
            let o2 = self.he.opp(o);
            if self.he.tag(o) != NONE || o2 == NONE || self.he.tag(o2) != NONE {
                return None;
            }
            let e = self.he.from(halfedge::prev(o2));
            // A vertex the new one already reaches, or reaches through another flip (two
            // sides of a valence-4 corner), would get a second edge to it.
            if [a, b, c, d].contains(&e)
                || blocked[e as usize]
                || plan.after.iter().any(|t| t[1] == e || t[2] == e)
            {
                return None;
            }
            let n_e = self.he.face_normal_raw(o2 / 3);
            let (t1, t2) = ([NONE, u, e], [NONE, e, w]);
            if !(shape(t1, n_old) && shape(t1, n_e) && shape(t2, n_old) && shape(t2, n_e)) {
                return None;
            }
            plan.before.push([w, u, e]);
            plan.faces.push(o2 / 3);
            plan.after.extend([t1, t2]);
            plan.flips.push((u, w));
        }
        Some(plan)
    }

    /// The triangles around `v`, each corner mapped by `value`, `v` itself to `at`.
    fn fan_corners<T: Copy>(&self, v: u32, at: T, value: impl Fn(u32) -> T) -> Vec<[T; 3]> {
        self.he
            .outgoing(v)
            .map(|k| {
                self.he
                    .face_vertices(halfedge::face_of(k))
                    .map(|u| if u == v { at } else { value(u) })
            })
            .collect()
    }

    /// Whether the triangles `tris[0]` (around `q`, projected from input face `q_hint`, with
    /// corners `corners`) may become `tris[1]` on the way to the far point of `pull`:
    /// [`State::move_keeps_distances`] over the input vertices [`State::input_near`] them,
    /// with a `trade` or without ([`FarPull::uncover_bound2`]).
    #[allow(clippy::too_many_arguments)]
    fn replacement_keeps_distances(
        &self,
        q: V3,
        corners: &[u32],
        q_hint: u32,
        tris: [&[[V3; 3]]; 2],
        hints: [&[[u32; 3]]; 2],
        faces: &[u32],
        pull: &mut FarPull<'_>,
        trade: bool,
    ) -> bool {
        *pull.generation += 1;
        let near = self.input_near(
            q,
            pull.p,
            corners,
            q_hint,
            pull.i,
            pull.limit,
            pull.input,
            pull.stamp,
            *pull.generation,
        );
        self.move_keeps_distances(
            tris,
            hints,
            faces,
            &near,
            pull.far_face,
            pull.limit,
            pull.uncover_bound2(trade),
            pull.input,
        )
    }

    /// The input vertices whose distance from a fan of triangles may change when its centre
    /// moves from `q` to `p` (the fan's other corners: `ring`): those within the reach of the
    /// fan at either position (its longest spoke plus `limit`) of either position, found by a
    /// breadth-first search over the input's edges from input vertex `i`, the input face the
    /// centre was projected onto (`q_hint`) and those of the ring's vertices.
    #[allow(clippy::too_many_arguments)]
    fn input_near(
        &self,
        q: V3,
        p: V3,
        ring: &[u32],
        q_hint: u32,
        i: u32,
        limit: f64,
        input: &TriMesh,
        stamp: &mut [u32],
        generation: u32,
    ) -> Vec<u32> {
        let mut reach: f64 = 0.0;
        let mut seeds = vec![i];
        for &u in ring {
            let x = self.he.position(u);
            reach = reach.max(vec3::dist(x, q)).max(vec3::dist(x, p));
            if let Some(t) = input.triangles.get(self.hint[u as usize] as usize) {
                seeds.extend_from_slice(t);
            }
        }
        if let Some(t) = input.triangles.get(q_hint as usize) {
            seeds.extend_from_slice(t);
        }
        let r = reach + limit;
        let inside = |x: V3| vec3::dist(x, q) <= r || vec3::dist(x, p) <= r;
        let mut found = Vec::new();
        for s in seeds {
            if stamp[s as usize] != generation && inside(input.positions[s as usize]) {
                stamp[s as usize] = generation;
                found.push(s);
            }
        }
        grow_over_input(input, found, stamp, generation, inside)
    }

    /// The triangles of `v` before and after it moves to `p` (projected onto input face
    /// `p_face`), the input faces their corners were projected onto, and their faces: the
    /// arguments of [`State::move_keeps_distances`].
    #[allow(clippy::type_complexity)]
    fn fan_move(
        &self,
        v: u32,
        p: V3,
        p_face: u32,
    ) -> ([Vec<[V3; 3]>; 2], [Vec<[u32; 3]>; 2], Vec<u32>) {
        let position = |u: u32| self.he.position(u);
        let hint = |u: u32| self.hint[u as usize];
        (
            [
                self.fan_corners(v, position(v), position),
                self.fan_corners(v, p, position),
            ],
            [
                self.fan_corners(v, hint(v), hint),
                self.fan_corners(v, p_face, hint),
            ],
            self.he.outgoing(v).map(halfedge::face_of).collect(),
        )
    }

    /// Whether the triangles `tris[0]` becoming `tris[1]` (the input faces their corners were
    /// projected onto in `hints`; they replace the faces `fan_faces`) leave every input vertex
    /// of `near` within the larger of its old distance from them and `limit` (or within
    /// [`FAR_TRADE`] times the distance `√far_d2` of the point pulled in), and seven points of
    /// each new triangle (centroid, thirds of the sides) within the larger of their old
    /// distance from the input surface and `limit`.
    #[allow(clippy::too_many_arguments)]
    fn move_keeps_distances(
        &self,
        tris: [&[[V3; 3]]; 2],
        hints: [&[[u32; 3]]; 2],
        fan_faces: &[u32],
        near: &[u32],
        far_face: &[u32],
        limit: f64,
        far_d2: f64,
        input: &TriMesh,
    ) -> bool {
        let [before, after] = tris;
        let limit2 = limit * limit;
        let mut uncovered: f64 = 0.0;
        // Most near points lie beyond the limit of both fans (the points are gathered in
        // balls around the fan's centre, the fans cover less): a triangle whose box is
        // beyond the limit (with a margin for rounding) cannot hold a point within it, and
        // its exact distance is computed only where the answer needs it.
        let boxes =
            |tris: &[[V3; 3]]| -> Vec<Aabb> { tris.iter().map(|t| Aabb::around(t)).collect() };
        let (boxes_before, boxes_after) = (boxes(before), boxes(after));
        let beyond2 = limit2 * (1.0 + 1e-9);
        let within = |tris: &[[V3; 3]], boxes: &[Aabb], x: V3| {
            tris.iter().zip(boxes).any(|(t, b)| {
                b.dist2(x) <= beyond2
                    && crestflow_geom::bvh::closest_point_on_triangle(x, t[0], t[1], t[2]).0
                        <= limit2
            })
        };
        let dist2 = |tris: &[[V3; 3]], x: V3| dist2_to_triangles(x, tris.iter().copied());
        for &k in near {
            let x = input.positions[k as usize];
            if within(after, &boxes_after, x) {
                continue;
            }
            // Farther than the limit from the fan before: either a far point, whose own face
            // may be in the fan, or closer to some other (unmoved) face, which the move does
            // not change.
            let own_face_moves =
                far_face[k as usize] != NONE && fan_faces.contains(&far_face[k as usize]);
            if own_face_moves {
                let (d_new, d_old) = (dist2(after, x), dist2(before, x));
                if d_old <= limit2 || d_new > d_old {
                    uncovered = uncovered.max(d_new);
                }
            } else if within(before, &boxes_before, x) {
                uncovered = uncovered.max(dist2(after, x));
            }
        }
        // A point the move leaves farther than the limit (or farther than before) is
        // accepted only well below the distance of the point pulled in, so the largest
        // distance around the fan drops.
        if uncovered > FAR_TRADE * FAR_TRADE * far_d2 {
            return false;
        }
        const SAMPLES: [[f64; 3]; 7] = [
            [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
            [2.0 / 3.0, 1.0 / 3.0, 0.0],
            [1.0 / 3.0, 2.0 / 3.0, 0.0],
            [0.0, 2.0 / 3.0, 1.0 / 3.0],
            [0.0, 1.0 / 3.0, 2.0 / 3.0],
            [1.0 / 3.0, 0.0, 2.0 / 3.0],
            [2.0 / 3.0, 0.0, 1.0 / 3.0],
        ];
        // To the input by a walk from the face the nearest corner was projected onto (the
        // moved vertex: the far point's face); the BVH answers where the walk gets lost.
        let off_surface = |tris: &[[V3; 3]], hints: &[[u32; 3]]| {
            let mut worst: f64 = 0.0;
            for (t, h) in tris.iter().zip(hints) {
                for w in SAMPLES {
                    let x = vec3::add(
                        vec3::add(vec3::scale(t[0], w[0]), vec3::scale(t[1], w[1])),
                        vec3::scale(t[2], w[2]),
                    );
                    let k = if w[0] >= w[1] && w[0] >= w[2] {
                        0
                    } else if w[1] >= w[2] {
                        1
                    } else {
                        2
                    };
                    worst = worst.max(self.proj.project(x, h[k], self.l).hit.dist2);
                }
            }
            worst
        };
        let new_off = off_surface(after, hints[1]);
        new_off <= limit2 || new_off <= off_surface(before, hints[0])
    }

    /// Where free vertex `v` would move: the best of a few positions (towards its neighbours'
    /// centroid, or tangent steps of 0.05–0.3 of its target length, projected onto the input
    /// surface) when that raises the smallest angle of its triangles and keeps them nearly flat
    /// (or, on a fan that is not, lifts it to 30°). Reads only the positions, hints and sizes
    /// of `v` and its neighbours.
    fn plan_vertex(&self, v: u32) -> VertexPlan {
        let p = self.he.position(v);
        let mut c = [0.0; 3];
        let mut count = 0.0;
        for u in self.neighbor_iter(v) {
            c = vec3::add(c, self.he.position(u));
            count += 1.0;
        }
        let mut plan = VertexPlan {
            to: None,
            projections: 0,
            fallbacks: 0,
        };
        if count == 0.0 {
            return plan;
        }
        let c = vec3::scale(c, 1.0 / count);
        let mut normal = [0.0; 3];
        for k in self.he.outgoing(v) {
            normal = vec3::add(normal, self.he.face_normal_raw(halfedge::face_of(k)));
        }
        let n = vec3::normalize(normal);
        let seed = if n[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        // Any gain where the triangles around v are nearly flat (within 15° of their mean
        // normal, before and after); on a curved patch moving v changes the surface, so
        // only a move that ends the sliver (30°) is worth it there.
        let faces: Vec<[u32; 3]> = self
            .he
            .outgoing(v)
            .map(|k| self.he.face_vertices(halfedge::face_of(k)))
            .collect();
        let flat = |q: V3| {
            faces.iter().all(|t| {
                let [a, b, c] = t.map(|u| if u == v { q } else { self.he.position(u) });
                let m = vec3::cross(vec3::sub(b, a), vec3::sub(c, a));
                vec3::dot(m, n) >= COS_FLAT * vec3::norm(m)
            })
        };
        let flat_here = flat(p);
        let e1 = vec3::normalize(vec3::cross(n, seed));
        let e2 = vec3::cross(n, e1);
        let mut candidates: Vec<V3> = [0.25, 0.5, 1.0]
            .iter()
            .map(|&t| vec3::lerp(p, c, t))
            .collect();
        for r in [0.05, 0.15, 0.3] {
            for k in 0..8 {
                let a = k as f64 * std::f64::consts::FRAC_PI_4;
                let d = vec3::add(vec3::scale(e1, a.cos()), vec3::scale(e2, a.sin()));
                candidates.push(vec3::add(p, vec3::scale(d, r * self.size[v as usize])));
            }
        }
        let mut best = (self.fan_min_angle_cos(v, NONE), p, NONE);
        for q in candidates {
            let r = self.proj.project(q, self.hint[v as usize], self.l);
            plan.projections += 1;
            plan.fallbacks += r.fallback as u32;
            let Some(new) = self.fan_below(v, r.hit.point, best.0) else {
                continue;
            };
            let ok = if flat_here {
                flat(r.hit.point)
            } else {
                new <= COS_FLIP_MIN_ANGLE && !self.move_leaves_surface(v, r.hit.point)
            };
            if ok {
                best = (new, r.hit.point, r.hit.face);
            }
        }
        if best.2 != NONE {
            plan.to = Some((best.1, best.2));
        }
        plan
    }

    /// Counts the projections of `plan` and moves `v` where it says; returns whether it moved.
    fn apply_plan(&mut self, v: u32, plan: VertexPlan) -> bool {
        self.projections += plan.projections as usize;
        self.fallbacks += plan.fallbacks as usize;
        let Some((p, face)) = plan.to else {
            return false;
        };
        self.he.set_position(v, p);
        self.hint[v as usize] = face;
        true
    }

    /// After the rounds: collapses between two free vertices that lower the valence
    /// deviation of the four corners of the edge's pair. A 5–5 edge between two 7s becomes
    /// one regular vertex with two regular apexes (a 4 beside two 7s likewise), which no flip
    /// reaches: flipping that edge makes 4s and 8s. Such collapses may leave edges up to
    /// [`VALENCE_COLLAPSE_STRETCH`]·L and no angle below 30° that was not there, and the two
    /// vertices removed must lie within [`VALENCE_COLLAPSE_OFF`]·L of the triangles that
    /// replace them (on a curved patch or a thin part one vertex fewer cuts the surface).
    /// A few sweeps; a vertex next to a collapse waits for the next one. Returns the number
    /// of collapses.
    fn collapse_for_valence(&mut self, par: Par) -> usize {
        let mut valence: Vec<i64> = {
            let he = &self.he;
            par.map_collect(he.n_vertex_slots(), |v| he.valence(v as u32) as i64)
        };
        // `lengths_ok` compares with the split length, 4/3 L.
        let stretch2 = (VALENCE_COLLAPSE_STRETCH * 0.75).powi(2);
        let off2 = (VALENCE_COLLAPSE_OFF * self.l).powi(2);
        let mut done = 0;
        for _ in 0..3 {
            let mut touched = vec![false; self.he.n_vertex_slots()];
            let mut any = false;
            for h in 0..self.he.n_halfedge_slots() as u32 {
                if !self.he.is_halfedge_alive(h)
                    || !self.he.is_canonical(h)
                    || self.he.is_boundary_edge(h)
                    || self.he.tag(h) != NONE
                {
                    continue;
                }
                let (a, b) = (self.he.from(h), self.he.to(h));
                if touched[a as usize]
                    || touched[b as usize]
                    || !self.movable(a)
                    || !self.movable(b)
                {
                    continue;
                }
                let c = self.he.from(halfedge::prev(h));
                let d = self.he.from(halfedge::prev(self.he.opp(h)));
                // a and b are free, off the boundary: their target is 6.
                let (va, vb) = (valence[a as usize], valence[b as usize]);
                let dc = valence[c as usize] - self.target_valence(c);
                let dd = valence[d as usize] - self.target_valence(d);
                let before = (va - 6).pow(2) + (vb - 6).pow(2) + dc * dc + dd * dd;
                let after = (va + vb - 10).pow(2) + (dc - 1).pow(2) + (dd - 1).pow(2);
                if after >= before
                    || !self.collapse_allowed_at(h, stretch2, false, COS_FLIP_MIN_ANGLE)
                {
                    continue;
                }
                if !self.merge_stays_within(h, off2) {
                    continue;
                }
                self.apply_collapse(h, &mut touched);
                valence[b as usize] = va + vb - 4;
                valence[c as usize] -= 1;
                valence[d as usize] -= 1;
                for u in self.neighbor_iter(b) {
                    touched[u as usize] = true;
                }
                done += 1;
                any = true;
            }
            if !any {
                break;
            }
        }
        done
    }

    /// Vertex splits for the valences, after the valence collapses (their inverse): a free
    /// vertex `v` of valence 7 or more becomes two joined vertices, `v` keeping the arc of
    /// its ring from `r_p` to `r_q` and a new vertex the rest, so that `r_p` and `r_q` gain an
    /// edge each. A 7 between two 5s becomes a 5 and a 6 between two 6s, an 8 two 6s. Made
    /// where it lowers the squared valence deviation of `v`, `r_p` and `r_q` (targets as for
    /// the flips), where the two vertices at their rings' centroids, on the input, make
    /// triangles that keep 30° (or the fan's smallest angle), turn by at most 60° and have
    /// sides between 0.6 and 4/3 of the local target, where `v`'s old place lies within 0.1 L
    /// of them, and where no input vertex nearby ends up farther than before and than
    /// [`VALENCE_SPLIT_NEAR`]·L ([`State::split_keeps_input_close`]). Three sweeps at most;
    /// the rings of a split wait for the next sweep. Made in slot order (planned ahead on the
    /// pool, see below): the same bits at any thread count.
    fn split_for_valence(&mut self, input: &TriMesh, par: Par) -> usize {
        let off2 = (VALENCE_COLLAPSE_OFF * self.l).powi(2);
        let n_in = input.n_vertices();
        let mut stamp = vec![0u32; n_in];
        let mut generation = 0u32;
        let mut done = 0;
        // After the first sweep, only vertices whose two-ring a split changed are planned
        // again (the plan of any other would be refused again).
        let mut last: Option<Vec<bool>> = None;
        for _ in 0..3 {
            let slots = self.he.n_vertex_slots();
            let candidates: Vec<u32> = (0..slots as u32)
                .filter(|&v| {
                    self.he.is_vertex_alive(v) && self.movable(v) && self.he.valence(v) >= 7
                })
                .filter(|&v| match &last {
                    Some(t) => {
                        let changed = |u: u32| t.get(u as usize).is_none_or(|&x| x);
                        changed(v) || self.neighbor_iter(v).any(changed)
                    }
                    None => true,
                })
                .collect();
            // Every candidate is planned on the pool against the sweep's first state; few
            // plans succeed. A split at w changes the positions, valences and fans of w, its
            // ring and the new vertex only (all `touched`), and the plan of v reads v, its
            // ring, their valences and the faces around the ring: a plan whose vertex and ring
            // are untouched is what planning it in order would give. The others are planned
            // again when their turn comes, in slot order as before.
            // (On one thread that would only add the plans of vertices touched before their
            // turn.)
            let mut plans: Option<Vec<Option<VertexSplit>>> = (par == Par::Rayon).then(|| {
                let st = &*self;
                par.map_init_collect(
                    candidates.len(),
                    || (vec![0u32; n_in], 0u32),
                    |(stamp, generation), k| {
                        st.plan_vertex_split(candidates[k], off2, input, stamp, generation)
                    },
                )
            });
            let mut touched = vec![false; slots];
            let mut any = false;
            for (k, &v) in candidates.iter().enumerate() {
                if touched[v as usize] {
                    continue;
                }
                let made_ahead = plans.as_mut().filter(|_| {
                    !self
                        .neighbor_iter(v)
                        .any(|u| touched.get(u as usize).is_none_or(|&t| t))
                });
                let plan = if let Some(plans) = made_ahead {
                    let plan = plans[k].take();
                    debug_assert_eq!(
                        plan,
                        self.plan_vertex_split(v, off2, input, &mut stamp, &mut generation),
                        "a plan made ahead differs from the plan in order"
                    );
                    plan
                } else {
                    self.plan_vertex_split(v, off2, input, &mut stamp, &mut generation)
                };
                let Some(plan) = plan else {
                    continue;
                };
                for &u in &plan.ring {
                    touched[u as usize] = true;
                }
                touched[v as usize] = true;
                self.apply_vertex_split(v, &plan);
                done += 1;
                any = true;
            }
            if !any {
                break;
            }
            last = Some(touched);
        }
        done
    }

    /// The best vertex split of `v` for the valences that passes the geometric tests of
    /// [`State::split_for_valence`], if any.
    fn plan_vertex_split(
        &self,
        v: u32,
        off2: f64,
        input: &TriMesh,
        stamp: &mut [u32],
        generation: &mut u32,
    ) -> Option<VertexSplit> {
        let ring: Vec<u32> = self.he.outgoing(v).map(|h| self.he.to(h)).collect();
        let n = ring.len();
        // A ring that meets itself (or a fan that is not closed) is left alone.
        if n < 7 || n != self.he.valence(v) {
            return None;
        }
        for i in 0..n {
            if ring[i + 1..].contains(&ring[i]) {
                return None;
            }
        }
        let dev: Vec<i64> = ring
            .iter()
            .map(|&u| self.he.valence(u) as i64 - self.target_valence(u))
            .collect();
        let nv = n as i64;
        // (gain, p, q): v keeps r_p ..= r_q (forward), the new vertex r_q ..= r_p.
        let mut cands: Vec<(i64, usize, usize)> = Vec::new();
        for p in 0..n {
            for q in p + 2..n {
                let s1 = (q - p - 1) as i64;
                let s2 = nv - 2 - s1;
                if s2 < 1 {
                    continue;
                }
                let before = (nv - 6).pow(2) + dev[p].pow(2) + dev[q].pow(2);
                let after =
                    (s1 - 3).pow(2) + (s2 - 3).pow(2) + (dev[p] + 1).pow(2) + (dev[q] + 1).pow(2);
                if after < before {
                    cands.push((before - after, p, q));
                }
            }
        }
        cands.sort_by(|x, y| y.0.cmp(&x.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let pos = |u: u32| self.he.position(u);
        let pv = pos(v);
        let old: Vec<[V3; 3]> = (0..n)
            .map(|k| [pv, pos(ring[k]), pos(ring[(k + 1) % n])])
            .collect();
        let old_cos = old
            .iter()
            .map(|t| min_angle_cos(t[0], t[1], t[2]))
            .fold(COS_FLIP_MIN_ANGLE, f64::max);
        let n_v = old.iter().fold([0.0; 3], |s, t| {
            vec3::add(s, vec3::cross(vec3::sub(t[1], t[0]), vec3::sub(t[2], t[0])))
        });
        let h = self.size[v as usize];
        let (lo2, hi2) = ((0.6 * h).powi(2), (4.0 / 3.0 * h).powi(2));
        for &(_, p, q) in &cands {
            let arc_a: Vec<usize> = (p..=q).collect();
            let arc_b: Vec<usize> = (q..=p + n).map(|k| k % n).collect();
            // The two ring centroids, each with the other vertex in its ring: a 2 × 2 system
            // per coordinate, solved exactly.
            let sum = |arc: &[usize]| {
                arc.iter()
                    .fold([0.0; 3], |s, &k| vec3::add(s, pos(ring[k])))
            };
            let (sa, sb) = (sum(&arc_a), sum(&arc_b));
            let (al, be) = ((arc_a.len() + 1) as f64, (arc_b.len() + 1) as f64);
            let det = al * be - 1.0;
            let a0 = vec3::scale(vec3::add(vec3::scale(sa, be), sb), 1.0 / det);
            let b0 = vec3::scale(vec3::add(vec3::scale(sb, al), sa), 1.0 / det);
            // The triangles of the split with its two vertices at `pa` and `pb` (each with the
            // normal of the old triangle it replaces), when their shapes pass.
            let shaped = |pa: V3, pb: V3| -> Option<Vec<([V3; 3], V3)>> {
                let mut new: Vec<([V3; 3], V3)> = Vec::with_capacity(n + 2);
                for (arc, x) in [(&arc_a, pa), (&arc_b, pb)] {
                    for w in arc.windows(2) {
                        let o = &old[w[0]];
                        new.push((
                            [x, o[1], o[2]],
                            vec3::cross(vec3::sub(o[1], pv), vec3::sub(o[2], pv)),
                        ));
                    }
                }
                new.push(([pa, pos(ring[q]), pb], n_v));
                new.push(([pa, pb, pos(ring[p])], n_v));
                let d2 = |x: V3, y: V3| {
                    let d = vec3::sub(x, y);
                    vec3::dot(d, d)
                };
                let ok = new.iter().all(|(t, n_old)| {
                    min_angle_cos(t[0], t[1], t[2]) <= old_cos
                        && keeps_orientation(*n_old, *t, self.cos_turn)
                }) && arc_a
                    .iter()
                    .all(|&k| (lo2..=hi2).contains(&d2(pa, pos(ring[k]))))
                    && arc_b
                        .iter()
                        .all(|&k| (lo2..=hi2).contains(&d2(pb, pos(ring[k]))))
                    && (lo2..=hi2).contains(&d2(pa, pb));
                ok.then_some(new)
            };
            // Off the surface first (no projection needed where that fails), then on it.
            if shaped(a0, b0).is_none() {
                continue;
            }
            let ra = self.proj.project(a0, self.hint[v as usize], self.l);
            let rb = self.proj.project(b0, self.hint[v as usize], self.l);
            let (pa, pb) = (ra.hit.point, rb.hit.point);
            let Some(new) = shaped(pa, pb) else {
                continue;
            };
            let ok = dist2_within(pv, new.iter().map(|(t, _)| *t), off2) <= off2
                && self.split_keeps_input_close(v, &ring, &old, &new, input, stamp, generation);
            if ok {
                return Some(VertexSplit {
                    ring,
                    p,
                    q,
                    a: (pa, ra.hit.face),
                    b: (pb, rb.hit.face),
                });
            }
        }
        None
    }

    /// Whether no input vertex near the fan of `v` ends farther from the triangles `new` (or
    /// from the faces around the fan, which stay) than it was and than [`VALENCE_SPLIT_NEAR`]·L:
    /// a split may not cut off a tip the fan reached.
    #[allow(clippy::too_many_arguments)]
    fn split_keeps_input_close(
        &self,
        v: u32,
        ring: &[u32],
        old: &[[V3; 3]],
        new: &[([V3; 3], V3)],
        input: &TriMesh,
        stamp: &mut [u32],
        generation: &mut u32,
    ) -> bool {
        let Some(t) = input.triangles.get(self.hint[v as usize] as usize) else {
            return false;
        };
        *generation += 1;
        let pv = self.he.position(v);
        let limit = VALENCE_SPLIT_NEAR * self.l;
        let near = self.input_near(
            pv,
            pv,
            ring,
            self.hint[v as usize],
            t[0],
            limit,
            input,
            stamp,
            *generation,
        );
        // The faces around the fan stay: a point closer to one of them keeps that distance.
        let fan: Vec<u32> = self.he.outgoing(v).map(halfedge::face_of).collect();
        let mut around: Vec<[V3; 3]> = Vec::new();
        let mut seen: Vec<u32> = Vec::new();
        for &u in ring {
            for h in self.he.outgoing(u) {
                let f = halfedge::face_of(h);
                if !fan.contains(&f) && !seen.contains(&f) {
                    seen.push(f);
                    around.push(self.he.face_vertices(f).map(|w| self.he.position(w)));
                }
            }
        }
        let limit2 = limit * limit;
        near.iter().all(|&k| {
            let x = input.positions[k as usize];
            let d_new = dist2_within(x, new.iter().map(|(t, _)| *t), limit2);
            if d_new <= limit2 {
                return true;
            }
            let d_around = dist2_to_triangles(x, around.iter().copied());
            let d_new = d_new.min(d_around);
            d_new <= limit2 || d_new <= dist2_to_triangles(x, old.iter().copied()).min(d_around)
        })
    }

    /// Makes the split planned by [`State::plan_vertex_split`]: the edge `v`–`r_{q+1}` is split
    /// and the edges from `v` to `r_{q+2}`, …, `r_{p-1}` flipped over to the new vertex.
    fn apply_vertex_split(&mut self, v: u32, s: &VertexSplit) {
        let n = s.ring.len();
        let h = self.he.find_edge(v, s.ring[(s.q + 1) % n]);
        let m = self.he.split_edge(h, s.b.0);
        self.role.push(Role::Free);
        self.param.push(0.0);
        self.hint.push(s.b.1);
        self.size.push(self.size[v as usize]);
        self.origin.push(self.origin[v as usize]);
        let mut k = s.q + 2;
        while k % n != s.p {
            let e = self.he.find_edge(v, s.ring[k % n]);
            self.he.flip(e);
            k += 1;
        }
        self.he.set_position(v, s.a.0);
        self.hint[v as usize] = s.a.1;
        debug_assert_eq!(self.he.valence(v), s.q - s.p + 2);
        debug_assert_eq!(self.he.valence(m), n - (s.q - s.p) + 2);
    }

    /// Whether both ends of `h` keep their old places within `√off2` of the triangles that
    /// replace them when `h` collapses (at [`Self::merged_position`]).
    fn merge_stays_within(&self, h: u32, off2: f64) -> bool {
        let (a, b) = (self.he.from(h), self.he.to(h));
        let p = self.merged_position(h);
        self.merged_fan_dist2(a, b, p, self.he.position(a)) <= off2
            && self.merged_fan_dist2(a, b, p, self.he.position(b)) <= off2
    }

    /// Squared distance from `q` to the triangles that stay around `a` and `b` when they
    /// merge at `p` (those of the edge a–b itself go).
    fn merged_fan_dist2(&self, a: u32, b: u32, p: V3, q: V3) -> f64 {
        let stay = [(a, b), (b, a)].into_iter().flat_map(|(v, other)| {
            self.he
                .outgoing(v)
                .map(|k| self.he.face_vertices(halfedge::face_of(k)))
                .filter(move |t| !t.contains(&other))
                .map(move |t| t.map(|u| if u == v { p } else { self.he.position(u) }))
        });
        dist2_to_triangles(q, stay)
    }

    fn collapse_slivers_sweep(&mut self, stretch2: f64, par: Par) -> bool {
        let mut any = false;
        let mut touched = vec![false; self.he.n_vertex_slots()];
        // The slivers at the sweep's start: a face that becomes one during the sweep has a
        // corner a collapse touched (only those move or change faces), and is skipped below
        // anyway. Those found are asked again (a collapse may have ended or removed them).
        for f in self.sliver_faces(par) {
            let Some(t) = self.sliver_corners(f) else {
                continue;
            };
            if t.iter().any(|&v| touched[v as usize]) {
                continue;
            }
            // The face's shortest side, either way along it.
            let h = (0..3u32)
                .map(|i| 3 * f + i)
                .min_by(|&p, &q| {
                    let lp = self.len2(self.he.from(p), self.he.to(p));
                    let lq = self.len2(self.he.from(q), self.he.to(q));
                    lp.total_cmp(&lq)
                })
                .expect("three sides");
            let g = self.he.opp(h);
            let mut pick = [h, g]
                .into_iter()
                .find(|&k| k != NONE && self.collapse_allowed_with(k, stretch2, true));
            if pick.is_none() && !self.collapse_topology_ok(h) {
                pick = self.cap_apex_collapse(f, stretch2);
            }
            let Some(pick) = pick else {
                // A boundary edge has one half-edge: its target can go into its origin only
                // this way (a boundary chain vertex beside a boundary corner).
                if g == NONE && self.merge_allowed(h, true, stretch2, true, COS_COLLAPSE_MIN_ANGLE)
                {
                    self.apply_merge(h, true, &mut touched);
                    any = true;
                }
                continue;
            };
            self.apply_collapse(pick, &mut touched);
            any = true;
        }
        any
    }

    /// For a cap `f` (an angle of 150° or more) whose shortest side fails the link condition,
    /// as where a tip of valence 3 has the cap's middle vertex beside it: a collapse of that
    /// middle vertex along one of its two sides (the shorter first) that
    /// [`Self::collapse_allowed_with`] allows and that leaves both vertices' old places within
    /// [`VALENCE_COLLAPSE_OFF`]·L of the triangles that replace them.
    fn cap_apex_collapse(&self, f: u32, stretch2: f64) -> Option<u32> {
        let t = self.he.face_vertices(f);
        let p = t.map(|u| self.he.position(u));
        let k = (0..3).find(|&k| {
            let u = vec3::normalize(vec3::sub(p[(k + 1) % 3], p[k]));
            let w = vec3::normalize(vec3::sub(p[(k + 2) % 3], p[k]));
            vec3::dot(u, w) <= -COS_CAP
        })?;
        // Half-edge 3f + k runs from corner k to k + 1; the twin of the one before it runs
        // from corner k to k + 2.
        let mut sides = [
            3 * f + k as u32,
            self.he.opp(halfedge::prev(3 * f + k as u32)),
        ];
        let len2 = |h: u32| {
            if h == NONE {
                f64::INFINITY
            } else {
                self.len2(self.he.from(h), self.he.to(h))
            }
        };
        if len2(sides[1]) < len2(sides[0]) {
            sides.swap(0, 1);
        }
        let off2 = (VALENCE_COLLAPSE_OFF * self.l).powi(2);
        sides.into_iter().find(|&h| {
            if h == NONE || !self.collapse_allowed_with(h, stretch2, true) {
                return false;
            }
            self.merge_stays_within(h, off2)
        })
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

    /// Collapses `pick` into its target, which takes the merged position and the smaller
    /// local target length, and marks the target as touched in this sweep.
    fn apply_collapse(&mut self, pick: u32, touched: &mut [bool]) {
        self.apply_merge(pick, false, touched);
    }

    /// [`Self::apply_collapse`], or with `into_origin` the other way round: the target of
    /// boundary half-edge `h` goes into its origin ([`Self::merge_allowed`]).
    fn apply_merge(&mut self, h: u32, into_origin: bool, touched: &mut [bool]) {
        let (mut a, mut b) = (self.he.from(h), self.he.to(h));
        if into_origin {
            std::mem::swap(&mut a, &mut b);
        }
        let p = self.merged_position_into(a, b);
        self.size[b as usize] = self.size[a as usize].min(self.size[b as usize]);
        if into_origin {
            self.he.collapse_keeping_origin(h);
        } else {
            self.he.collapse(h);
        }
        self.he.set_position(b, p);
        touched[b as usize] = true;
        self.collapses += 1;
        if self.role[a as usize] == Role::Corner {
            self.corners_merged += 1;
        }
    }

    fn collapse_short(&mut self) {
        // Whether an edge may collapse depends only on the one-rings of its ends and of the
        // apexes of its triangles (positions, connectivity, local sizes). A collapse into `b`
        // changes the one-rings of `b` and its new neighbours only; those get the collapse's
        // number in `changed`, and an edge refused after the last change of its four vertices
        // is refused again without looking (same outcome, far fewer tries in the later sweeps).
        let mut collapses = 0u32;
        let nh = self.he.n_halfedge_slots();
        let mut changed = vec![0u32; self.he.n_vertex_slots()];
        let mut refused = vec![0u32; nh];
        // After the first sweep, an edge none of whose four vertices changed since it was
        // last looked at is skipped by every test below (long, refused, or gone; an end
        // touched by a collapse is such a change): when a sweep changed few vertices, the
        // next one visits only the edges of the faces around them (a bit per half-edge),
        // and, within that sweep, the edges that its own collapses change further on.
        let mut todo: Option<Vec<u64>> = None;
        // A few sweeps per round: edges left short now are retried in the next round, after
        // relaxation has moved their neighbours.
        const SWEEPS: usize = 4;
        for sweep in 0..SWEEPS {
            let mut any = false;
            let first_stamp = collapses + 2;
            // A vertex takes part in one collapse per sweep: the sweep thins the mesh evenly
            // instead of merging a growing vertex again and again.
            let mut touched = vec![false; self.he.n_vertex_slots()];
            let mut h = 0u32;
            loop {
                // The next half-edge to look at: every one, or the next marked one (debug
                // builds look at every one and check that the unmarked ones are skipped).
                if !cfg!(debug_assertions) {
                    if let Some(bits) = &todo {
                        match next_marked(bits, h) {
                            Some(k) => h = k,
                            None => break,
                        }
                    }
                }
                if h as usize >= nh {
                    break;
                }
                let cur = h;
                h += 1;
                if todo.as_ref().is_some_and(|bits| !is_marked(bits, cur)) {
                    debug_assert!(
                        !self.worth_trying(cur, &touched, &refused, &changed),
                        "an unmarked edge is worth trying"
                    );
                    continue;
                }
                if !self.worth_trying(cur, &touched, &refused, &changed) {
                    continue;
                }
                let (a, b) = (self.he.from(cur), self.he.to(cur));
                let g = self.he.opp(cur);
                // Remove the vertex with fewer edges when both ways are allowed, else the one
                // that is allowed.
                let (first, second) = if g != NONE && self.he.valence(b) < self.he.valence(a) {
                    (g, cur)
                } else {
                    (cur, g)
                };
                // Between two free vertices both ways merge at the middle and test the same
                // triangles (up to the rounding of the middle): when the first way is refused,
                // the second is not tried.
                let both_free =
                    self.role[a as usize] == Role::Free && self.role[b as usize] == Role::Free;
                let pick = if self.collapse_allowed(first) {
                    first
                } else if second != NONE && !both_free && self.collapse_allowed(second) {
                    second
                } else {
                    // States are numbered from 1 (the state after `collapses` collapses is
                    // `collapses + 1`); 0 means "never refused".
                    refused[cur as usize] = collapses + 1;
                    continue;
                };
                let target = self.he.to(pick);
                self.apply_collapse(pick, &mut touched);
                collapses += 1;
                changed[target as usize] = collapses + 1;
                for u in self.neighbor_iter(target) {
                    changed[u as usize] = collapses + 1;
                }
                if let Some(bits) = &mut todo {
                    self.mark_edges_around(target, bits, cur + 1);
                    for u in self.neighbor_iter(target) {
                        self.mark_edges_around(u, bits, cur + 1);
                    }
                }
                any = true;
            }
            if !any || sweep + 1 == SWEEPS {
                break;
            }
            let stamped: Vec<u32> = (0..changed.len() as u32)
                .filter(|&v| changed[v as usize] >= first_stamp && self.he.is_vertex_alive(v))
                .collect();
            todo = (stamped.len() * 8 <= changed.len()).then(|| {
                let mut bits = vec![0u64; nh.div_ceil(64)];
                for &v in &stamped {
                    self.mark_edges_around(v, &mut bits, 0);
                }
                bits
            });
        }
    }

    /// Whether a collapse sweep tries the edge of canonical half-edge `h`: alive, no end
    /// collapsed into in this sweep (`touched`), shorter than the collapse length, and not
    /// refused since the last change of its ends and apexes.
    fn worth_trying(&self, h: u32, touched: &[bool], refused: &[u32], changed: &[u32]) -> bool {
        if !self.he.is_halfedge_alive(h) || !self.he.is_canonical(h) {
            return false;
        }
        let (a, b) = (self.he.from(h), self.he.to(h));
        if touched[a as usize] || touched[b as usize] {
            return false;
        }
        let lo = 4.0 / 5.0 * (0.5 * (self.size[a as usize] + self.size[b as usize]));
        if self.len2(a, b) >= lo * lo {
            return false;
        }
        if refused[h as usize] > 0 {
            let g = self.he.opp(h);
            let apex = |k: u32| self.he.from(halfedge::prev(k));
            let mut last = changed[a as usize]
                .max(changed[b as usize])
                .max(changed[apex(h) as usize]);
            if g != NONE {
                last = last.max(changed[apex(g) as usize]);
            }
            // Refused in state `refused[h]`, which included every change up to it.
            if refused[h as usize] >= last {
                debug_assert!(
                    !self.collapse_allowed(h) && (g == NONE || !self.collapse_allowed(g)),
                    "a collapse skipped as refused before is allowed now"
                );
                return false;
            }
        }
        true
    }

    /// Marks in `bits` the half-edges (and their twins) of the faces around `v` from index
    /// `from` on: the edges that have `v` as an end or as the apex of one of their triangles.
    fn mark_edges_around(&self, v: u32, bits: &mut [u64], from: u32) {
        let mut mark = |k: u32| {
            if k != NONE && k >= from {
                bits[(k / 64) as usize] |= 1 << (k % 64);
            }
        };
        for o in self.he.outgoing(v) {
            let f = halfedge::face_of(o);
            for k in [3 * f, 3 * f + 1, 3 * f + 2] {
                mark(k);
                mark(self.he.opp(k));
            }
        }
    }

    /// The valence that gives vertex `v` angles closest to 60°: 6 inside a smooth region and
    /// inside a feature chain away from the boundary (three triangles on each side of a
    /// crease); at a corner or on the boundary, each sector between two feature edges of angle
    /// θ wants max(1, round(θ / 60°)) triangles, plus one edge on the boundary (4 on a
    /// straight boundary, 3 at a square corner of a boundary, 6 at a cube corner).
    fn target_valence(&self, v: u32) -> i64 {
        let boundary = self.he.is_boundary_vertex(v);
        if !boundary && matches!(self.role[v as usize], Role::Free | Role::Chain(_)) {
            return 6;
        }
        // The fan's half-edges on the stack (this runs for every corner in every flip sweep);
        // a longer fan than the buffer holds goes to the heap.
        let mut buf = [NONE; 32];
        let mut n = 0;
        let mut heap: Vec<u32> = Vec::new();
        for h in self.he.outgoing(v) {
            if n < buf.len() {
                buf[n] = h;
            } else {
                if heap.is_empty() {
                    heap.extend_from_slice(&buf);
                }
                heap.push(h);
            }
            n += 1;
        }
        let hs: &[u32] = if heap.is_empty() { &buf[..n] } else { &heap };
        if n == 0 {
            return 6;
        }
        let tagged = |i: usize| self.he.tag(hs[i % n]) != NONE;
        // A corner without feature edges is a tip: its whole fan is one sector, closed around
        // the apex.
        let tip = !boundary && !(0..n).any(tagged);
        let start = if boundary || tip {
            0
        } else {
            (0..n).find(|&i| tagged(i)).unwrap_or(0)
        };
        let p = self.he.position(v);
        let sixty = std::f64::consts::PI / 3.0;
        let (mut tris, mut acc) = (0i64, 0.0);
        for i in start..start + n {
            let h = hs[i % n];
            let u = vec3::sub(self.he.position(self.he.to(h)), p);
            let w = vec3::sub(self.he.position(self.he.from(halfedge::prev(h))), p);
            acc += crestflow_geom::mesh::corner_angle(u, w);
            let closes = if boundary || tip {
                i + 1 == n || tagged(i + 1)
            } else {
                tagged(i + 1)
            };
            if closes {
                tris += ((acc / sixty).round() as i64).max(1);
                acc = 0.0;
            }
        }
        if tip {
            // At least three triangles close a cone.
            return tris.max(3);
        }
        tris + boundary as i64
    }

    /// Whether moving `v` to `p` makes an edge at `v` a chord off the surface
    /// ([`Self::chord_leaves_surface`]): the far-point pull runs after the last splits, like
    /// the final flips ([`Self::long_flip_leaves_surface`]).
    fn move_leaves_surface(&self, v: u32, p: V3) -> bool {
        let q = self.he.position(v);
        self.neighbor_iter(v).any(|u| {
            let x = self.he.position(u);
            let split2 = Self::split_len2(self.size[u as usize], self.size[v as usize]);
            self.chord_leaves_surface([x, p], [x, q], [u, u], split2)
        })
    }

    /// Whether an edge `new` that replaces the edge `old` is longer than both the split length
    /// (`split2`, squared) and `old`, and its middle lies farther than [`FAR_POINT`]·L from
    /// the input surface and farther than the middle of `old`. The middles are projected
    /// from the input faces recorded for the vertices `hints` (new, old).
    fn chord_leaves_surface(
        &self,
        new: [V3; 2],
        old: [V3; 2],
        hints: [u32; 2],
        split2: f64,
    ) -> bool {
        let len2 = |e: [V3; 2]| {
            let d = vec3::sub(e[0], e[1]);
            vec3::dot(d, d)
        };
        let l2 = len2(new);
        if l2 <= split2 || l2 <= len2(old) {
            return false;
        }
        let off = |e: [V3; 2], v: u32| {
            let mid = vec3::lerp(e[0], e[1], 0.5);
            self.proj
                .project(mid, self.hint[v as usize], self.l)
                .hit
                .dist2
        };
        let far = off(new, hints[0]);
        far > (FAR_POINT * self.l).powi(2) && far > off(old, hints[1])
    }

    /// Whether flipping the edge `a`–`b` to `c`–`d` makes an edge longer than the split length
    /// (and than `a`–`b`) whose middle lies farther than [`FAR_POINT`]·L from the input surface
    /// and farther than the middle of `a`–`b`.
    fn long_flip_leaves_surface(&self, a: u32, b: u32, c: u32, d: u32) -> bool {
        let p = |v: u32| self.he.position(v);
        let split2 = Self::split_len2(self.size[c as usize], self.size[d as usize]);
        self.chord_leaves_surface([p(c), p(d)], [p(a), p(b)], [c, a], split2)
    }

    /// Whether flipping the folded pair `a`–`b` (face normals `n1`, `n2`) to `c`–`d` puts the
    /// edge back on the input: the middle of `a`–`b` lies farther than [`FAR_POINT`]·L from
    /// the input surface, that of `c`–`d` within half that distance (and neither new triangle
    /// turns over: `flip_ok`, checked by the caller). Such a pair spans a crease of the input
    /// (a ridge running from `c` to `d`) as a chord.
    fn flip_follows_crease(&self, a: u32, b: u32, c: u32, d: u32) -> bool {
        let p = |v: u32| self.he.position(v);
        // Where the walk gives up, no flip: the test is not worth building the BVH for.
        let off2 = |x: u32, y: u32| {
            let mid = vec3::lerp(p(x), p(y), 0.5);
            self.proj
                .project_walk(mid, self.hint[x as usize], self.l)
                .map(|hit| hit.dist2)
        };
        match (off2(a, b), off2(c, d)) {
            (Some(old), Some(new)) => old > (FAR_POINT * self.l).powi(2) && new <= 0.25 * old,
            _ => false,
        }
    }

    /// One flip sweep (module docs, step 3). With `neutral`, a flip that leaves the valence
    /// deviation of an irregular quad unchanged is made as well: it moves a 5–7 pair
    /// one edge, and pairs that meet a pair of the opposite orientation cancel in later
    /// sweeps, which flips that must lower the deviation never do.
    fn equalize_valences(&mut self, par: Par, neutral: bool) {
        let n = self.he.n_halfedge_slots() as u32;
        let cos_turn = self.max_turn.cos();
        let (target, mut valence): (Vec<i64>, Vec<i64>) = {
            let st = &*self;
            par.map_collect(st.he.n_vertex_slots(), |v| {
                if st.he.is_vertex_alive(v as u32) {
                    (st.target_valence(v as u32), st.he.valence(v as u32) as i64)
                } else {
                    (6, 0)
                }
            })
            .into_iter()
            .unzip()
        };
        // Per face, the cosine of its smallest angle and its unnormalised normal: each face
        // belongs to three pairs (positions do not move during the sweep, and the two faces
        // of every flip are refreshed). `min_angle_cos` does not depend on the corners' order.
        let mut faces: Vec<(f64, V3)> = {
            let he = &self.he;
            par.map_collect(n as usize / 3, |f| {
                let f = f as u32;
                if !he.is_face_alive(f) {
                    return (1.0, [0.0; 3]);
                }
                let [x, y, z] = he.face_vertices(f).map(|u| he.position(u));
                (min_angle_cos(x, y, z), he.face_normal_raw(f))
            })
        };
        for h in 0..n {
            if !self.he.is_halfedge_alive(h)
                || !self.he.is_canonical(h)
                || self.he.is_boundary_edge(h)
                || self.he.tag(h) != NONE
            {
                continue;
            }
            let g = self.he.opp(h);
            let (a, b) = (self.he.from(h), self.he.to(h));
            let c = self.he.from(halfedge::prev(h));
            let d = self.he.from(halfedge::prev(g));
            let (fh, fg) = (halfedge::face_of(h), halfedge::face_of(g));
            let dev = |v: u32, delta: i64| {
                let x = valence[v as usize] + delta - target[v as usize];
                x * x
            };
            let before = dev(a, 0) + dev(b, 0) + dev(c, 0) + dev(d, 0);
            let after = dev(a, -1) + dev(b, -1) + dev(c, 1) + dev(d, 1);
            let p = |v: u32| self.he.position(v);
            let old = faces[fh as usize].0.max(faces[fg as usize].0);
            // Keep the surface: no flip across a fold steeper than the collapse limit, unless
            // the pair cuts across a crease of the input that the other diagonal follows
            // (then whatever the valences, if the angles allow).
            let (n1, n2) = (faces[fh as usize].1, faces[fg as usize].1);
            if vec3::dot(n1, n2) < cos_turn * vec3::norm(n1) * vec3::norm(n2) {
                let new = min_angle_cos(p(d), p(b), p(c)).max(min_angle_cos(p(c), p(a), p(d)));
                if new <= old.max(COS_FLIP_MIN_ANGLE)
                    && self.flip_follows_crease(a, b, c, d)
                    && self.he.flip_ok(h)
                {
                    self.flip_counted(h, &mut valence);
                    self.refresh_faces(&mut faces, [fh, fg]);
                }
                continue;
            }
            let maybe_sideways = neutral && after == before && before > 0;
            if after >= before && !maybe_sideways && !(old > COS_FLIP_MIN_ANGLE) {
                continue;
            }
            let new = min_angle_cos(p(d), p(b), p(c)).max(min_angle_cos(p(c), p(a), p(d)));
            // Valence flips keep the smallest angle of the pair above 30° (or do not lower
            // it); a pair with a smaller angle is flipped whenever that raises it (then no
            // flip can undo another, so the sweeps terminate). Angles as cosines.
            let keeps_angles = new <= old.max(COS_FLIP_MIN_ANGLE);
            // A sideways flip needs the angle test above, and an angle-raising flip passes it
            // too: where it fails, whether the flip would be sideways does not matter, and
            // the roles of the four rings are not looked at (most pairs with equal valence
            // deviations before and after end here).
            let sideways = maybe_sideways
                && keeps_angles
                && [a, b, c, d].iter().all(|&v| {
                    self.role[v as usize] == Role::Free
                        && self
                            .neighbor_iter(v)
                            .all(|u| self.role[u as usize] == Role::Free)
                });
            let valence_better = after < before || sideways;
            if !valence_better && !(old > COS_FLIP_MIN_ANGLE) {
                continue;
            }
            let ok = if valence_better {
                keeps_angles
            } else {
                new < old - 1e-6
            };
            if !ok {
                continue;
            }
            // After the last splits, a flip that makes an edge the split rule would cut may
            // not put its middle farther than FAR_POINT·L from the input (where the far-point
            // step counts the surface as cut off), unless the old edge's middle was farther: a
            // long diagonal of a curved pair otherwise spans the surface as a chord (on the
            // armadillo at 1 %, 0.46 L off it, the largest distance of the output).
            if self.no_split_follows && self.long_flip_leaves_surface(a, b, c, d) {
                continue;
            }
            // A sideways flip changes the surface a curved pair stands for, for no valence
            // gain (near the tip of a thin cigar they cut it off further): only where the
            // pair folds by less than 25° and the normals at its corners agree within 40°.
            if sideways && {
                let nn = vec3::normalize(vec3::add(n1, n2));
                vec3::dot(n1, n2) < COS_SIDEWAYS_FLAT * vec3::norm(n1) * vec3::norm(n2)
                    || [a, b, c, d].iter().any(|&v| {
                        let vn = self
                            .he
                            .outgoing(v)
                            .map(|k| self.he.face_normal_raw(halfedge::face_of(k)))
                            .fold([0.0; 3], vec3::add);
                        vec3::dot(vec3::normalize(vn), nn) < COS_SIDEWAYS_NORMALS
                    })
            } {
                continue;
            }
            if self.he.flip_ok(h) {
                self.flip_counted(h, &mut valence);
                self.refresh_faces(&mut faces, [fh, fg]);
            }
        }
    }

    /// Recomputes the smallest-angle cosine and normal of faces `fs` in a flip sweep's table.
    fn refresh_faces(&self, faces: &mut [(f64, V3)], fs: [u32; 2]) {
        for f in fs {
            let [x, y, z] = self.he.face_vertices(f).map(|u| self.he.position(u));
            faces[f as usize] = (min_angle_cos(x, y, z), self.he.face_normal_raw(f));
        }
    }

    /// Flips the edge of `h` and updates the valences of its quad's corners in `valence`.
    fn flip_counted(&mut self, h: u32, valence: &mut [i64]) {
        let (a, b) = (self.he.from(h), self.he.to(h));
        let c = self.he.from(halfedge::prev(h));
        let d = self.he.from(halfedge::prev(self.he.opp(h)));
        self.he.flip(h);
        valence[a as usize] -= 1;
        valence[b as usize] -= 1;
        valence[c as usize] += 1;
        valence[d as usize] += 1;
        self.flips += 1;
    }

    fn relax_and_project(&mut self, par: Par, project: bool) {
        let nv = self.he.n_vertex_slots();
        let he = &self.he;
        let role = &self.role;
        let proj = self.proj;
        let far = self.l;
        let lloyd = self.lloyd;
        // Per face: its unnormalised normal (2 × area along the normal), its corner sum
        // weighted by a third of that length, and the length itself. Computed by each of its
        // corners (three times over): one parallel loop per sweep instead of two, which on
        // meshes of a few thousand vertices costs less than the second loop's start.
        let face_value = |f: u32| {
            let [x, y, z] = he.face_vertices(f).map(|u| he.position(u));
            let nf = vec3::cross(vec3::sub(y, x), vec3::sub(z, x));
            let a = vec3::norm(nf);
            (nf, vec3::scale(vec3::add(vec3::add(x, y), z), a / 3.0), a)
        };
        // Chain vertices slide along their chains meanwhile: that reads their parameters and
        // fixed corners only, and their new positions are written after the free vertices'
        // moves, which see the old ones (as when the slide ran after them).
        let mut param = std::mem::take(&mut self.param);
        let mut slides = std::mem::take(&mut self.slides);
        // Each vertex's new place goes into a second buffer (its neighbours read the old
        // ones), swapped in afterwards; its projection hint, which no other vertex reads, is
        // updated in place. One parallel loop writes both, with no list of moves between
        // (written back after the loop, on the calling thread or on the pool, the moves cost
        // a few milliseconds of fandisk_large's run at 2 %).
        let mut hint = std::mem::take(&mut self.hint);
        let mut next = std::mem::take(&mut self.spare_positions);
        next.resize(nv, [0.0; 3]);
        let st = &*self;
        // The new place of `v` from its projection hint `h`: the place, its input face
        // (`NONE`: the old place, kept) and how it was projected (0: not, 1: by a walk, 2: by
        // the BVH).
        let relax = |v: u32, h: u32| -> (V3, u32, u8) {
            let p = he.position(v);
            if !he.is_vertex_alive(v) {
                return (p, NONE, 0);
            }
            match role[v as usize] {
                Role::Corner => (p, h, 0),
                // Slid by the other side of the join.
                Role::Chain(_) => (p, NONE, 0),
                Role::Free => {
                    // Centroid of the incident triangles' centroids weighted by their
                    // areas, moved within the tangent plane of the area-weighted
                    // vertex normal.
                    let mut s = [0.0; 3];
                    let mut nsum = [0.0; 3];
                    let mut w = 0.0;
                    let mut degree = 0;
                    if lloyd {
                        for k in he.outgoing(v) {
                            degree += 1;
                            // The corners after v, in the face's order.
                            let a = he.position(he.to(k));
                            let b = he.position(he.to(halfedge::next(k)));
                            let n = vec3::cross(vec3::sub(a, p), vec3::sub(b, p));
                            nsum = vec3::add(nsum, n);
                            let (g, area) = voronoi_part(p, a, b);
                            s = vec3::add(s, vec3::scale(g, area));
                            w += area;
                        }
                    } else {
                        for k in he.outgoing(v) {
                            degree += 1;
                            let (nf, c, a) = face_value(halfedge::face_of(k));
                            nsum = vec3::add(nsum, nf);
                            s = vec3::add(s, c);
                            w += a;
                        }
                    }
                    let q = if w > 0.0 {
                        let u = vec3::sub(vec3::scale(s, 1.0 / w), p);
                        let n = vec3::normalize(nsum);
                        vec3::add(p, vec3::sub(u, vec3::scale(n, vec3::dot(n, u))))
                    } else {
                        p
                    };
                    if degree == 3 && shrinks_tetrahedron(he, v, q, 0.5 * far) {
                        return (p, h, 0);
                    }
                    if project {
                        let r = proj.project(q, h, far);
                        (r.hit.point, r.hit.face, 1 + r.fallback as u8)
                    } else {
                        (q, h, 0)
                    }
                }
            }
        };
        const CHUNK: usize = 512;
        let (counts, slid) = par.join(
            || {
                par.map_chunk_pairs_mut(&mut next, &mut hint[..nv], CHUNK, |start, ps, hs| {
                    let (mut projections, mut fallbacks) = (0, 0);
                    for (i, (p, h)) in ps.iter_mut().zip(hs.iter_mut()).enumerate() {
                        let (q, f, k) = relax((start + i) as u32, *h);
                        *p = q;
                        if f != NONE {
                            *h = f;
                        }
                        projections += (k > 0) as usize;
                        fallbacks += (k > 1) as usize;
                    }
                    (projections, fallbacks)
                })
            },
            || st.slide_chain_params(&mut param, &mut slides),
        );
        for (p, f) in counts {
            self.projections += p;
            self.fallbacks += f;
        }
        self.he.swap_positions(&mut next);
        self.spare_positions = next;
        self.hint = hint;
        self.param = param;
        self.slides = slides;
        for (v, p) in slid {
            self.he.set_position(v, p);
        }
    }

    /// Every vertex inside a chain moves to the middle (in arc length) of its two chain
    /// neighbours, on the chain, unless that would make one of its two feature edges stray
    /// from the chain by more than the tolerance (so bends stay in place). Gauss–Seidel in
    /// vertex order: few vertices, and each move is checked against its neighbours' current
    /// places. Updates `param` and returns the new positions (the mesh is not touched, so
    /// that it can run beside the free vertices' relaxation). `slides` keeps each vertex's
    /// last slide ([`Slide`]).
    fn slide_chain_params(&self, param: &mut [f64], slides: &mut Vec<Slide>) -> Vec<(u32, V3)> {
        slides.resize(self.he.n_vertex_slots(), Slide::NONE);
        let mut slid = Vec::new();
        for v in 0..self.he.n_vertex_slots() as u32 {
            let Role::Chain(c) = self.role[v as usize] else {
                continue;
            };
            if !self.he.is_vertex_alive(v) {
                continue;
            }
            let x = self.chain_neighbor(v, c, NONE);
            let y = if x == NONE {
                NONE
            } else {
                self.chain_neighbor(v, c, x)
            };
            if y == NONE {
                continue;
            }
            let s = param[v as usize];
            let (sx, sy) = self.stretch_params(param, c, x, y, s);
            // A boundary chain's slide also depends on the neighbours' places.
            let key = [sx.to_bits(), sy.to_bits(), s.to_bits()];
            let known = slides[v as usize];
            let same = known.chain == c && known.key == key && !self.boundary_chain[c as usize];
            // Debug builds compute the slide anyway and compare.
            if same && !cfg!(debug_assertions) {
                slid.push((v, known.p));
                param[v as usize] = known.to;
                continue;
            }
            let ch = &self.chains[c as usize];
            // The neighbours' places on the chain (where they are, or will be once slid onto
            // it: a curve chain starts at the edge path, off the network's polyline).
            let (px, py) = (ch.point_at(sx), ch.point_at(sy));
            // The stretch from x through v to y (on a short loop, maybe the longer way round),
            // and the ends of its two halves at a parameter t inside it.
            let (lo, hi) = ch.interval_through(sx, sy, s);
            let (plo, phi) = if lo == sx { (px, py) } else { (py, px) };
            let unwrap = |t: f64| if t < lo { t + ch.total() } else { t };
            let ok = |t: f64| {
                let t = unwrap(t);
                let p = ch.point_at(t);
                self.replaces(c, lo, t, plo, p)
                    && self.replaces(c, t, hi, p, phi)
                    && (!self.boundary_chain[c as usize] || self.boundary_slide_ok(v, p))
            };
            let t = ch.wrap(0.5 * (lo + hi));
            // Else onto the bend between the neighbours: two vertices that straddle a bend
            // cannot merge (their edge cannot cut it), and they would stay a short edge
            // with a needle triangle on each side.
            let to = if ok(t) {
                Some(t)
            } else {
                ch.sharpest_over(lo, hi).filter(|&k| ok(k))
            };
            // Onto the chain at its own parameter when it stays: a no-op on a chain of input
            // edges, and on a curve chain never farther from the network's polyline than
            // before.
            let t = to.unwrap_or(s);
            let p = ch.point_at(t);
            debug_assert!(
                !same
                    || (known.to.to_bits() == t.to_bits()
                        && known.p.map(f64::to_bits) == p.map(f64::to_bits)),
                "a chain vertex's slide differs from the one computed before"
            );
            slid.push((v, p));
            param[v as usize] = t;
            slides[v as usize] = Slide {
                chain: c,
                key,
                to: t,
                p,
            };
        }
        slid
    }
}

/// The far input point being pulled in ([`State::pull_to_far_points`]): input vertex `i` at
/// `p` on input face `p_face`, its squared distance `far_d2` from the output, the distance
/// limit, the faces the far points are closest to, and the stamps of [`State::input_near`].
struct FarPull<'a> {
    p: V3,
    i: u32,
    p_face: u32,
    far_d2: f64,
    limit: f64,
    far_face: &'a [u32],
    input: &'a TriMesh,
    stamp: &'a mut [u32],
    generation: &'a mut u32,
}

impl FarPull<'_> {
    /// Whether the far point lies within the limit of `tris` (what a partial pull must reach).
    fn within_limit_of(&self, tris: impl IntoIterator<Item = [V3; 3]>) -> bool {
        let limit2 = self.limit * self.limit;
        dist2_within(self.p, tris, limit2) <= limit2
    }

    /// The squared distance that [`State::move_keeps_distances`] divides by [`FAR_TRADE`]²
    /// to bound what a change may uncover: the far point's own with a `trade`; without one
    /// (a partial pull or split), at most what makes that bound the limit itself.
    fn uncover_bound2(&self, trade: bool) -> f64 {
        if trade {
            self.far_d2
        } else {
            self.far_d2
                .min(self.limit * self.limit / (FAR_TRADE * FAR_TRADE))
        }
    }
}

/// What [`State::split_toward`] would do to one edge: the triangles it replaces (`NONE` for
/// the middle of the split edge) and makes (`NONE` for the new vertex), the faces it
/// replaces, and the sides (vertex pairs) it flips after the split.
struct SplitPlan {
    before: Vec<[u32; 3]>,
    after: Vec<[u32; 3]>,
    faces: Vec<u32>,
    flips: Vec<(u32, u32)>,
}

/// Longest edge, in target lengths, that a collapse for the valences may leave
/// ([`State::collapse_for_valence`]); the relaxation after it evens them out.
/// A vertex split planned by [`State::plan_vertex_split`]: the ring of the vertex, the two
/// ring positions that become the apexes of the new edge, and the two vertices' places (point,
/// input face).
#[derive(Debug, PartialEq)]
struct VertexSplit {
    ring: Vec<u32>,
    p: usize,
    q: usize,
    a: (V3, u32),
    b: (V3, u32),
}

/// What [`State::plan_vertex`] found for a vertex: where to move it (position and input face),
/// if anywhere, and the projections it made.
#[derive(Clone, Copy)]
struct VertexPlan {
    to: Option<(V3, u32)>,
    projections: u32,
    fallbacks: u32,
}

const VALENCE_COLLAPSE_STRETCH: f64 = 1.5;

/// How far, in target lengths, the two vertices of a collapse for the valences may lie from
/// the triangles that replace them.
const VALENCE_COLLAPSE_OFF: f64 = 0.1;

/// How far (in target lengths) a vertex split for the valences may leave an input vertex near
/// it when that is farther than before ([`State::split_keeps_input_close`]). With the far-point
/// limit (0.3 L) in its place, the relaxation after the splits left the bunny at 2 % 0.33 L
/// from an input vertex (0.30 L without the splits); with 0.15 L, 0.30 L.
const VALENCE_SPLIT_NEAR: f64 = 0.15;

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

/// How far, in target lengths, a vertex of a sliver may move onto an input vertex
/// ([`State::move_sliver_vertices_onto_input`]).
const SLIVER_MOVE_REACH: f64 = 0.8;

/// A share of the squared far-point limit within which an output vertex alone shows that an
/// input vertex is not far: below 1, so that rounding in the triangle distances cannot undo
/// what the vertex shows.
const NEAR_CORNER: f64 = 0.99;

/// Distance from the output, in target lengths, beyond which an input vertex pulls the
/// output onto itself ([`State::pull_to_far_points`]).
const FAR_POINT: f64 = 0.3;

/// Curve chains shorter than this times L between two corners let the corners merge (see
/// `State::mergeable`).
const CORNER_MERGE: f64 = 0.3;

/// Median index distance between a face's corners above which the input is renumbered
/// (`crestflow_geom::locality`): 512 positions are 12 KB, within the first-level caches.
/// Scans and subdivided meshes measured 1064–46815, generated CAD parts 11–102.
const INCOHERENT_SPREAD: u32 = 512;

/// How far, relative to the far point pulled in, a point the pull uncovers may end up from
/// the output ([`State::move_keeps_distances`]).
const FAR_TRADE: f64 = 0.7;

/// Cosine of 30°, the smallest angle a vertex pulled onto a far input point may leave in
/// its triangles (unless it was smaller before).
const COS_FAR_MOVE_MIN_ANGLE: f64 = 0.866_025_403_784_438_6;

/// cos 25°: the largest fold between the pair of triangles of a sideways (valence-neutral)
/// flip. Until version 28 the limits were 5° and 10°: on curved organic shapes most 5–7
/// pairs then could not move (the scale-conforming armadillo at 1 % kept 0.77–0.78 of its
/// vertices regular over six axis orders, 0.80–0.81 with these limits; Hausdorff median
/// 0.00448 → 0.00440).
const COS_SIDEWAYS_FLAT: f64 = 0.906_307_787_036_649_9;

/// cos 40°: how far the vertex normals of its four corners may turn from the pair's normal.
const COS_SIDEWAYS_NORMALS: f64 = 0.766_044_443_118_978;

/// cos 15°: how far a triangle's normal may turn from its fan's mean for the final vertex
/// moves.
const COS_FLAT: f64 = 0.965_925_826_289_068_3;

/// Holes bounded by three edges shorter than this many target lengths are closed before
/// remeshing ([`close_small_triangular_holes`]): a triangle with one side of 0.5 L and two of
/// L has angles of about 29°.
const HOLE_EDGE: f64 = 0.5;

/// Cosine of 30°: a triangle with an angle of 150° or more (the supplement) is a cap.
const COS_CAP: f64 = 0.866_025_403_784_438_6;

/// Valence-improving flips may not create an angle below both the old smallest angle of the
/// pair and 30° (its cosine).
const COS_FLIP_MIN_ANGLE: f64 = 0.866_025_403_784_438_6;

/// Collapses may not create an angle below both the old smallest angle around them and 20°
/// (its cosine).
const COS_COLLAPSE_MIN_ANGLE: f64 = 0.939_692_620_785_908_4;

fn is_marked(bits: &[u64], k: u32) -> bool {
    bits[(k / 64) as usize] & (1 << (k % 64)) != 0
}

/// The first half-edge at or after `from` whose bit is set in `bits`.
fn next_marked(bits: &[u64], from: u32) -> Option<u32> {
    let mut w = (from / 64) as usize;
    let mut word = *bits.get(w)? & (u64::MAX << (from % 64));
    loop {
        if word != 0 {
            return Some(w as u32 * 64 + word.trailing_zeros());
        }
        w += 1;
        word = *bits.get(w)?;
    }
}

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

/// Whether `v` is a vertex of a tetrahedron (a closed part collapsed to four vertices of
/// valence 3, which no collapse can reduce further) whose move to `q` would bring it within
/// `floor` of a neighbour, and closer than it is. Tangential relaxation pulls each vertex of
/// such a part toward the other three: on a smooth sphere that settles into a regular
/// tetrahedron, but on a coarse small part, or with one vertex fixed, it draws all four to one
/// point (small closed parts of a CAD assembly remeshed at a target about their size ended
/// so). Below the floor no move may shorten a vertex's shortest edge.
fn shrinks_tetrahedron(he: &HalfEdgeMesh, v: u32, q: V3, floor: f64) -> bool {
    let valence3 = |u: u32| !he.is_boundary_vertex(u) && he.valence(u) == 3;
    if !(valence3(v) && he.outgoing(v).all(|k| valence3(he.to(k)))) {
        return false;
    }
    let nearest = |x: V3| {
        he.outgoing(v)
            .map(|k| vec3::dist(x, he.position(he.to(k))))
            .fold(f64::INFINITY, f64::min)
    };
    let near_q = nearest(q);
    near_q < floor && near_q < nearest(he.position(v))
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
    const VERSION: u32 = 38;
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
        else a split part of the way (report far_splits_partway). \
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

/// The part of triangle (p, a, b) nearer to p than to a and b (its Voronoi part; where the
/// triangle is obtuse, the circumcentre is replaced by the middle of the longest side, as in
/// Meyer et al.'s mixed area): centroid and area.
fn voronoi_part(p: V3, a: V3, b: V3) -> (V3, f64) {
    let (u, w) = (vec3::sub(a, p), vec3::sub(b, p));
    let n = vec3::cross(u, w);
    let nn = vec3::dot(n, n);
    if nn <= 0.0 {
        return (p, 0.0);
    }
    let (ma, mb) = (vec3::lerp(p, a, 0.5), vec3::lerp(p, b, 0.5));
    let (da, db, dab) = (vec3::dot(u, u), vec3::dot(w, w), vec3::dist(a, b).powi(2));
    let c = if dab >= da + db {
        vec3::lerp(a, b, 0.5)
    } else if da >= db + dab {
        ma
    } else if db >= da + dab {
        mb
    } else {
        // circumcentre p + (|u|² (w × n) + |w|² (n × u)) / (2 |n|²)
        let t = vec3::add(
            vec3::scale(vec3::cross(w, n), da),
            vec3::scale(vec3::cross(n, u), db),
        );
        vec3::add(p, vec3::scale(t, 0.5 / nn))
    };
    let tri = |x: V3, y: V3, z: V3| {
        let a = 0.5 * vec3::norm(vec3::cross(vec3::sub(y, x), vec3::sub(z, x)));
        (vec3::scale(vec3::add(vec3::add(x, y), z), a / 3.0), a)
    };
    let (g1, a1) = tri(p, ma, c);
    let (g2, a2) = tri(p, c, mb);
    let a = a1 + a2;
    if a <= 0.0 {
        return (p, 0.0);
    }
    (vec3::scale(vec3::add(g1, g2), 1.0 / a), a)
}
