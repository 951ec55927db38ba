// ricci — target curvatures and the discrete Ricci flow solvers (gradient descent, Newton).
//
// The flow du/dt = K̄ − K is the gradient flow of the Ricci energy
//     E(u) = ∫ Σ_i (K_i − K̄_i) du_i,      ∇E = K − K̄,      ∇²E = ∂K/∂u,
// convex in E (strictly on Σu = 0) and strictly convex in H (the paper's Theorems 5 and 6); not
// convex in S. Newton's method solves ∂K/∂u · δ = K̄ − K with a sparse Cholesky factorization
// whose symbolic analysis is done once per solve, and is globalised by a backtracking line search
// on E (energy differences by Gauss–Legendre quadrature along the step).
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ricci/intrinsic.h"
#include "ricci/metric.h"
#include "ricci/status.h"
#include "ricci/topology.h"

namespace ricci {

// ---------------------------------------------------------------------------------------------
// Targets.

/// What is prescribed on the boundary.
enum class BoundaryMode : int {
  Free = 0,      ///< boundary vertices carry an explicit K̄ like interior ones (per-vertex targets)
  FixedLengths,  ///< u is held at its starting value on the boundary (Dirichlet); boundary K free
  Circle,        ///< each loop becomes a circle, K̄ recomputed as lengths change; loop totals +2π
                 ///< for the longest loop and −2π for the others unless given. E (totals ±2π):
                 ///< the loop's polygon inscribed in a circle, K̄ = ±(α_in + α_out)/2 with
                 ///< α the sides' central angles in the circle through the polygon
                 ///< (inscribed_circle()); H, S, or when no such circle exists (one side at least
                 ///< as long as the others together): K̄ ∝ the length at each vertex (half the two
                 ///< incident boundary edges)
  Geodesic,      ///< K̄ = 0 on the boundary (hyperbolic background): geodesic boundary loops
  LoopTotals,    ///< a given total curvature per loop, spread by length as for Circle
};

std::string_view boundary_mode_name(BoundaryMode m);  ///< "free", "fixed", "circle", "geodesic", "loop-totals"

/// A target curvature. Vertices with fixed_u[v] != 0 keep their u and have no curvature
/// condition. For boundary modes Circle and LoopTotals the K̄ of boundary vertices is derived
/// from the current lengths and loop_total at every iteration (its stored value is ignored).
struct Target {
  std::vector<double> K;               ///< #V: K̄_i
  std::vector<std::uint8_t> fixed_u;   ///< #V: 1 where u is held fixed (empty: none)
  BoundaryMode boundary = BoundaryMode::Free;
  std::vector<double> loop_total;      ///< #loops: total K̄ per boundary loop (Circle, LoopTotals)
};

/// Uniformization of a closed surface: K̄ = 0 everywhere. For surfaces with boundary, interior
/// K̄ = 0 and the boundary as `mode` says (Circle: longest loop +2π, others −2π).
Target uniform_target(const Topology& topology, BoundaryMode mode = BoundaryMode::Circle);

/// All of 2πχ (minus what the boundary takes) at one vertex, zero elsewhere inside.
Target single_vertex_target(const Topology& topology, Index vertex, BoundaryMode mode = BoundaryMode::Circle);

/// Geometry chosen by the uniformization theorem for a closed surface: S for χ > 0, E for χ = 0,
/// H for χ < 0. With boundary: E for genus 0 (circle domain), H for genus ≥ 1 (geodesic boundary).
Geometry natural_geometry(const Topology& topology);
/// The natural boundary mode for the geometry: none (closed), Circle in E, Geodesic in H.
BoundaryMode natural_boundary_mode(const Topology& topology, Geometry geometry);

/// The ears (boundary vertices in a single triangle, validate.h find_ears()) that `target` makes
/// infeasible: ears without a fixed u whose target curvature is ≤ 0 — for Circle and LoopTotals
/// targets, whose boundary values are spread from the loop total, those on a loop with a total
/// ≤ 0 (the inner loops of a circle domain); otherwise those with K̄ ≤ 0 (a geodesic boundary).
/// An ear's angle is one triangle's, so its curvature is positive: these are exactly the ears
/// check_target() rejects, and split_ears() mends them. Sorted; empty when the sizes do not match.
std::vector<Index> infeasible_ears(const Topology& topology, const Target& target);

struct TargetFileResult {
  Status status = Status::NotRun;  ///< Ok, FileNotFound, FileUnreadable, FileTooLarge, ParseError, IndexOutOfRange
  std::string message = "not run";
  std::int64_t line = -1;
  Target target;
};
/// Reads `vertex_index curvature` lines (0-based vertex, radians; `#` comments, blank lines).
/// Unlisted interior vertices get 0; unlisted boundary vertices follow `mode`. A vertex listed
/// twice is a ParseError. A file larger than max_bytes (default 2 GiB, as ReadOptions) is
/// FileTooLarge, refused before any byte is read.
TargetFileResult read_target_file(const std::string& path, const Topology& topology,
                                  BoundaryMode mode = BoundaryMode::Free,
                                  std::uint64_t max_bytes = std::uint64_t{2} << 30);
/// read_target_file() on text already in memory: the same syntax and checks; statuses Ok,
/// ParseError, IndexOutOfRange (FileUnreadable only when memory runs out). `name` stands for the
/// path in messages ("name: line N: …"). Never throws. read_target_file() loads the file, then
/// parses it with this.
TargetFileResult parse_target_text(std::string_view text, const Topology& topology,
                                   BoundaryMode mode = BoundaryMode::Free, const std::string& name = "target");

/// The effective K̄ for the current edge lengths l (#E) in `geometry`: target.K, except that
/// boundary vertices of Circle / LoopTotals targets get loop_total[loop] · (½ of their two
/// boundary edge lengths) / (loop length) — or, for Circle loops in E with total ±2π, the
/// inscribed polygon's turning ±(α_in + α_out)/2, α the sides' central angles in the circle
/// through the polygon (inscribed_circle(); its vertices lie exactly on one circle, so a layout
/// closes around every hole and the circles do not depend on the cut). Writes #V values; allocates nothing.
void effective_target(const Topology& topology, const Target& target, std::span<const double> l,
                      std::span<double> K_target, Geometry geometry);

/// Whether effective_target() makes boundary loop `loop` an inscribed polygon (Circle, E, total ±2π).
bool inscribed_circle_loop(const Target& target, Geometry geometry, Index loop);

/// The circle through the vertices of a closed polygon with sides l (in order; E), the cyclic
/// polygon with those sides: it exists, and is unique, exactly when every side is shorter than the
/// sum of the others. Its centre lies inside (every side subtends a minor arc, Σ 2·arcsin(l_j/2R)
/// = 2π) or, when the longest side is too long for that, outside beyond the longest side, which
/// then subtends the major arc 2π − 2·arcsin(l_m/2R) (Σ_{j≠m} 2·arcsin(l_j/2R) = 2·arcsin(l_m/2R)).
struct InscribedCircle {
  double radius = 0;  ///< R; 0 when there is none (the polygon inequality fails) or a side is not positive finite
  Index major = -1;   ///< the position of the side with the major arc; −1 when the centre is inside
  /// The central angle of side j of length l: 2·arcsin(l/2R), or 2π minus that for `major`.
  double arc(Index j, double l) const;
  /// cos(arc/2): negative for `major`, its magnitude kept above 0.
  double half_arc_cosine(Index j, double l) const;
};
/// Solved to rounding: monotone Newton from a bound (both branches' equations are convex or
/// concave in the variable used), bisection where a step would leave the bracket.
InscribedCircle inscribed_circle(std::span<const double> sides);
/// The same for the sides of boundary loop `loop` (its edges in loop order, lengths l #E).
InscribedCircle inscribed_circle(const Topology& topology, Index loop, std::span<const double> l);
/// inscribed_circle(…).radius.
double inscribed_radius(std::span<const double> sides);
double inscribed_radius(const Topology& topology, Index loop, std::span<const double> l);

struct TargetCheck {
  Status status = Status::NotRun;  ///< Ok or InfeasibleTarget (or InvalidArgument for sizes)
  std::string message = "not run";
  Element element = Element::None;
  std::int64_t element_index = -1;
};
/// Checks a target before any iteration: sizes; Gauss–Bonnet (E: Σ K̄ = 2πχ; H: Σ K̄ > 2πχ;
/// S: Σ K̄ < 2πχ; the message states the expected value and the given sum); cone angles
/// positive (K̄ < 2π inside, K̄ < π on the boundary); and the admissibility condition of the
/// paper's Theorem 4 for every single vertex and every single boundary loop.
TargetCheck check_target(const Topology& topology, const ConformalStructure& structure, const Target& target);

/// Theorem 4 where a stalled circle-packing solve points (E and H, every η in [0, 1] — inversive
/// distance too, which is then a circle packing with Φ = arccos η; otherwise Ok, "no bound"):
/// (T4b) of check_target()'s notes on every sublevel set {u ≤ s} and superlevel set {u ≥ s} of
/// the last u (#V) — the radii that shrink or grow together when no packing exists — over the
/// vertices with a curvature condition (a Circle / LoopTotals loop enters whole, with its total;
/// held vertices never; in E proper subsets only). InfeasibleTarget naming the most violated set
/// (its size, its level of u, its first vertex), else Ok. A violated set proves the target
/// infeasible for these weights whatever u the solve reached; a sum within 1e-9·(1 + |bound|)
/// above its bound counts as violated (its radii would have to shrink past what double precision
/// holds).
TargetCheck check_theorem4_levels(const Topology& topology, const ConformalStructure& structure, const Target& target,
                                  std::span<const double> u);

// ---------------------------------------------------------------------------------------------
// Solvers.

enum class Method : int { Newton = 0, GradientDescent };

/// Storage of Newton's sparse Cholesky factor (FlowOptions::factorization).
enum class Factorization : int {
  Automatic = 0,  ///< simplicial below 180 flops per factor nonzero, supernodal above
  Supernodal,     ///< dense blocks through the BLAS
  Simplicial,     ///< column by column
};

struct FlowOptions {
  Method method = Method::Newton;
  /// Stop when max_i |K̄_i − K_i| < tolerance (over vertices with a curvature condition). A
  /// tolerance below the curvatures' rounding level (16 ulps of the largest angle sum, about 5e-14)
  /// is raised to it, with a note.
  double tolerance = 1e-10;
  /// Iteration limit: Newton steps, or gradient-descent steps.
  int max_iterations = 200;
  /// Gradient descent: u += step · (K̄ − K) (the paper's ε; at most 0.05 there).
  double gradient_step = 0.05;
  /// OpenMP threads for the kernels; 0 keeps the current setting (but solves meshes under 20 000
  /// faces on one thread, where forking costs more than the work). Results do not depend on it.
  /// Counts above available_threads() — this one or the current setting — are clamped to it.
  int threads = 0;
  /// S is not convex; Newton's safeguards there (targets that do not depend on the lengths):
  /// the round sphere (closed genus 0, K̄ = 0) starts from the stereographic image of a planar
  /// circle-domain solution instead of u0 (the three vertices pinned for the Möbius gauge keep
  /// that start's values); when Newton has not converged after 40 steps (or stops earlier), a
  /// continuation walks the target from the curvature at the start to K̄ through intermediate
  /// targets, each solved from the previous solution. Both are noted in the result. Off: Newton
  /// from u0 only.
  bool spherical_safeguards = true;
  /// Circle targets on genus-0 surfaces in E (Newton): fix the Möbius normalization of the circle
  /// domain explicitly — the first Fourier modes of u along the outer loop keep their starting
  /// values, and the outer loop's target gets two zero-sum modes (cos θ, sin θ) whose size the
  /// notes report. Off: the gauge is left free (the inscribed-polygon target of E is exactly
  /// Möbius invariant for vertex scaling, so Newton picks a member of the family; the target
  /// proportional to length is invariant only nearly, and fine meshes then converge slowly to a
  /// strongly distorted map).
  bool normalize_circle_domains = true;
  /// Circle and LoopTotals targets with vertex scaling (Newton): the derivative of the
  /// length-dependent target is split into its loop-local part, factorized with the Newton matrix,
  /// and one rank-one term per boundary loop (Woodbury): a Newton step costs one factorization and
  /// a solve per loop more than with a fixed target. Off (and for the other schemes, whose loop
  /// edges' lengths depend unequally on their ends): the boundary system of the size of the
  /// boundary, solved directly (dense LU) or by GMRES. The solutions agree to the tolerance.
  bool split_loop_coupling = true;
  /// Newton: once the tolerance is met, up to this many further Newton steps, each kept only when
  /// it lowers max |K̄ − K| (a layout closes up to the metric's residual curvature, so the last
  /// digits matter there); the first step that does not ends the polishing, and none is tried once
  /// the error is at the rounding level, 4 ε (4π + max |K̄|). The steps reuse the
  /// solve's symbolic analysis, are counted in `iterations` and `history`, and a note reports them.
  int polish_steps = 0;
  /// Newton with polishing (polish_steps > 0): after it, up to this many chord steps (the last
  /// factor, a solve and one evaluation each) while the step still changes some u by more than
  /// 1e-13 (after the gauge's mean), each at most half the one before and kept when max |K̄ − K|
  /// stays within the rounding level. A layout closes up to the curvature its loops enclose, and
  /// at a max error of a few ulps the residual's smooth part can still add up over large regions
  /// (genus2-400k: a residual summing to 1.6e-10, one propagation off by 2.0e-9 where its front
  /// closes; after one such step 1.1e-11). Counted in `iterations` and `history`; a note reports them.
  int smooth_steps = 3;
  /// Newton: reuse the last factor for chord steps where they reach what a new factor would for
  /// less (FlowResult::chord_steps); off: every step factorizes anew.
  bool chord_steps = true;
  /// Newton's factor. Automatic takes the simplicial layout where it was measured faster with
  /// Debian's ATLAS (systems of up to ~1e9 flops: 20–50 % faster flows at 5k–53k unknowns) and
  /// the supernodal one above; fix it for another BLAS. The solution agrees to rounding, and the
  /// stages after the flow give the same results either way.
  Factorization factorization = Factorization::Automatic;
  /// Called after every iteration (for progress output; the library never prints).
  std::function<void(const struct IterationRecord&)> on_iteration;

  bool is_valid(std::string* why) const;
};

/// Wall-clock seconds spent in each part of a solve (for benchmarks; sums over iterations).
/// Newton's work per iteration splits into `derivatives` + `assembly` + `factorization` + `solve`
/// + `line_search`; gradient descent puts its curvature evaluations into `line_search`.
struct FlowTimings {
  double setup = 0;          ///< vertex classes, first curvature evaluation, Hessian pattern
  double analysis = 0;       ///< symbolic analysis of the sparse factorization (once per solve)
  double derivatives = 0;    ///< per-face kernel: the 3×3 blocks of ∂θ/∂u (angle_derivative_blocks)
  double assembly = 0;       ///< Hessian values into the fixed pattern, right-hand side
  double factorization = 0;  ///< numeric factorizations (including shifted retries)
  double solve = 0;          ///< triangular solves and what is built on them (Möbius projection,
                             ///< boundary GMRES, circle-domain modes)
  double line_search = 0;    ///< trial points: lengths, angles, curvature, energy quadrature
};

struct IterationRecord {
  int iteration = 0;
  double max_error = 0;   ///< max |K̄ − K| after the step
  double energy = 0;      ///< E(u) − E(u_start)
  double step = 0;        ///< accepted step length (Newton: fraction of the Newton step)
  /// Newton: the step reused the last factor (a chord step: no new Hessian, no factorization;
  /// taken where it reaches what a new factor would, see FlowResult::chord_steps).
  bool chord = false;
  double seconds = 0;     ///< time since the start of the solve
  /// This iteration's share of FlowResult::timings (setup and analysis stay 0 here).
  FlowTimings timings;
};

struct FlowResult {
  /// Ok (converged), NotConverged, LineSearchFailed, InfeasibleTarget, TriangleInequality,
  /// NumericalFailure, InvalidArgument. u, l, K are the last iterate in every case but
  /// InvalidArgument and a target refused before the solve (then empty). solve_flow(): a
  /// circle-packing or inversive-distance solve that stalls (LineSearchFailed, NotConverged,
  /// TriangleInequality) where check_theorem4_levels() finds a violated set is InfeasibleTarget
  /// with that set in `message` (the stall in `notes`), and keeps its last iterate.
  Status status = Status::NotRun;
  std::string message = "not run";
  std::vector<double> u;         ///< #V
  std::vector<double> l;         ///< #E
  std::vector<double> K;         ///< #V
  std::vector<double> K_target;  ///< #V: the final target (boundary modes derive it from lengths)
  Geometry geometry = Geometry::Euclidean;  ///< the background geometry that was solved in
  int iterations = 0;  ///< steps taken (history entries), chord steps included
  /// Newton steps among `iterations` that reused the last factor (IterationRecord::chord): after a
  /// full Newton step that gained γ, the old factor converges at a rate of about 2γ, so where the
  /// chord steps needed to reach what the next Newton step would cost less than it (timed in the
  /// solve), they replace it; typically the last step of a solve and polishing.
  int chord_steps = 0;
  double max_curvature_error = 0;
  /// Vertices whose computed curvature resolves less than the tolerance (the ends of an edge far
  /// shorter than its neighbours: their angles follow from double lengths only to about ε·l/s),
  /// and the largest such resolution, ε·Σ|∂θ/∂u_b|·(1 + |u_b|) over the vertex's corners. Newton
  /// stops when each of them is within its resolution and every other vertex within the tolerance,
  /// so max_curvature_error may exceed the tolerance up to this. 0 on ordinary meshes.
  Index resolution_vertices = 0;
  double curvature_resolution = 0;
  double gauss_bonnet_error = 0;  ///< |Σ K + λ Σ A − 2πχ|
  double seconds = 0;
  /// Where `seconds` went, summed over every Newton (or gradient) run of the solve (the spherical
  /// safeguards may run several; the planar start of the round sphere is not included).
  FlowTimings timings;
  /// Nonzeros of the Cholesky factor of the last Newton run (0 for gradient descent).
  double factor_nonzeros = 0;
  /// solve_flow_with_flips(): edge flips from the starting triangulation to the final one, and the
  /// most non-Delaunay edges left at one point because their flip was refused (intrinsic.h).
  std::int64_t flips = 0;
  Index flips_refused = 0;
  std::vector<IterationRecord> history;
  /// Notes on safeguards that acted (spherical damping, fallback to the flow, …).
  std::vector<std::string> notes;

  /// One line: status, geometry, iterations, error, time.
  std::string brief_report() const;
};

/// The processors available to this process (omp_get_num_procs()), at least 1: the most threads
/// a solve uses. More only add overhead on these compute-bound kernels, and a count past what the
/// system can start (OMP_NUM_THREADS=100000, say) would bring the OpenMP runtime down.
int available_threads();

/// Lowers the OpenMP default thread count (OMP_NUM_THREADS, omp_set_num_threads()) to
/// available_threads() when it is above; returns the count it was, or 0 when it was not above.
/// For programs whose own parallel regions should not fail on a mistaken environment.
int cap_default_threads();

/// Solves for u such that K(u) = K̄ from the start u0 (#V).
FlowResult solve_flow(const Topology& topology, const ConformalStructure& structure, std::span<const double> u0,
                      const Target& target, const FlowOptions& options = {});

/// Vertex scaling with intrinsic Delaunay flips (intrinsic.h): solves K(u) = K̄ from u0 (#V) on
/// the Delaunay triangulation of each metric the solve visits. Before the start and at every trial
/// point of the line search (and every quadrature node) the triangulation is flipped by Ptolemy's
/// relation until it is Delaunay at that u, so the Ricci energy, which is C¹ and convex across
/// flips in E and H (Bobenko–Pinkall–Springborn 2015; Gu–Luo–Sun–Wu 2018), is evaluated with the
/// curvature of its own Delaunay triangulation; the Newton matrix is assembled on the current
/// triangulation (a changed pattern is analysed again with the first fill-reducing ordering).
/// Targets and options as solve_flow(). The round sphere (S, closed genus 0, K̄ = 0, nothing held,
/// spherical_safeguards on) starts from the planar problem with one vertex at infinity — the
/// sphere minus that vertex's star, projected stereographically, is a convex euclidean Dirichlet
/// problem — solved with flips, laid out, projected back and Möbius-centred (the flattest of up to
/// three vertices is sent to infinity; a note says which); Newton from u0 when none gives a start,
/// or when the start does not converge. The circle schemes' other spherical safeguards do not apply. On return `triangulation` is the Delaunay triangulation of the final u; FlowResult::l
/// are its edge lengths and `flips` counts the flips from the start.
FlowResult solve_flow_with_flips(IntrinsicTriangulation& triangulation, std::span<const double> u0,
                                 const Target& target, const FlowOptions& options = {});

}  // namespace ricci
