// The discrete Ricci flow solvers: gradient descent (the paper's Step 3.1) and Newton's method
// (Step 3.2) with a sparse Cholesky factorization whose symbolic analysis is done once per solve.
//
// Design notes.
//
// Unknowns. A vertex has a curvature condition unless it holds its u (target.fixed_u) or is used
// by no face. The Newton system has one row per condition vertex, minus the gauge-pinned ones
// below; the others keep their u (Dirichlet).
//
// Gauges. In E the angles do not change when u moves by a constant on a connected component,
// so ∂K/∂u has the constants of every component without a fixed vertex in its null space. Newton
// pins the first condition vertex of such a component (its update is 0 in the linear system,
// which is then positive definite), then subtracts the mean of the update over the component:
// since the rows of ∂K/∂u sum to zero there, the shifted update solves the full system too, and
// Σu keeps its starting value. The right-hand side K̄ − K sums to zero only up to rounding (which
// grows with the mesh); its mean is removed first, or the pinned vertex would collect the sum. (The paper's
// Step 3.1 normalises Σu = 0; holding Σu at its start instead gives the same metric up to a global scale and
// keeps the caller's scale: a mesh scaled by s gives u + log s. Gradient descent applies the same rule to its
// updates.) In S, a closed genus-0 component with K̄ = 0 everywhere (the round sphere) has a 3-dimensional
// family of solutions, the Möbius transformations, and ∂K/∂u is singular at the solution. Newton
// then pins three vertices far apart in the graph (about a quarter of the diameter from each
// other, so that their circles are not on one great circle) at their starting u and solves for
// the rest. The pinned curvature conditions hold at the solution by Möbius invariance (and are
// checked with the others) provided the right-hand side is orthogonal to the three Möbius
// directions, which rounding breaks by an amount growing with the mesh; so the right-hand side is
// projected onto their complement (three extra solves per step, see project_moebius()).
//
// Factorization. E and H: supernodal LLᵀ (CHOLMOD), as ∂K/∂u is positive definite for the
// circle-packing scheme (Theorems 5 and 6). S: simplicial LDLᵀ, as ∂K/∂u is indefinite there
// (growing all circles grows all angles, so the constants are a direction of negative curvature).
// When a factorization fails (a non-positive or zero pivot, e.g. for inversive distance or
// Yamabe far from a solution), A + μI is factorized for μ = 10⁻¹⁰, 10⁻⁸, … times the largest
// diagonal entry; when that fails too, or the direction is not a descent direction of the merit
// function below, the step falls back to the gradient direction. Each such event is counted in
// FlowResult::notes.
//
// Line search. E and H (targets that do not depend on the lengths): backtracking (Armijo, c = 10⁻⁴, halving)
// on the Ricci energy E(u) = ∫ Σ (K_i − K̄_i) du_i, whose change along t·δ is ∫_0^t (K(u + sδ) − K̄)·δ ds,
// evaluated by 4-point Gauss–Lobatto quadrature (curvature evaluations only; the end nodes are the current
// and the trial point, so a trial costs three curvature evaluations in all). Before that, a trial
// is accepted on cubic Hermite quadrature from the end points alone when it agrees with a rule of
// lower degree (f'(s) = δᵀ(∂K/∂u)δ from the per-face derivative blocks; the trial's blocks are the
// next step's, so an accepted Newton step costs one curvature evaluation and no extra kernel;
// see line_search()). When the energy
// change is below what rounding can resolve (near convergence), a step is accepted if it lowers
// the maximal curvature error; when even the slope is, only a few halvings are tried before the
// solve stops (LineSearchFailed: the tolerance is below the rounding level of the mesh).
// S: the target is a saddle point of E, not a minimum, so the merit function is ½‖K̄ − K‖² over
// the system rows (Newton directions are descent directions of it); the energy (with K̄ held over
// the step) is still recorded, as it is for length-dependent targets.
// Trial points whose u leaves the admissible range, whose lengths are not positive and finite (or
// unreasonably long in H), or which violate a triangle inequality are rejected (the step is
// halved). A step below 10⁻¹² is LineSearchFailed.
//
// Targets whose boundary mode is Circle or LoopTotals depend on the lengths. Newton solves
// K(u) − K̄(l(u)) = 0 with the Jacobian J = ∂K/∂u − ∂K̄/∂u: the second term lives on the boundary
// loops only, so J δ = g reduces to a system of the size of the boundary, solved directly from the
// factorization of ∂K/∂u (or by GMRES with it when the boundary is long; see coupled_direction()
// and setup_boundary_direct()) — with vertex scaling instead through the split of ∂K̄/∂u into a
// loop-local part factorized with the Newton matrix and one rank-one term per loop
// (split_direction()) — and the line search uses the residual merit
// ½‖K̄(l) − K‖² with K̄ recomputed at each trial. (Holding K̄ fixed within a step converges
// linearly at best — 20–110 steps on disks, annuli and spheres with holes — and oscillates without
// converging on surfaces with several holes; the coupled step takes 3–5.)
//
// Curvature resolution. A computed K_v is only as good as the lengths it is computed from: each
// length carries a rounding error of a few ulps (of it, and of its log), so K_v is known only to
// about ε·Σ |∂θ/∂u_b|·(1 + |u_b|) over the corners at v (update_resolution()). That is ~1e-15 on
// ordinary meshes, but at the ends of an edge far shorter than its neighbours (near-coincident
// vertices, which mollification keeps) ∂θ/∂u grows like l/s and K_v is noise below ε·l/s: 1e-5
// for s/l = 1e-11. Their pair sum is well conditioned, their split is not, and no double u hits
// it closer (a one-ulp change of u_v moves K_v by that much). Newton therefore judges a point by
// max_v |K̄_v − K_v|·min(1, tolerance / resolution_v) (judged_error()): the plain maximal error
// wherever the resolution is below the tolerance, which is every vertex of an ordinary mesh, so
// there nothing changes; the solve converges when every vertex is within the tolerance or its
// resolution, the line search's noise level includes the resolution, and steps below that noise
// are ranked by the judged error, so the rest of the mesh still converges quadratically while the
// pair sits at its noise floor. FlowResult reports the raw maximal error and the resolution.
//
// Determinism. Every parallel loop writes its own slots; sums use fixed chunks added in a fixed
// order; maxima are exact. Results do not depend on the number of threads.
#include "ricci/flow.h"
#include "sphere_start.h"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include "hessian.h"
#include "ricci/intrinsic.h"
#include "ricci/layout.h"
#include "sparse_solver.h"
#include "flow_parts.h"

namespace ricci {

namespace {

using Clock = std::chrono::steady_clock;
using detail::kParallelMin;
constexpr double kPi = std::numbers::pi;
constexpr double kEps = std::numeric_limits<double>::epsilon();
// Smoothing chord steps (FlowSolver::smooth_step()): taken while the step changes some u by more
// than kSmoothAbove, each at most kSmoothGain of the one before.
constexpr double kSmoothAbove = 1e-13;
constexpr double kSmoothGain = 0.5;

constexpr double kArmijo = 1e-4;
constexpr double kMinStep = 1e-12;
// Newton with intrinsic flips has stalled (FlowSolver::stalled()) after kStallSteps full steps in
// a row, each accepted at most kStallStep of the Newton step, that lowered max |K̄ − K| by less
// than kStallProgress (relative) together. With flips Newton converges in a few steps where it
// converges at all (uniformize() caps it at 60 and falls back); a long thin genus-0 surface's
// subdivision took 52 more such steps, 3.6 s, from 2.82 to 2.81. Without flips such runs of cut
// steps can end: applied there, the rule stopped the planar circle-packing solve that starts
// small sweep draw 1375's sphere, which then did not map; so it is not.
constexpr int kStallSteps = 8;
constexpr double kStallStep = 1.0 / 1024;
constexpr double kStallProgress = 0.01;
constexpr int kMaxShifts = 6;  // μ = 1e-10, 1e-8, …, 1 times the largest diagonal entry
constexpr double kFirstShift = 1e-10;
constexpr double kShiftGrowth = 100;
// Guards that keep every kernel free of overflow and division by zero (the debug tests trap
// them): e^{2u} stays below e^300; in H with ε > 0, 1 − ε e^{2u} stays above 1e-30; lengths stay
// above 1e-100 and, in H, below 200 (so sinh of half perimeters and their products are finite).
constexpr double kMaxU = 150;
constexpr double kMinHyperbolicGap = 1e-30;
constexpr double kMinLength = 1e-100;
constexpr double kMaxHyperbolicLength = 200;

// Quadrature of the energy change along a step: the 4-point Gauss–Lobatto rule on [0, 1]
// (exact for polynomials of degree 5, like 3-point Gauss–Legendre). Its end nodes are the current
// point and the trial point, whose curvatures are known anyway, so each trial costs two extra
// curvature evaluations instead of the three or four of a Gauss–Legendre rule of the same order.
constexpr int kQuadratureNodes = 4;
constexpr double kQuadratureNode[kQuadratureNodes] = {0.0, 0.5 - 0.5 / 2.2360679774997896964,
                                                      0.5 + 0.5 / 2.2360679774997896964, 1.0};
constexpr double kQuadratureWeight[kQuadratureNodes] = {1.0 / 12, 5.0 / 12, 5.0 / 12, 1.0 / 12};
// The line search's estimate of the energy change without interior nodes is used only when two
// rules of different degree agree on it to this fraction (see line_search()).
constexpr double kEstimateSpread = 0.1;

// Meshes with fewer faces than this are solved on the calling thread unless FlowOptions::threads
// asks otherwise: the kernels fork a team several times per iteration, which costs more than the
// work on a small mesh (and much more on an oversubscribed machine, where idle team members
// spin). The results do not depend on the thread count.
constexpr Index kSmallMeshFaces = 20000;

}  // namespace

int available_threads() { return std::max(1, omp_get_num_procs()); }

int cap_default_threads() {
  const int current = omp_get_max_threads();
  if (current <= available_threads()) return 0;
  omp_set_num_threads(available_threads());
  return current;
}

namespace {

using detail::ChunkedSum;
using detail::CircleDomainModes;
using detail::CurvatureResolution;
using detail::LoopTargetDerivative;
using detail::RestartedGmres;
using detail::VertexClasses;
using detail::max_error;

// Sets the OpenMP thread count for the duration of a solve (at most available_threads()).
class ThreadScope {
 public:
  ThreadScope(int threads, Index num_faces) {
    if (threads == 0 && num_faces < kSmallMeshFaces) threads = 1;
    if (threads == 0 && omp_get_max_threads() > available_threads()) threads = available_threads();
    threads = std::min(threads, available_threads());
    if (threads > 0) {
      saved_ = omp_get_max_threads();
      omp_set_num_threads(threads);
    }
  }
  ~ThreadScope() {
    if (saved_ > 0) omp_set_num_threads(saved_);
  }
  ThreadScope(const ThreadScope&) = delete;
  ThreadScope& operator=(const ThreadScope&) = delete;

 private:
  int saved_ = 0;
};


// Lengths, angles and curvature of one metric.
struct MetricState {
  std::vector<double> l, theta, K;
  void allocate(const Topology& t) {
    l.assign(static_cast<std::size_t>(t.num_edges), 0.0);
    theta.assign(3 * static_cast<std::size_t>(t.num_faces), 0.0);
    K.assign(static_cast<std::size_t>(t.num_vertices), 0.0);
  }
  void swap(MetricState& o) {
    l.swap(o.l);
    theta.swap(o.theta);
    K.swap(o.K);
  }
};

enum class Validity { Ok, OutOfRange, BadLength, TriangleInequality, FlipLimit };

// Evaluates lengths, angles and curvature at u; reports the first problem (the outputs are then
// partial but finite).
Validity evaluate(const Topology& t, const ConformalStructure& s, std::span<const double> u, MetricState& m) {
  const Index nv = t.num_vertices, ne = t.num_edges;
  const bool hyperbolic_radii = s.geometry == Geometry::Hyperbolic && s.epsilon > 0;
  int out_of_range = 0;
#pragma omp parallel for schedule(static) if (nv >= kParallelMin) reduction(max : out_of_range)
  for (Index v = 0; v < nv; ++v) {
    const double x = u[v];
    bool ok = std::isfinite(x) && x <= kMaxU;
    if (ok && hyperbolic_radii) ok = 1 - s.epsilon * std::exp(2 * x) >= kMinHyperbolicGap;
    if (!ok) out_of_range = 1;
  }
  if (out_of_range) return Validity::OutOfRange;
  if (edge_lengths(t, s, u, m.l) != kInvalid) return Validity::BadLength;
  const double max_length =
      s.geometry == Geometry::Hyperbolic ? kMaxHyperbolicLength : std::numeric_limits<double>::max();
  int bad_length = 0;
#pragma omp parallel for schedule(static) if (ne >= kParallelMin) reduction(max : bad_length)
  for (Index e = 0; e < ne; ++e)
    if (!(m.l[e] >= kMinLength && m.l[e] <= max_length)) bad_length = 1;
  if (bad_length) return Validity::BadLength;
  const AngleReport angles = corner_angles(t, s.geometry, m.l, m.theta);
  vertex_curvature(t, m.theta, m.K);
  return angles.violations > 0 ? Validity::TriangleInequality : Validity::Ok;
}


std::string format_double(const char* format, double x) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, x);
  return buffer;
}


// ---------------------------------------------------------------------------------------------

class FlowSolver {
 public:
  FlowSolver(const Topology& t, const ConformalStructure& s, std::span<const double> u0, const Target& target,
             const FlowOptions& options, FlowResult& result)
      : t_(t), s_(s), target_(target), options_(options), r_(result), sum_(std::max(t.num_vertices, t.num_faces)) {
    u_.assign(u0.begin(), u0.end());
  }

  void run();
  void finish();
  /// Pins for the Möbius gauge of the round sphere instead of the graph-distance choice (three
  /// distinct vertices; ignored unless valid).
  void set_sphere_pins(const std::array<Index, 3>& pins) { vc_.pin_hint = pins; }
  /// Vertex orders for the symbolic analysis of the Newton system: `hint` (when not null and not
  /// empty) is used as its fill-reducing ordering, restricted to the unknowns (vertices of the
  /// hint that are not unknowns are skipped; unknowns it misses go last, in index order); `out`
  /// (when not null) receives the ordering that was used, as vertices (with intrinsic flips: the
  /// last one, after the pattern changed). Newton only.
  void set_ordering(const std::vector<Index>* hint, std::vector<Index>* out) {
    order_hint_ = hint;
    order_out_ = out;
  }
  /// Intrinsic Delaunay flips (vertex scaling): the solver's topology and structure are
  /// `triangulation.topology` and `structure` (as passed to the constructor), which it keeps
  /// Delaunay at every point it evaluates, updating both in place (see evaluate_at()).
  void set_intrinsic(IntrinsicTriangulation& triangulation, ConformalStructure& structure) {
    tri_ = &triangulation;
    s_mut_ = &structure;
  }

 private:
  // Setup.
  // Iterations.
  bool newton_step();
  bool stalled();
  bool gradient_step();
  bool compute_direction();
  bool factorize_newton_matrix(Clock::time_point& mark, detail::FactorOutcome& outcome);
  bool project_moebius();
  bool gram_solve();
  bool line_search();
  bool polish_step();
  bool smooth_step();
  bool chord_step(double bound);
  bool chord_pays();
  bool chord_possible() const;
  /// max |K̄ − K| at the rounding level of the angle sums (kPolishUlps ulps of the largest).
  double curvature_rounding() const;
  double step_size();
  // Curvature resolution (see the design notes).
  void update_resolution();
  void resolution_at_u();
  void note_resolution();
  void set_tolerance();
  double judged_error(std::span<const double> K, std::span<const double> target) const;
  bool energy_difference(double t, double& dE);
  double directional_derivative(const Topology& t);
  // blocks_, allocated (9 per face) if energy_difference() or finish() released it.
  std::span<double> block_storage() {
    if (blocks_.empty()) blocks_.assign(9 * static_cast<std::size_t>(t_.num_faces), 0.0);
    return blocks_;
  }
  void remove_gauge_mean(std::span<double> step) { vc_.remove_gauge_mean(t_, step, sum_); }
  void accept(double step_length, double dE);
  // Circle / LoopTotals coupling.
  void setup_coupling();
  void loop_edge_derivatives() { loop_dK_.at(t_, s_, u_, cur_.l); }
  void target_derivative(std::span<const double> x, std::span<double> dK) {
    loop_dK_.apply(t_, target_, s_.geometry, cur_.l, x, dK);
  }
  void apply_boundary_operator(std::span<const double> w, std::span<double> out);
  void setup_boundary_direct(bool force = false);
  bool boundary_direct_solve();
  bool coupled_direction(std::span<const double> g);
  bool split_values();
  bool split_direction(std::span<const double> g);
  bool moebius_direction();
  Validity evaluate_at(std::span<const double> u, MetricState& m, bool& flipped);
  void undo_flips_after(std::int64_t keep);
  bool refresh_pattern();
  void keep_ordering(bool fresh);
  void compute_pin_edges();
  void fail(Status status, std::string message) {
    r_.status = status;
    r_.message = std::move(message);
  }
  double seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  // Seconds since `mark`, which moves to now.
  static double lap(Clock::time_point& mark) {
    const Clock::time_point now = Clock::now();
    const double s = std::chrono::duration<double>(now - mark).count();
    mark = now;
    return s;
  }
  void add_timings(const FlowTimings& t) {
    FlowTimings& r = r_.timings;
    r.derivatives += t.derivatives;
    r.assembly += t.assembly;
    r.factorization += t.factorization;
    r.solve += t.solve;
    r.line_search += t.line_search;
  }
  static std::string validity_text(Validity v) {
    switch (v) {
      case Validity::OutOfRange:
        return "u left its admissible range";
      case Validity::BadLength:
        return "an edge length is not a positive finite number in range";
      case Validity::TriangleInequality:
        return "a triangle violates the triangle inequality";
      case Validity::FlipLimit:
        return "flipping to the Delaunay triangulation did not finish within its flip limit";
      case Validity::Ok:
        break;
    }
    return "ok";
  }

  const Topology& t_;
  const ConformalStructure& s_;
  const Target& target_;
  const FlowOptions& options_;
  double tolerance_ = 0;  // options_.tolerance, raised to curvature_rounding() (run())
  FlowResult& r_;
  Clock::time_point start_ = Clock::now();
  ChunkedSum sum_;

  VertexClasses vc_;  // vertex classes (#V flags), components and gauge
  // Circle / LoopTotals targets: K̄ of the loop vertices depends on the lengths; the Newton
  // system is J = ∂K/∂u − ∂K̄/∂u (see coupled_direction()). Per boundary position p (the CSR
  // order of Topology::boundary_vertices): its vertex's unknown (or kInvalid), its outgoing edge
  // and ∂l/∂u of that edge at its two ends.
  bool coupled_ = false;
  bool residual_merit_ = false;  // S or coupled: the line search uses ½‖K̄ − K‖²
  std::vector<Index> position_unknown_;
  std::vector<double> position_dK_;
  LoopTargetDerivative loop_dK_;
  std::vector<double> full_;            // #V scratch
  std::vector<double> K_target_trial_;  // #V: effective target of the trial lengths
  // Restarted GMRES on the boundary system (dimension: the number of boundary positions).
  RestartedGmres gmres_;
  int gmres_failures_ = 0;
  // The boundary system by a direct solve (see setup_boundary_direct()): the positions with an
  // unknown (block columns) and their unknowns, G = E_Bᵀ H⁻¹ E_B over them, the LU factors of the
  // boundary matrix over all positions (row-major, with row pivots), and whether they belong to
  // the current factorization.
  bool boundary_direct_ = false;
  bool boundary_factored_ = false;
  int direct_fallbacks_ = 0;  // Newton steps whose boundary system went direct after GMRES failed
  // Measured choice: full solves GMRES spent on the boundary systems since the last factorization,
  // the estimated work of the direct solve and of one full solve (setup_boundary_direct()), and
  // whether GMRES once cost more than the direct solve would have (then direct for good).
  double operator_solves_ = 0;
  double direct_flops_ = -1, solve_flops_ = 0;
  bool prefer_direct_ = false;
  int switched_direct_at_ = 0;         // the Newton step from which prefer_direct_ holds (0: never)
  double switched_after_solves_ = 0;   // GMRES's full solves in the step before
  std::vector<Index> block_position_;
  std::vector<std::int64_t> block_unknown_;
  std::vector<double> block_gram_, boundary_lu_;
  std::vector<Index> boundary_pivot_;
  // The split coupling (see split_direction()): per position its loop-local weight w and the
  // factors a, b of its loop's rank-one term, the value slots of its diagonal entry and of the
  // entry to the next position of its loop (-1 where an end is not an unknown); the pins; F⁻¹ of
  // the low-rank columns (n each) and the LU factors of the small system (row pivots) and its
  // right-hand side; whether the values hold F this step and whether the small system's factors
  // are this factorization's.
  bool split_ = false;
  bool split_applied_ = false, split_ready_ = false;
  int split_fallbacks_ = 0;
  Index split_pin_count_ = 8;               // pins per positive loop of the next split factorization
  std::vector<Index> split_pins_;           // the pinned unknowns
  std::vector<double> split_rho_;           // their weights
  std::vector<double> split_w_, split_a_, split_b_, split_z_, split_c_, split_small_;
  std::vector<std::int64_t> split_diag_, split_next_;
  std::vector<Index> split_pivot_;
  // Circle domains: the Möbius normalization (CircleDomainModes).
  CircleDomainModes modes_;
  const std::vector<Index>* order_hint_ = nullptr;
  std::vector<Index>* order_out_ = nullptr;
  // Intrinsic flips (set_intrinsic()): the current triangulation and structure (t_ and s_ refer
  // to them), which a trial point and a quadrature node flip in place to their own Delaunay
  // triangulation, the flips recorded in journal_ to be undone when the point is not accepted (a
  // copy of the triangulation per point instead: 2 × 108 bytes per face held through the solve);
  // whether they hold the trial's flips now, and whether the Newton pattern is that of an older
  // triangulation.
  IntrinsicTriangulation* tri_ = nullptr;
  ConformalStructure* s_mut_ = nullptr;
  FlipJournal journal_;
  bool trial_flipped_ = false;
  bool pattern_stale_ = false;
  std::int64_t start_flips_ = 0;
  Index flips_refused_ = 0;
  int reanalyses_ = 0, pattern_reuses_ = 0;
  std::vector<std::int64_t> analysis_order_;
  double ordered_fill_ = 0;  // nonzeros of the factor with the last fresh ordering
  double ordered_flops_ = 0;  // its factorization's flops
  int reorderings_ = 0;      // fresh orderings after flips
  std::vector<std::vector<std::pair<Index, Index>>> pin_edges_;  // per pin: (edge, unknown) of its neighbours
  std::vector<std::vector<double>> moebius_;                     // per pin: w_p on the unknowns
  std::vector<double> gram_, coefficient_, rhs_projected_;

  // State.
  std::vector<double> u_, u_trial_, u_quad_;
  MetricState cur_, trial_, quad_;
  std::vector<double> K_target_;  // effective target of the current lengths
  std::vector<double> step_;      // #V: search direction (0 where u is held)
  std::vector<double> grad_;      // #V: K̄ − K on condition vertices (mean-free on E gauge components)
  double error_ = 0;
  double energy_ = 0;
  // Curvature resolution (resolution_.current when its values are those of u_); judged_ =
  // judged_error() of the current point (error_ when not active).
  CurvatureResolution resolution_;
  double judged_ = 0;
  int iteration_ = 0;

  // Newton.
  detail::HessianPattern pattern_;
  detail::SymmetricSolver solver_;
  std::vector<double> blocks_, rhs_, x_, x2_, tmp_;
  double slope_ = 0;  // derivative of the merit function along step_ at t = 0
  // Whether blocks_ hold the derivative blocks of u_ (of the trial point u_trial_), and the
  // seconds the line search spent computing them (see line_search()).
  bool blocks_at_u_ = false, blocks_at_trial_ = false;
  // Polishing (FlowOptions::polish_steps): a step is kept only when it lowers the maximal error.
  bool polishing_ = false;
  int polish_tried_ = 0, polished_ = 0;
  // Smoothing (smooth_step()): chord steps after the polishing while they still move u.
  bool smoothing_ = false, smoothing_over_ = false;
  int smoothed_ = 0;
  double smooth_first_ = 0, smooth_last_ = 0;  // the largest |δu| of the first and last smoothing steps
  // Chord steps (chord_step()): the last factor reused for a new right-hand side. factor_current_:
  // the factor is of the current pattern's Newton matrix at the last Newton point, unshifted.
  bool chord_ = false, factor_current_ = false;
  int chords_ = 0, polish_chords_ = 0;
  double chord_bound_ = 0;  // a chord step is kept only at a judged error at most this
  // The last full Newton step (t = 1, a new factor): its gain γ = e/e′ in judged error and the
  // quadratic constant M = e/e′² it shows.
  double newton_gain_ = 1, newton_constant_ = 0;
  int chords_in_row_ = 0;
  double error_before_polish_ = 0;
  double search_kernels_ = 0;
  double shift_ = 0;  // μ of the last factorization

  // Timings of the current iteration (see FlowTimings); the line search started at search_start_.
  FlowTimings iter_;
  Clock::time_point search_start_;
  bool iteration_recorded_ = false;

  // Counters for the notes.
  int shifted_ = 0, gradient_fallbacks_ = 0, noise_accepts_ = 0, damped_ = 0, projection_skipped_ = 0;
  double largest_shift_ = 0;
  std::vector<double> area_;
};

// With intrinsic flips, flips the triangulation in place, on top of what it holds, to the
// Delaunay triangulation at u (recorded in journal_; `flipped`: some flip was made) and updates the
// structure's η on the flipped edges; then evaluates there.
Validity FlowSolver::evaluate_at(std::span<const double> u, MetricState& m, bool& flipped) {
  flipped = false;
  if (m.K.empty()) m.allocate(t_);
  if (tri_) {
    const std::vector<Index> suspects = non_delaunay_edges(*tri_, u);
    if (!suspects.empty()) {
      const std::int64_t before = journal_.flips();
      const DelaunayReport report = make_delaunay(*tri_, u, suspects, DelaunayOptions{}, &journal_);
      flips_refused_ = std::max(flips_refused_, report.refused);
      flipped = journal_.flips() > before;
      bool finite = true;
      for (std::int64_t k = before; k < journal_.flips(); ++k) {
        const Index e = journal_.records[static_cast<std::size_t>(k)].edge;
        s_mut_->eta[e] = vertex_scaling_eta(*tri_, e);
        finite = finite && std::isfinite(s_mut_->eta[e]);
      }
      if (!report.complete) return Validity::FlipLimit;
      // A chord the flips made beyond double range: no length there is a finite number.
      if (!finite) return Validity::BadLength;
    }
  }
  return evaluate(t_, s_, u, m);
}

// Undoes the recorded flips after the first `keep` (the triangulation and the structure's η are
// then bit for bit what they were after those).
void FlowSolver::undo_flips_after(std::int64_t keep) {
  if (!tri_ || journal_.flips() <= keep) return;
  std::vector<Index> edges;
  for (auto r = journal_.records.begin() + keep; r != journal_.records.end(); ++r) edges.push_back(r->edge);
  undo_flips(*tri_, journal_, keep);
  for (const Index e : edges) s_mut_->eta[e] = vertex_scaling_eta(*tri_, e);
  if (keep == 0) trial_flipped_ = false;
}

// After flips changed the triangulation: the Newton pattern of the new one, analysed again unless
// it has the same entries, with the last analysis's ordering carried over (repair_ordering(): an
// unknown whose flipped-in edge crosses a separator of that ordering joins the separator), which
// skips the ordering, most of the analysis's cost; what depends on the analysis follows. False
// (with the status set) when it fails.
// Without the repair, a flipped-in edge across a top separator merges the fill of its two halves:
// the benchmark's generated genus-2 surface of 1M faces: its first flips took the factor from 1.0e10 to 1.7e11 flops
// with the old ordering, 1.3e10 with the repaired one (a fresh ordering: 1.0e10).
// Growth of the factor over the last fresh ordering's, in nonzeros or in flops, past which a
// pattern changed by flips gets a fresh ordering after all (see refresh_pattern()).
constexpr double kRefillGrowth = 1.25;
constexpr double kRefillFlops = 1.5;

// After a successful symbolic analysis: its ordering (CHOLMOD's, postordered) handed out as
// vertices (set_ordering()) and, with intrinsic flips, kept to be carried over to the next
// pattern; `fresh`: a new ordering, whose factor the carried-over ones are measured against.
void FlowSolver::keep_ordering(bool fresh) {
  const auto n = static_cast<std::size_t>(pattern_.num_unknowns);
  std::vector<std::int64_t> order(n);
  if (!solver_.ordering(order)) order.clear();
  if (order_out_ && !order.empty()) {
    order_out_->resize(n);
    for (std::size_t k = 0; k < n; ++k) (*order_out_)[k] = pattern_.unknown_vertex[order[k]];
  }
  if (fresh) {
    ordered_fill_ = solver_.factor_nonzeros();
    ordered_flops_ = solver_.factor_flops();
  }
  if (tri_) analysis_order_ = std::move(order);
}

bool FlowSolver::refresh_pattern() {
  Clock::time_point mark = Clock::now();  // the new pattern and its analysis count as analysis
  pattern_stale_ = false;
  detail::HessianPattern next = detail::build_hessian_pattern(t_, vc_.unknown);
  const bool same = next.col_ptr == pattern_.col_ptr && next.row == pattern_.row;
  // A new pattern: the old factor is of no use, and freed before the repair (it is the largest
  // thing the solve holds).
  if (!same) {
    solver_.reset();
    factor_current_ = false;
  }
  if (!same && !analysis_order_.empty()) analysis_order_ = detail::repair_ordering(t_, pattern_, next, analysis_order_);
  pattern_ = std::move(next);
  if (vc_.spherical_gauge) compute_pin_edges();
  if (same) {
    ++pattern_reuses_;
    const double seconds = lap(mark);
    r_.timings.analysis += seconds;
    iter_.factorization += seconds;
    return true;
  }
  const detail::FactorKind kind = s_.geometry == Geometry::Spherical ? detail::FactorKind::Indefinite
                                                                     : detail::FactorKind::PositiveDefinite;
  detail::FactorOutcome analysis =
      solver_.analyze(pattern_.num_unknowns, pattern_.col_ptr, pattern_.row, kind, analysis_order_);
  ++reanalyses_;
  // The carried-over ordering keeps the analysis cheap while the fill stays near what it was; once
  // the factor has grown past kRefillGrowth / kRefillFlops over the last fresh ordering's, a fresh
  // one (AMD, or METIS on large systems) is computed and carried over from then on.
  if (analysis == detail::FactorOutcome::Ok && ordered_fill_ > 0 &&
      (solver_.factor_nonzeros() > kRefillGrowth * ordered_fill_ || solver_.factor_flops() > kRefillFlops * ordered_flops_)) {
    solver_.reset();
    const detail::FactorOutcome fresh = solver_.analyze(pattern_.num_unknowns, pattern_.col_ptr, pattern_.row, kind, {});
    if (fresh != detail::FactorOutcome::Ok) {
      solver_.reset();
      analysis = solver_.analyze(pattern_.num_unknowns, pattern_.col_ptr, pattern_.row, kind, analysis_order_);
      if (analysis == detail::FactorOutcome::Ok) keep_ordering(false);
    } else {
      ++reorderings_;
      keep_ordering(true);
    }
  } else if (analysis == detail::FactorOutcome::Ok) {
    keep_ordering(false);
  }
  if (analysis == detail::FactorOutcome::Ok && coupled_ && !split_) {
    boundary_direct_ = false;
    setup_boundary_direct();
  }
  const double seconds = lap(mark);
  r_.timings.analysis += seconds;
  iter_.factorization += seconds;
  if (analysis != detail::FactorOutcome::Ok) {
    fail(analysis == detail::FactorOutcome::OutOfMemory ? Status::OutOfMemory : Status::NumericalFailure,
         "the symbolic analysis of the Newton system after intrinsic flips failed at step " +
             std::to_string(iteration_));
    return false;
  }
  return true;
}

// Per sphere-gauge pin: (edge, unknown) of each neighbour of the pin that is an unknown.
void FlowSolver::compute_pin_edges() {
  const std::size_t k = vc_.spherical_pins.size();
  pin_edges_.assign(k, {});
  for (std::size_t a = 0; a < k; ++a) {
    const Index p = vc_.spherical_pins[a];
    for (Index i = t_.vertex_corner_offsets[p]; i < t_.vertex_corner_offsets[p + 1]; ++i) {
      const Index c = t_.vertex_corners[i];
      for (const Index other : {next_corner(c), prev_corner(c)}) {
        // The edge from p to the vertex of `other` is opposite the third corner of the face.
        const Index third = 3 * corner_face(c) + (3 - corner_slot(c) - corner_slot(other));
        const Index j = pattern_.vertex_unknown[t_.corner_vertex[other]];
        if (j != kInvalid) pin_edges_[a].emplace_back(t_.corner_edge[third], j);
      }
    }
    std::sort(pin_edges_[a].begin(), pin_edges_[a].end());
    pin_edges_[a].erase(std::unique(pin_edges_[a].begin(), pin_edges_[a].end()), pin_edges_[a].end());
  }
}

// Energy change ∫_0^t (K(u + sδ) − K̄)·δ ds by quadrature, trial_ holding the metric at u + tδ;
// false when an interior node is not an admissible metric.
bool FlowSolver::energy_difference(double t, double& dE) {
  const Index nv = t_.num_vertices;
  // E and H: the derivative blocks (72 bytes per face) are given up while the quadrature's point
  // is held beside the current and the trial one (40 bytes per face each), where the solve would
  // otherwise peak in memory; the next step computes them again (one kernel pass). (In S a chord
  // step's Möbius pins read the blocks of the factorization's point.)
  if (s_.geometry != Geometry::Spherical) {
    blocks_ = std::vector<double>{};
    blocks_at_u_ = blocks_at_trial_ = false;
  }
  auto slope_at = [&](const std::vector<double>& K) {
    return sum_(nv, [&](std::int64_t v) { return vc_.condition[v] ? (K[v] - K_target_[v]) * step_[v] : 0.0; });
  };
  dE = 0;
  for (int q = 0; q < kQuadratureNodes; ++q) {
    const double s = t * kQuadratureNode[q];
    double f = 0;
    if (q == 0) {
      f = slope_at(cur_.K);
    } else if (q == kQuadratureNodes - 1) {
      f = slope_at(trial_.K);
    } else {
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
      for (Index v = 0; v < nv; ++v) u_quad_[v] = u_[v] + s * step_[v];
      // Flipped on top of the trial's flips, and back.
      const std::int64_t trial_flips = journal_.flips();
      bool flipped = false;
      const Validity validity = evaluate_at(u_quad_, quad_, flipped);
      undo_flips_after(trial_flips);
      if (validity != Validity::Ok) return false;
      f = slope_at(quad_.K);
    }
    dE += kQuadratureWeight[q] * f;
  }
  dE *= t;
  return std::isfinite(dE);
}

// d/ds (K(u + sδ) − K̄)·δ at s = 0, i.e. δᵀ (∂K/∂u) δ, from the per-face blocks of the current
// point: K_v = 2π − Σ θ, so the form is −Σ_f δ_fᵀ B_f δ_f (per-face terms, summed in order).
double FlowSolver::directional_derivative(const Topology& t) {
  return -sum_(t.num_faces, [&](std::int64_t f) {
    const double* B = &blocks_[9 * static_cast<std::size_t>(f)];
    const double d[3] = {step_[t.corner_vertex[3 * f]], step_[t.corner_vertex[3 * f + 1]],
                         step_[t.corner_vertex[3 * f + 2]]};
    double q = 0;
    for (int a = 0; a < 3; ++a) q += d[a] * (B[3 * a] * d[0] + B[3 * a + 1] * d[1] + B[3 * a + 2] * d[2]);
    return q;
  });
}

// The sphere gauge. At a solution, ∂K/∂u has the infinitesimal Möbius transformations as its
// null space; with the pins P (fixed in the system) and the unknowns R, a basis is w_p =
// (−H_RR⁻¹ H_Rp, e_p) for p ∈ P, three solves with the factorization at hand. The right-hand
// side g = K̄ − K lies in the range of ∂K/∂u, i.e. is orthogonal to these, in exact arithmetic; the
// computed curvatures satisfy this only up to rounding, and Newton would push that remainder
// (which grows with the mesh size) onto the pinned vertices. So g is projected orthogonally onto
// the complement of span{w_p} (the analogue of removing the mean in E) into rhs_projected_.
// False when a solve fails or the Gram matrix is not positive definite.
bool FlowSolver::project_moebius() {
  const Index n = pattern_.num_unknowns;
  const std::size_t k = vc_.spherical_pins.size();
  for (std::size_t a = 0; a < k; ++a) {
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (Index j = 0; j < n; ++j) tmp_[j] = 0;
    for (const auto& [e, j] : pin_edges_[a]) tmp_[j] = -detail::hessian_edge_entry(t_, blocks_, e);
    if (!solver_.solve(tmp_, moebius_[a])) return false;
  }
  // Gram matrix G_ab = w_a·w_b and c_a = w_a·g (the pin entries of w are e_p).
  for (std::size_t a = 0; a < k; ++a) {
    const std::vector<double>& wa = moebius_[a];
    for (std::size_t b = 0; b <= a; ++b) {
      const std::vector<double>& wb = moebius_[b];
      gram_[a * k + b] = sum_(n, [&](std::int64_t j) { return wa[j] * wb[j]; }) + (a == b ? 1.0 : 0.0);
    }
    coefficient_[a] = sum_(n, [&](std::int64_t j) { return wa[j] * rhs_[j]; }) + grad_[vc_.spherical_pins[a]];
  }
  // Dense Cholesky of G (lower triangle, in place) and the solve G α = c.
  for (std::size_t a = 0; a < k; ++a) {
    for (std::size_t b = 0; b <= a; ++b) {
      double x = gram_[a * k + b];
      for (std::size_t m = 0; m < b; ++m) x -= gram_[a * k + m] * gram_[b * k + m];
      if (a == b) {
        if (!std::isfinite(x) || x <= 0) return false;
        gram_[a * k + a] = std::sqrt(x);
      } else {
        gram_[a * k + b] = x / gram_[b * k + b];
      }
    }
  }
  if (!gram_solve()) return false;
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (Index j = 0; j < n; ++j) {
    double x = rhs_[j];
    for (std::size_t a = 0; a < k; ++a) x -= coefficient_[a] * moebius_[a][j];
    rhs_projected_[j] = x;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Circle / LoopTotals coupling. On a loop with vertices v_p, outgoing edges e_p (lengths l_p),
// length L and total T, the target is K̄(v_p) = T·m_p/L with m_p = ½(l_{p−1} + l_p), so
//     dK̄(v_p) = T/L · (½(dl_{p−1} + dl_p) − m_p·dL/L),   dl_p = ∂l_p/∂u · du,   dL = Σ dl_p.
// D = ∂K̄/∂u lives on the boundary positions B only, so J = H − E_B D_BB E_Bᵀ and Newton's
// J δ = g becomes, with y = H⁻¹g and w = D_BB E_Bᵀ δ (one value per boundary position),
//     (I − D_BB E_Bᵀ H⁻¹ E_B) w = D_BB E_Bᵀ y,     δ = y + H⁻¹ E_B w,
// a system of the size of the boundary, solved directly (setup_boundary_direct()) or by restarted
// GMRES whose operator costs one solve with the factorization at hand. (Holding K̄ fixed within a step instead converges linearly at
// best, and oscillates for surfaces with several holes.)

constexpr int kGmresMaxIterations = 400;

// LU with partial pivoting of the n×n row-major matrix A, in place, with the row swaps in pivot;
// false when the matrix is not finite or a pivot is at most `tiny` times its largest entry. The
// rows below each pivot are updated each on its own (in parallel when there are many): the same
// factors on any number of threads.
bool lu_factor(double* A, std::size_t n, std::vector<Index>& pivot, double tiny) {
  double largest = 0;
  for (std::size_t i = 0; i < n * n; ++i) largest = std::max(largest, std::abs(A[i]));
  if (!std::isfinite(largest)) return false;
  pivot.assign(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    std::size_t pivot_row = j;
    for (std::size_t i = j + 1; i < n; ++i)
      if (std::abs(A[i * n + j]) > std::abs(A[pivot_row * n + j])) pivot_row = i;
    const double p = A[pivot_row * n + j];
    if (!(std::abs(p) > tiny * largest)) return false;
    pivot[j] = static_cast<Index>(pivot_row);
    if (pivot_row != j)
      for (std::size_t c = 0; c < n; ++c) std::swap(A[j * n + c], A[pivot_row * n + c]);
    const auto rows = static_cast<std::int64_t>(n - j - 1);
#pragma omp parallel for schedule(static) if (rows >= 256)
    for (std::int64_t d = 1; d <= rows; ++d) {
      const std::size_t i = j + static_cast<std::size_t>(d);
      const double f = A[i * n + j] / p;
      A[i * n + j] = f;
      if (f != 0)
        for (std::size_t c = j + 1; c < n; ++c) A[i * n + c] -= f * A[j * n + c];
    }
  }
  return true;
}

// w ← A⁻¹w with lu_factor()'s factors.
void lu_solve(const double* A, std::size_t n, const std::vector<Index>& pivot, double* w) {
  for (std::size_t j = 0; j < n; ++j) std::swap(w[j], w[static_cast<std::size_t>(pivot[j])]);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t c = 0; c < i; ++c) w[i] -= A[i * n + c] * w[c];
  for (std::size_t i = n; i-- > 0;) {
    for (std::size_t c = i + 1; c < n; ++c) w[i] -= A[i * n + c] * w[c];
    w[i] /= A[i * n + i];
  }
}

void FlowSolver::setup_coupling() {
  const auto positions = static_cast<std::size_t>(t_.num_boundary_edges());
  if (positions == 0) return;
  coupled_ = true;
  position_unknown_.assign(positions, kInvalid);
  bool any_unknown = false;
  for (std::size_t p = 0; p < positions; ++p) {
    position_unknown_[p] = pattern_.vertex_unknown[t_.boundary_vertices[p]];
    any_unknown = any_unknown || position_unknown_[p] != kInvalid;
  }
  if (!any_unknown) {
    coupled_ = false;
    return;
  }
  loop_dK_.resize(positions);
  position_dK_.assign(positions, 0.0);
  // Vertex scaling: each loop edge's length has the same derivative in the u of its two ends, so
  // the target's derivative splits (split_direction()).
  split_ = options_.split_loop_coupling && s_.epsilon == 0;
  full_.assign(static_cast<std::size_t>(t_.num_vertices), 0.0);
  K_target_trial_.assign(static_cast<std::size_t>(t_.num_vertices), 0.0);
  gmres_.resize(positions);
}



// out = (I − D_BB E_Bᵀ H⁻¹ E_B) w on the boundary positions (positions whose vertex is not an
// unknown are identity rows with no coupling).
void FlowSolver::apply_boundary_operator(std::span<const double> w, std::span<double> out) {
  const Index n = pattern_.num_unknowns;
  ++operator_solves_;
  const auto positions = static_cast<Index>(position_unknown_.size());
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (Index j = 0; j < n; ++j) tmp_[j] = 0;
  for (Index p = 0; p < positions; ++p)
    if (position_unknown_[p] != kInvalid) tmp_[position_unknown_[p]] = w[p];
  if (!solver_.solve(tmp_, x2_)) {
    std::fill(out.begin(), out.end(), std::numeric_limits<double>::quiet_NaN());
    return;
  }
  for (Index p = 0; p < positions; ++p) {
    const Index j = position_unknown_[p];
    full_[t_.boundary_vertices[p]] = j != kInvalid ? x2_[j] : 0.0;
  }
  target_derivative(full_, position_dK_);
  for (Index p = 0; p < positions; ++p)
    out[p] = w[p] - (position_unknown_[p] != kInvalid ? position_dK_[p] : 0.0);
}


// The boundary system directly. G = E_Bᵀ H⁻¹ E_B over the positions with an unknown comes from
// the factor by sparse forward solves along elimination-tree paths (SymmetricSolver::
// inverse_block(), no full solve), the boundary matrix I − D_BB G (D_BB applied column by column,
// O(P²)) is factorized by LU with partial pivoting once per Newton step, and each coupled solve
// of the step (three with the circle-domain modes) is then one triangular pair of size P. Used
// when the estimated work is below that of about kDirectBoundarySolves full solves (restarted
// GMRES takes 10–16 per system, three systems per step, on circle domains); exact to rounding,
// where GMRES stops at the forcing tolerance. A failure (e.g. a singular boundary matrix) falls
// back to GMRES for that system.
constexpr double kDirectBoundarySolves = 16;
// Where GMRES does not reach its tolerance (an ill-conditioned boundary system: boundary edges
// many orders of magnitude apart), the direct solve is set up whatever its cost, up to this many
// boundary positions (dense LU, (2/3)·P³ flops once per Newton step).
constexpr Index kDirectBoundaryFallback = 3000;

void FlowSolver::setup_boundary_direct(bool force) {
  const auto positions = static_cast<Index>(position_unknown_.size());
  block_position_.clear();
  block_unknown_.clear();
  for (Index p = 0; p < positions; ++p)
    if (position_unknown_[p] != kInvalid) {
      block_position_.push_back(p);
      block_unknown_.push_back(position_unknown_[p]);
    }
  const double block_flops = solver_.prepare_block(block_unknown_);
  if (!(block_flops >= 0)) return;
  const auto P = static_cast<double>(positions);
  const double flops = block_flops + (2.0 / 3.0) * P * P * P + 8 * P * P;
  const double solve_flops = 4 * solver_.factor_nonzeros();
  direct_flops_ = flops;
  solve_flops_ = solve_flops;
  if (!force && !prefer_direct_ && !(flops <= kDirectBoundarySolves * solve_flops)) return;
  const auto k = block_unknown_.size();
  block_gram_.assign(k * k, 0.0);
  boundary_lu_.assign(static_cast<std::size_t>(positions) * static_cast<std::size_t>(positions), 0.0);
  boundary_direct_ = true;
}

// gmres_.w from gmres_.b with the LU factors of the boundary matrix, factorized first if they are not
// those of the current step. False when the block is unavailable, the matrix is singular or the
// result not finite.
bool FlowSolver::boundary_direct_solve() {
  const auto positions = static_cast<Index>(position_unknown_.size());
  const auto k = static_cast<Index>(block_position_.size());
  const std::size_t P = static_cast<std::size_t>(positions);
  double* S = boundary_lu_.data();
  if (!boundary_factored_) {
    if (!solver_.inverse_block(block_gram_)) return false;
    // Column q of I − D_BB G: e_q − D_BB applied to column q of G (zero for a position without
    // an unknown).
    std::fill(boundary_lu_.begin(), boundary_lu_.end(), 0.0);
    for (Index p = 0; p < positions; ++p) S[p * P + p] = 1;
    for (Index c = 0; c < k; ++c) {
      for (Index p = 0; p < positions; ++p) full_[t_.boundary_vertices[p]] = 0;
      for (Index r = 0; r < k; ++r)
        full_[t_.boundary_vertices[block_position_[r]]] = block_gram_[static_cast<std::size_t>(r) * k + c];
      target_derivative(full_, position_dK_);
      const Index q = block_position_[c];
      for (Index p = 0; p < positions; ++p)
        if (position_unknown_[p] != kInvalid) S[p * P + q] -= position_dK_[p];
    }
    if (!lu_factor(S, P, boundary_pivot_, 1e-14)) return false;
    boundary_factored_ = true;
  }
  double* w = gmres_.w.data();
  std::copy(gmres_.b.begin(), gmres_.b.end(), w);
  lu_solve(S, P, boundary_pivot_, w);
  for (std::size_t i = 0; i < P; ++i)
    if (!std::isfinite(w[i])) return false;
  return true;
}

// Turns x_ = H⁻¹ g (the step with K̄ held) into the Newton step of K − K̄(l(u)) = 0 and sets
// slope_ = d/dt ½‖K̄ − K‖² along it. Leaves x_ and slope_ for the held target when GMRES fails
// (and returns false).
bool FlowSolver::coupled_direction(std::span<const double> g) {
  if (split_applied_) return split_direction(g);
  const Index n = pattern_.num_unknowns;
  const auto positions = static_cast<Index>(position_unknown_.size());
  loop_edge_derivatives();
  // b = D_BB E_Bᵀ y.
  for (Index p = 0; p < positions; ++p) {
    const Index j = position_unknown_[p];
    full_[t_.boundary_vertices[p]] = j != kInvalid ? x_[j] : 0.0;
  }
  target_derivative(full_, position_dK_);
  for (Index p = 0; p < positions; ++p) gmres_.b[p] = position_unknown_[p] != kInvalid ? position_dK_[p] : 0.0;
  // Directly when set up (see setup_boundary_direct()); otherwise inexact Newton: GMRES to a
  // relative accuracy that tightens with the error.
  bool ok = boundary_direct_ && boundary_direct_solve();
  if (!ok) {
    // The relative residual left in the boundary system becomes about forcing × error in the next
    // curvature error: 0.01 × error keeps Newton quadratic, and nothing below a tenth of the
    // curvatures' rounding level (curvature_rounding()) can show in it, so the polishing steps
    // near that level need only a loose solve.
    const double forcing =
        std::clamp(std::max(0.01 * error_, 0.1 * curvature_rounding() / std::max(error_, 1e-300)), 1e-13, 1e-3);
    ok = gmres_.solve([this](std::span<const double> x, std::span<double> out) { apply_boundary_operator(x, out); },
                      forcing, kGmresMaxIterations);
    if (!ok && !boundary_direct_ && positions <= kDirectBoundaryFallback) {
      setup_boundary_direct(true);
      ok = boundary_direct_ && boundary_direct_solve();
      if (ok) ++direct_fallbacks_;
    }
  }
  if (ok) {
    // δ = y + H⁻¹ E_B w.
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (Index j = 0; j < n; ++j) tmp_[j] = 0;
    for (Index p = 0; p < positions; ++p)
      if (position_unknown_[p] != kInvalid) tmp_[position_unknown_[p]] += gmres_.w[p];
    ok = solver_.solve(tmp_, x2_);
  }
  // J δ = (g + E_B w − μ δ) − D δ, where (H + μI) δ = g + E_B w. For the held-target step y,
  // w = 0.
  if (ok) {
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (Index j = 0; j < n; ++j) x_[j] += x2_[j];
  } else {
    std::fill(gmres_.w.begin(), gmres_.w.end(), 0.0);
  }
  for (Index p = 0; p < positions; ++p) {
    const Index j = position_unknown_[p];
    full_[t_.boundary_vertices[p]] = j != kInvalid ? x_[j] : 0.0;
  }
  target_derivative(full_, position_dK_);
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (Index j = 0; j < n; ++j) tmp_[j] = g[j] - shift_ * x_[j];
  for (Index p = 0; p < positions; ++p) {
    const Index j = position_unknown_[p];
    if (j != kInvalid) tmp_[j] += gmres_.w[p] - position_dK_[p];
  }
  slope_ = -sum_(n, [&](std::int64_t j) { return g[j] * tmp_[j]; });
  return ok;
}

// The split coupling. With vertex scaling each loop edge's length has the same derivative in the
// u of its two ends, and the target's derivative is a loop-local symmetric part plus one rank-one
// term per loop (LoopTargetDerivative::split()): ∂K̄/∂u = D_loc + A Bᵀ (k loops, A and B n×k), so
//     J = H − D_loc − A Bᵀ.
// M = H − D_loc has the pattern of H (loop edges are edges) but need not be definite: on the
// near-constant direction its form is about the pinned vertex's cotangent weight minus 2π for the
// outer loop, and on a circle domain J itself is singular along the Möbius directions (the modes'
// bordering fixes them). Its negative directions live along the loops whose local part is
// subtracted (positive totals: a bump on an arc of such a loop costs less Dirichlet energy than
// the loop's part takes away), so the factorized matrix is F = M + Σ ρ_i e_i e_iᵀ with soft pins
// evenly along each of those loops (8 per loop, ρ_i = kSplitPinWeight × the diagonal entry; twice
// as many while F is not positive definite, up to kSplitMaxPins per loop), and J = F − U Vᵀ with
// U = [ρ_i e_i | A], V = [e_i | B] (m = pins + k columns). The Newton step — with the circle
// domain's modes, the bordered one: J δ − N Δ = g, Nₙᵀ δ = r (N the two modes, Nₙ the two
// normalization rows; see below) — is δ = Y + Z s + Z_N Δ with Y = F⁻¹g, Z = F⁻¹U, Z_N = F⁻¹N
// and (s, Δ) from the (m + 2)-square system
//     [I − VᵀZ   −VᵀZ_N] [s]   [VᵀY    ]
//     [Nₙᵀ Z     Nₙᵀ Z_N] [Δ] = [r − NₙᵀY],
// nonsingular exactly when the bordered Newton system is (whatever M's definiteness). Per Newton
// step: one factorization of F and m + 2 solves set it up; each right-hand side is one solve.
// The boundary system of the size of the boundary (a dense LU of P³, or GMRES at 10–16 solves per
// system, three systems per step on circle domains) is what this replaces; it is used again from
// the step where the split fails (no positive definite F, or a singular small system).
constexpr Index kSplitMaxPins = 64;
constexpr double kSplitPinWeight = 8;

// Subtracts D_loc from the assembled Hessian (after split() at the current lengths) and adds the
// pins; false (values untouched) when the split does not apply.
bool FlowSolver::split_values() {
  loop_edge_derivatives();
  if (!loop_dK_.split(t_, target_, s_.geometry, cur_.l, split_w_, split_a_, split_b_)) return false;
  const auto positions = static_cast<Index>(position_unknown_.size());
  const Index n = pattern_.num_unknowns;
  const std::span<double> values = solver_.values();
  double largest = 0;
  for (Index j = 0; j < n; ++j) largest = std::max(largest, std::abs(values[pattern_.col_ptr[j + 1] - 1]));
  if (!std::isfinite(largest)) return false;
  split_diag_.assign(static_cast<std::size_t>(positions), -1);
  split_next_.assign(static_cast<std::size_t>(positions), -1);
  // The value slot of (i, j), i ≤ j, in the upper triangle's compressed columns (rows sorted).
  auto slot = [&](Index i, Index j) -> std::int64_t {
    const auto first = pattern_.row.begin() + pattern_.col_ptr[j], last = pattern_.row.begin() + pattern_.col_ptr[j + 1];
    const auto it = std::lower_bound(first, last, i);
    return it != last && *it == i ? static_cast<std::int64_t>(it - pattern_.row.begin()) : -1;
  };
  for (Index loop = 0; loop < t_.num_boundary_loops(); ++loop) {
    const Index begin = t_.boundary_offsets[loop], end = t_.boundary_offsets[loop + 1];
    for (Index p = begin; p < end; ++p) {
      const Index next = p + 1 < end ? p + 1 : begin;
      const Index i = position_unknown_[p], j = position_unknown_[next];
      if (i != kInvalid) split_diag_[p] = slot(i, i);
      if (i != kInvalid && j != kInvalid) split_next_[p] = slot(std::min(i, j), std::max(i, j));
      if ((i != kInvalid && split_diag_[p] < 0) || (i != kInvalid && j != kInvalid && split_next_[p] < 0)) return false;
    }
  }
  for (Index loop = 0; loop < t_.num_boundary_loops(); ++loop) {
    const Index begin = t_.boundary_offsets[loop], end = t_.boundary_offsets[loop + 1];
    for (Index p = begin; p < end; ++p) {
      const Index next = p + 1 < end ? p + 1 : begin;
      const double w = split_w_[p];
      if (split_diag_[p] >= 0) values[split_diag_[p]] -= w;
      if (split_diag_[next] >= 0) values[split_diag_[next]] -= w;
      if (split_next_[p] >= 0) values[split_next_[p]] -= w;
    }
  }
  // The pins: split_pin_count_ evenly along each loop whose local part is subtracted (positive
  // total, or the target proportional to length with T > 0), where M's negative directions live.
  split_pins_.clear();
  split_rho_.clear();
  for (Index loop = 0; loop < t_.num_boundary_loops(); ++loop) {
    if (!(target_.loop_total[loop] > 0)) continue;
    std::vector<Index> unknowns;
    for (Index p = t_.boundary_offsets[loop]; p < t_.boundary_offsets[loop + 1]; ++p)
      if (position_unknown_[p] != kInvalid) unknowns.push_back(position_unknown_[p]);
    const auto count = static_cast<Index>(unknowns.size());
    const Index pins = std::min(split_pin_count_, count);
    for (Index i = 0; i < pins; ++i) {
      const Index j = unknowns[static_cast<std::size_t>((static_cast<std::int64_t>(i) * count) / pins)];
      if (std::find(split_pins_.begin(), split_pins_.end(), j) != split_pins_.end()) continue;
      double& diagonal = values[pattern_.col_ptr[j + 1] - 1];
      const double d = std::abs(diagonal);
      split_pins_.push_back(j);
      split_rho_.push_back(kSplitPinWeight * (std::isfinite(d) && d > 0 ? d : std::max(largest, 1.0)));
      diagonal += split_rho_.back();
    }
  }
  return true;
}

// x_ = F⁻¹g on entry (the factor holds F, or F + μI); on return the Newton step (above), with
// modes_.d_alpha, d_beta on a circle domain, and slope_ = d/dt ½‖g‖² = −gᵀ(g − μ x_). False when
// a solve fails, the small system is singular or a value is not finite.
bool FlowSolver::split_direction(std::span<const double> g) {
  const Index n = pattern_.num_unknowns;
  const auto N = static_cast<std::size_t>(n);
  const Index pins = static_cast<Index>(split_pins_.size()), k = t_.num_boundary_loops();
  const Index m = pins + k, modes = modes_.active ? 2 : 0, size = m + modes;
  const auto S = static_cast<std::size_t>(size);
  // Vᵀ x, column c (a pin's value, or Σ b_p x_p over a loop's unknowns), and Nₙᵀ x, row r.
  auto v_dot = [&](Index c, const double* x) {
    if (c < pins) return x[split_pins_[c]];
    double sum = 0;
    for (Index p = t_.boundary_offsets[c - pins]; p < t_.boundary_offsets[c - pins + 1]; ++p)
      if (position_unknown_[p] != kInvalid) sum += split_b_[p] * x[position_unknown_[p]];
    return sum;
  };
  auto n_dot = [&](Index r, const double* x) {
    const std::vector<double>& row = r == 0 ? modes_.norm_c : modes_.norm_s;
    double sum = 0;
    for (std::size_t i = 0; i < modes_.vertices.size(); ++i) {
      const Index j = pattern_.vertex_unknown[modes_.vertices[i]];
      if (j != kInvalid) sum += row[i] * x[j];
    }
    return sum;
  };
  if (!split_ready_) {
    std::vector<double> full(modes_.active ? static_cast<std::size_t>(t_.num_vertices) : 0);
    split_z_.assign(S * N, 0.0);
    split_c_.assign(S * S, 0.0);
    for (Index c = 0; c < size; ++c) {
      // Column c of U (pins, loops), then the modes N (with the gauge mean removed, as the
      // right-hand sides are).
      std::fill(tmp_.begin(), tmp_.end(), 0.0);
      if (c < pins) {
        tmp_[split_pins_[c]] = split_rho_[c];
      } else if (c < m) {
        for (Index p = t_.boundary_offsets[c - pins]; p < t_.boundary_offsets[c - pins + 1]; ++p)
          if (position_unknown_[p] != kInvalid) tmp_[position_unknown_[p]] += split_a_[p];
      } else {
        modes_.scatter(c == m ? 0 : 1, full);
        remove_gauge_mean(full);
        for (Index j = 0; j < n; ++j) tmp_[j] = full[pattern_.unknown_vertex[j]];
      }
      const std::span<double> z(split_z_.data() + static_cast<std::size_t>(c) * N, N);
      if (!solver_.solve(tmp_, z)) return false;
      for (Index r = 0; r < size; ++r) {
        double& entry = split_c_[static_cast<std::size_t>(r) * S + static_cast<std::size_t>(c)];
        if (r < m) entry = (c < m ? (r == c ? 1.0 : 0.0) - v_dot(r, z.data()) : -v_dot(r, z.data()));
        else entry = n_dot(r - m, z.data());
      }
    }
    if (!lu_factor(split_c_.data(), S, split_pivot_, 1e-13)) return false;
    split_ready_ = true;
  }
  // The small right-hand side: VᵀY, then r − NₙᵀY with r = n·(u at the start) − n·u.
  split_small_.assign(S, 0.0);
  for (Index r = 0; r < m; ++r) split_small_[static_cast<std::size_t>(r)] = v_dot(r, x_.data());
  for (Index r = 0; r < modes; ++r) {
    double nu = 0;
    for (std::size_t i = 0; i < modes_.vertices.size(); ++i)
      nu += (r == 0 ? modes_.norm_c[i] : modes_.norm_s[i]) * u_[modes_.vertices[i]];
    split_small_[static_cast<std::size_t>(m + r)] = ((r == 0 ? modes_.norm_c0 : modes_.norm_s0) - nu) - n_dot(r, x_.data());
  }
  double* w = split_small_.data();
  lu_solve(split_c_.data(), S, split_pivot_, w);
  for (std::size_t r = 0; r < S; ++r)
    if (!std::isfinite(w[r])) return false;
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (Index j = 0; j < n; ++j) {
    double add = 0;
    for (std::size_t r = 0; r < S; ++r) add += split_z_[r * N + static_cast<std::size_t>(j)] * w[r];
    x_[j] += add;
  }
  if (modes > 0) {
    modes_.d_alpha = w[m];
    modes_.d_beta = w[m + 1];
  }
  slope_ = -sum_(n, [&](std::int64_t j) { return g[j] * (g[j] - shift_ * x_[j]); });
  return std::isfinite(slope_);
}

// ---------------------------------------------------------------------------------------------
// Circle domains. The conformal maps of a genus-0 surface onto a circle domain form a family: the
// Möbius transformations of the outer disk (three parameters, one of them a rotation that leaves
// u alone). In E the discrete target, each loop an inscribed polygon, is invariant under them
// exactly (a Möbius map takes circles to circles and multiplies every length l_ij by
// √(|f'(z_i)| |f'(z_j)|), a vertex scaling), so ∂K/∂u − ∂K̄/∂u is singular along two directions;
// the target proportional to length (H, S) is invariant only up to the discretization, and its
// exact solution, decided by discretization effects, is on fine meshes a strongly distorted member
// of the family reached only after hundreds of damped Newton steps. Either way the family is
// normalized explicitly: along the outer loop, with θ_p the angular
// position of vertex p (2π × arc length from the loop start / loop length, at the start), two
// normalization rows n_c = w_p (cos θ_p − C), n_s = w_p (sin θ_p − S) (w the half lengths of the
// boundary edges at p at the start, C, S their weighted means) hold n·u at its start, and two
// zero-sum modes a_p = cos θ_p − c̄, b_p = sin θ_p − s̄ enter the outer loop's target as
// K̄_p + α a_p + β b_p, α and β two extra unknowns. Newton solves the bordered system
//     J δ − a Δα − b Δβ = g,   n·δ = 0,
// as δ = y + Δα z_a + Δβ z_b with y = J⁻¹g, z = J⁻¹a, J⁻¹b (three solves of the coupled system) and
// a 2×2 system for (Δα, Δβ). The loop total is unchanged (the modes sum to zero); the result's
// K_target contains the modes, and the notes give their size relative to the proportional target.


// Turns x_ = J⁻¹ g into the step of the bordered system (see CircleDomainModes) and sets
// modes_.d_alpha, modes_.d_beta and slope_. False (x_ unchanged, no mode update) when a solve fails or the
// 2×2 system is singular.
bool FlowSolver::moebius_direction() {
  const Index n = pattern_.num_unknowns;
  // Scratch for this step only (the solve's memory peaks later, in the line search).
  std::vector<double> y(x_), z_a(static_cast<std::size_t>(n)), z_b(static_cast<std::size_t>(n)),
      rhs(static_cast<std::size_t>(n)), full(static_cast<std::size_t>(t_.num_vertices));
  for (int k = 0; k < 2; ++k) {
    std::vector<double>& z = k == 0 ? z_a : z_b;
    modes_.scatter(k, full);
    remove_gauge_mean(full);
    for (Index j = 0; j < n; ++j) rhs[j] = full[pattern_.unknown_vertex[j]];
    if (!solver_.solve(rhs, x_) || !coupled_direction(rhs)) {
      std::copy(y.begin(), y.end(), x_.begin());
      return false;
    }
    std::copy(x_.begin(), x_.end(), z.begin());
  }
  // n·δ = n·u_start − n·u (zero up to rounding drift): the vertices' steps are x_ on the unknowns
  // and 0 elsewhere, and the mean removal that follows does not change n·δ (n sums to zero). The
  // rows vanish off the loop: the sums run over its unknowns, in the order of the unknowns.
  std::vector<std::pair<Index, std::size_t>> on_loop;  // (unknown, position on the loop)
  for (std::size_t i = 0; i < modes_.vertices.size(); ++i) {
    const Index j = pattern_.vertex_unknown[modes_.vertices[i]];
    if (j != kInvalid) on_loop.emplace_back(j, i);
  }
  std::sort(on_loop.begin(), on_loop.end());
  auto dot = [&](const std::vector<double>& row, const std::vector<double>& x) {
    double sum = 0;
    for (const auto& [j, i] : on_loop) sum += row[i] * x[j];
    return sum;
  };
  double nu_c = 0, nu_s = 0;
  for (std::size_t i = 0; i < modes_.vertices.size(); ++i) {
    nu_c += modes_.norm_c[i] * u_[modes_.vertices[i]];
    nu_s += modes_.norm_s[i] * u_[modes_.vertices[i]];
  }
  const double r_c = (modes_.norm_c0 - nu_c) - dot(modes_.norm_c, y), r_s = (modes_.norm_s0 - nu_s) - dot(modes_.norm_s, y);
  const double m00 = dot(modes_.norm_c, z_a), m01 = dot(modes_.norm_c, z_b), m10 = dot(modes_.norm_s, z_a), m11 = dot(modes_.norm_s, z_b);
  const double det = m00 * m11 - m01 * m10;
  const double scale = std::max({std::abs(m00 * m11), std::abs(m01 * m10), 1e-300});
  if (!std::isfinite(det) || std::abs(det) <= 1e-12 * scale) {
    std::copy(y.begin(), y.end(), x_.begin());
    return false;
  }
  modes_.d_alpha = (r_c * m11 - m01 * r_s) / det;
  modes_.d_beta = (m00 * r_s - m10 * r_c) / det;
  for (Index j = 0; j < n; ++j) x_[j] = y[j] + modes_.d_alpha * z_a[j] + modes_.d_beta * z_b[j];
  // d/dt ½‖g‖² for the exact bordered step: −‖g‖² (J δ − a Δα − b Δβ = g).
  slope_ = -sum_(n, [&](std::int64_t j) { return rhs_[j] * rhs_[j]; });
  return std::isfinite(modes_.d_alpha) && std::isfinite(modes_.d_beta);
}

// Solves G α = coefficient_ in place with the Cholesky factor of the Gram matrix in gram_.
bool FlowSolver::gram_solve() {
  const std::size_t k = vc_.spherical_pins.size();
  for (std::size_t a = 0; a < k; ++a) {
    double x = coefficient_[a];
    for (std::size_t m = 0; m < a; ++m) x -= gram_[a * k + m] * coefficient_[m];
    coefficient_[a] = x / gram_[a * k + a];
  }
  for (std::size_t a = k; a-- > 0;) {
    double x = coefficient_[a];
    for (std::size_t m = a + 1; m < k; ++m) x -= gram_[m * k + a] * coefficient_[m];
    coefficient_[a] = x / gram_[a * k + a];
  }
  return std::all_of(coefficient_.begin(), coefficient_.end(), [](double x) { return std::isfinite(x); });
}

// Newton direction into step_ (with the fallbacks of the design notes); sets slope_.
// The Newton matrix in the solver's values factorized: unshifted, else with growing diagonal shifts
// (shift_); the state that depends on the factor reset. False when the direction must be computed
// again (the split's pinned matrix was not positive definite: more pins, or the boundary system).
bool FlowSolver::factorize_newton_matrix(Clock::time_point& mark, detail::FactorOutcome& outcome) {
  const Index n = pattern_.num_unknowns;
  const std::span<const double> values = solver_.values();
  double max_diagonal = 0;
  for (Index j = 0; j < n; ++j)
    max_diagonal = std::max(max_diagonal, std::abs(values[pattern_.col_ptr[j + 1] - 1]));
  if (!std::isfinite(max_diagonal) || max_diagonal <= 0) max_diagonal = 1;
  shift_ = 0;
  factor_current_ = false;
  outcome = solver_.factorize(0);
  if (split_applied_ && outcome != detail::FactorOutcome::Ok && outcome != detail::FactorOutcome::OutOfMemory) {
    // The pinned split matrix is not positive definite: twice the pins, or the boundary system.
    iter_.factorization += lap(mark);
    if (split_pin_count_ < kSplitMaxPins) {
      split_pin_count_ *= 2;
    } else {
      split_ = false;
      ++split_fallbacks_;
    }
    return false;
  }
  if (outcome == detail::FactorOutcome::NotPositiveDefinite || outcome == detail::FactorOutcome::Failed) {
    double mu = kFirstShift * max_diagonal;
    for (int k = 0; k < kMaxShifts; ++k, mu *= kShiftGrowth) {
      outcome = solver_.factorize(mu);
      if (outcome == detail::FactorOutcome::Ok) {
        shift_ = mu;
        ++shifted_;
        largest_shift_ = std::max(largest_shift_, mu / max_diagonal);
        break;
      }
      if (outcome == detail::FactorOutcome::OutOfMemory) break;
    }
  }
  iter_.factorization += lap(mark);
  factor_current_ = outcome == detail::FactorOutcome::Ok && shift_ == 0;
  boundary_factored_ = false;
  split_ready_ = false;
  // GMRES needed more full solves in the last step than the direct solve's estimated work: the
  // direct solve from now on (the estimate of GMRES's iterations in setup_boundary_direct() is a
  // guess; this is the count).
  if (coupled_ && !boundary_direct_ && direct_flops_ > 0 && operator_solves_ * solve_flops_ > direct_flops_ &&
      static_cast<Index>(position_unknown_.size()) <= kDirectBoundaryFallback) {
    prefer_direct_ = true;
    switched_direct_at_ = iteration_;
    switched_after_solves_ = operator_solves_;
    setup_boundary_direct(true);
  }
  operator_solves_ = 0;
  return true;
}

bool FlowSolver::compute_direction() {
  const Index nv = t_.num_vertices;
  const Index n = pattern_.num_unknowns;

  // A chord step (chord_step()) solves with the last factor as it is: no kernels, no assembly.
  // Otherwise the trial and quadrature states of the last line search are not needed through the
  // factorization, where the solve peaks in memory (2 × 40 bytes per face): the next line search
  // allocates them again (evaluate_at()).
  if (!chord_) {
    trial_ = MetricState{};
    quad_ = MetricState{};
  }
  if (!chord_ && pattern_stale_ && !refresh_pattern()) return false;  // timed as analysis
  Clock::time_point mark = Clock::now();
  const std::span<double> values = solver_.values();
  if (!chord_) {
    if (!blocks_at_u_) angle_derivative_blocks(t_, s_, u_, cur_.l, cur_.theta, block_storage());
    blocks_at_u_ = true;
    if (!resolution_.current) update_resolution();
    iter_.derivatives += lap(mark);
    assemble_hessian(t_, pattern_, blocks_, values);
    split_applied_ = coupled_ && split_ && split_values();
  }
  // The right-hand side K̄ − K. On an E gauge component its mean is removed: it is zero in exact
  // arithmetic (Gauss–Bonnet), but the computed curvatures sum to 2πχ only up to rounding, and
  // that remainder must not be pushed onto the pinned vertex.
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
  for (Index v = 0; v < nv; ++v) grad_[v] = vc_.condition[v] ? K_target_[v] - cur_.K[v] : 0.0;
  remove_gauge_mean(grad_);
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (Index j = 0; j < n; ++j) rhs_[j] = grad_[pattern_.unknown_vertex[j]];

  iter_.assembly += lap(mark);
  detail::FactorOutcome outcome = detail::FactorOutcome::Ok;
  if (!chord_ && !factorize_newton_matrix(mark, outcome)) return compute_direction();
  if (outcome == detail::FactorOutcome::OutOfMemory) {
    fail(Status::OutOfMemory,
         "out of memory in the sparse Cholesky factorization at Newton step " + std::to_string(iteration_));
    return false;
  }

  bool ok = outcome == detail::FactorOutcome::Ok;
  if (ok && residual_merit_) {
    // Solve with the Möbius-projected right-hand side when the sphere gauge is active; use the
    // plain one when the projection is unavailable or does not give a descent direction.
    // d/dt ½‖g‖² = −gᵀ H δ with H δ = b − μ δ for the right-hand side b that was solved.
    auto merit_slope = [&](const std::vector<double>& b) {
      const double gb = sum_(n, [&](std::int64_t j) { return rhs_[j] * b[j]; });
      const double gx = sum_(n, [&](std::int64_t j) { return rhs_[j] * x_[j]; });
      return -(gb - shift_ * gx);
    };
    bool done = false;
    if (vc_.spherical_gauge && project_moebius() && solver_.solve(rhs_projected_, x_)) {
      slope_ = merit_slope(rhs_projected_);
      done = std::isfinite(slope_) && slope_ < 0;
      if (!done) ++projection_skipped_;
    }
    if (!done) {
      ok = solver_.solve(rhs_, x_);
      if (ok) slope_ = merit_slope(rhs_);
    }
  } else if (ok) {
    ok = solver_.solve(rhs_, x_);
  }
  // Circle / LoopTotals: correct the step for the dependence of K̄ on the lengths.
  modes_.d_alpha = modes_.d_beta = 0;
  if (ok && coupled_) {
    bool coupled = true;
    if (split_applied_) {
      if (!split_direction(rhs_)) {
        // The split failed (a singular rank-k system): the boundary system from here on.
        split_ = false;
        ++split_fallbacks_;
        return compute_direction();
      }
    } else if (!coupled_direction(rhs_)) {
      ++gmres_failures_;
      coupled = false;
    }
    if (coupled && !split_applied_ && modes_.active && !moebius_direction()) ++modes_.failures;
  }
  if (ok) {
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
    for (Index v = 0; v < nv; ++v) step_[v] = 0;
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (Index j = 0; j < n; ++j) step_[pattern_.unknown_vertex[j]] = x_[j];
    remove_gauge_mean(step_);  // a constant does not change J·δ (E), nor ∂E/∂δ
    if (!residual_merit_) slope_ = -sum_(nv, [&](std::int64_t v) { return grad_[v] * step_[v]; });
    ok = std::isfinite(slope_) && slope_ < 0;
  }
  if (ok) return true;

  if (chord_) return false;  // not kept: the caller takes a full Newton step instead
  // Fallback: the Ricci flow direction K̄ − K (E, H: the negative gradient of E), or with a
  // residual merit the negative gradient H(K̄ − K) of ½‖K̄ − K‖² (K̄ held).
  ++gradient_fallbacks_;
  factor_current_ = false;
  shift_ = 0;
  if (split_applied_) {  // the values hold the split matrix: the Hessian again
    assemble_hessian(t_, pattern_, blocks_, values);
    split_applied_ = false;
  }
  if (residual_merit_) {
    detail::multiply_hessian(pattern_, values, rhs_, tmp_);
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
    for (Index v = 0; v < nv; ++v) step_[v] = 0;
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
    for (Index j = 0; j < n; ++j) step_[pattern_.unknown_vertex[j]] = tmp_[j];
    slope_ = -sum_(n, [&](std::int64_t j) { return tmp_[j] * tmp_[j]; });
    if (coupled_) {
      // d/dt ½‖g‖² = −gᵀ(H − ∂K̄/∂u)·δ for δ = H g.
      detail::multiply_hessian(pattern_, values, tmp_, x_);
      target_derivative(step_, position_dK_);
      const Index positions = static_cast<Index>(position_unknown_.size());
      for (Index q = 0; q < positions; ++q)
        if (position_unknown_[q] != kInvalid) x_[position_unknown_[q]] -= position_dK_[q];
      slope_ = -sum_(n, [&](std::int64_t j) { return rhs_[j] * x_[j]; });
    }
  } else {
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
    for (Index v = 0; v < nv; ++v) step_[v] = grad_[v];
    slope_ = -sum_(nv, [&](std::int64_t v) { return grad_[v] * grad_[v]; });
  }
  if (!(std::isfinite(slope_) && slope_ < 0)) {
    fail(Status::LineSearchFailed, "no descent direction at Newton step " + std::to_string(iteration_) +
                                       " (the gradient vanishes on the free vertices)");
    return false;
  }
  return true;
}

bool FlowSolver::line_search() {
  if (smoothing_) {
    // A smoothing step only where it still changes u by more than kSmoothAbove, and by at most
    // kSmoothGain of the last one (beyond that it only moves u by the curvatures' rounding).
    const double size = step_size();
    if (!(size > kSmoothAbove) || !(smoothed_ == 0 || size <= kSmoothGain * smooth_last_)) return false;
    if (smoothed_ == 0) smooth_first_ = size;
    smooth_last_ = size;
  }
  const Index nv = t_.num_vertices;
  const Index n = pattern_.num_unknowns;
  const bool spherical = residual_merit_;
  // Rounding levels: each computed K_i carries an error of a few ulps of its angle sum, so
  // Σ (K − K̄)·δ (energy slope) is resolved only to about ε·Σ|δ_i|·(4π + |K̄_i|), and ½‖K̄ − K‖²
  // (the residual merit) to about ε·Σ|K̄_i − K_i|·(4π + |K̄_i|).
  const double merit0 = spherical ? 0.5 * sum_(n, [&](std::int64_t j) { return rhs_[j] * rhs_[j]; }) : 0;
  // Where a vertex resolves its curvature less well (update_resolution()), its resolution.
  const bool resolution = resolution_.active;
  const double noise = sum_(nv, [&](std::int64_t v) {
    if (!vc_.condition[v]) return 0.0;
    double scale = 64 * kEps * (4 * kPi + std::abs(K_target_[v]));
    if (resolution) scale = std::max(scale, resolution_.values[v]);
    return (spherical ? std::abs(K_target_[v] - cur_.K[v]) : std::abs(step_[v])) * scale;
  });
  // Below the rounding level the merit function cannot rank trial points; a step is then taken
  // if it lowers the maximal curvature error, and only a few halvings are tried.
  const bool rounding_level = spherical ? merit0 <= noise : std::abs(slope_) <= noise;
  const double min_step = chord_ ? 1 : rounding_level ? 1.0 / 16 : kMinStep;
  // E and H: the energy slope f(s) = (K(u + sδ) − K̄)·δ at s = 0 and its derivative δᵀ(∂K/∂u)δ
  // there, for the one-evaluation estimate of the energy change (see below).
  auto energy_slope = [&](const std::vector<double>& K) {
    return sum_(nv, [&](std::int64_t v) { return vc_.condition[v] ? (K[v] - K_target_[v]) * step_[v] : 0.0; });
  };
  const double f0 = spherical ? 0.0 : energy_slope(cur_.K);
  search_kernels_ = 0;
  if (!spherical && blocks_.empty()) {  // given up by energy_difference(), and a chord step needs them
    const Clock::time_point kernel_start = Clock::now();
    angle_derivative_blocks(t_, s_, u_, cur_.l, cur_.theta, block_storage());
    blocks_at_u_ = true;
    search_kernels_ += std::chrono::duration<double>(Clock::now() - kernel_start).count();
  }
  const double df0 = spherical ? 0.0 : directional_derivative(t_);
  Validity last = Validity::Ok;
  for (double t = 1; t >= min_step; t *= 0.5) {
    blocks_at_trial_ = false;
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
    for (Index v = 0; v < nv; ++v) u_trial_[v] = u_[v] + t * step_[v];
    undo_flips_after(0);  // the last trial's
    last = evaluate_at(u_trial_, trial_, trial_flipped_);
    if (last != Validity::Ok) continue;
    // The residual merit of a coupled target uses the target of the trial lengths.
    if (coupled_) {
      effective_target(t_, target_, trial_.l, K_target_trial_, s_.geometry);
      if (modes_.active) {
        modes_.alpha_trial = modes_.alpha + t * modes_.d_alpha;
        modes_.beta_trial = modes_.beta + t * modes_.d_beta;
        modes_.add(modes_.alpha_trial, modes_.beta_trial, K_target_trial_);
      }
    }
    const std::vector<double>& trial_target = coupled_ ? K_target_trial_ : K_target_;
    const double trial_error = max_error(trial_.K, trial_target, vc_.condition);
    // Ranked by the judged error (the plain one unless some vertex resolves less than the tolerance).
    const double trial_judged = resolution ? judged_error(trial_.K, trial_target) : trial_error;
    if (smoothing_) {
      // Below the rounding level of the energy and the max error: kept when the max error stays there.
      if (std::isfinite(trial_error) && trial_judged <= std::max(judged_, curvature_rounding())) {
        accept(t, 0);
        return true;
      }
      continue;
    }
    if (!std::isfinite(trial_error) || ((polishing_ || chord_) && !(trial_judged < judged_)) ||
        (chord_ && !(trial_judged <= chord_bound_)))
      continue;
    double dE = 0;
    bool accepted = false;
    if (spherical) {
      const double merit = 0.5 * sum_(n, [&](std::int64_t j) {
                             const Index v = pattern_.unknown_vertex[j];
                             const double d = trial_target[v] - trial_.K[v];
                             return d * d;
                           });
      accepted = !rounding_level && merit <= merit0 + kArmijo * t * slope_;
      if (!accepted && std::abs(merit - merit0) <= noise && trial_judged < judged_) {
        accepted = true;
        if (!chord_) ++noise_accepts_;  // chord steps are ranked by the error by design
      }
      // The energy is recorded only: a bad quadrature node does not veto the step.
      if (accepted && !energy_difference(t, dE)) dE = 0;
    } else {
      // First without interior nodes. f'(s) = δᵀ(∂K/∂u)δ comes from the per-face derivative blocks,
      // and the blocks of the trial point are those the next Newton step needs (computed here, they
      // are not computed again when the trial is accepted). Cubic Hermite quadrature
      //     H = t (f(0) + f(t)) / 2 + t² (f'(0) − f'(t)) / 12
      // is compared with the rule exact for quadratic f from f(0), f'(0), f(t),
      //     Q = t (2 f(0) + f(t)) / 3 + t² f'(0) / 6;
      // the step is accepted on H when they agree to kEstimateSpread and even H + |H − Q| passes
      // the test (Newton steps with f close to a low-degree polynomial over the step, i.e. all but
      // far from the solution, where degenerate triangles make f only piecewise smooth). A
      // trial that meets the tolerance ends the solve, so its blocks are not needed: Q and the
      // distance of f from linear, t |f(t) − f(0) − t f'(0)| / 6 = |Q − trapezoid|, decide there.
      // Otherwise the Gauss–Lobatto quadrature below decides (two more evaluations).
      const double f1 = energy_slope(trial_.K);
      const double quadratic = t * (2 * f0 + f1) / 3 + t * t * df0 / 6;
      double estimate = quadratic, spread = t * std::abs(f1 - f0 - t * df0) / 6;
      if (trial_error >= tolerance_) {
        const Clock::time_point kernel_start = Clock::now();
        angle_derivative_blocks(t_, s_, u_trial_, trial_.l, trial_.theta, block_storage());
        blocks_at_u_ = false;
        blocks_at_trial_ = true;
        const double df1 = directional_derivative(t_);
        estimate = t * (f0 + f1) / 2 + t * t * (df0 - df1) / 12;
        spread = std::abs(estimate - quadratic);
        search_kernels_ += std::chrono::duration<double>(Clock::now() - kernel_start).count();
      }
      if (std::isfinite(estimate) && spread <= kEstimateSpread * std::abs(estimate)) {
        if (!rounding_level && estimate + spread <= kArmijo * t * slope_) {
          accepted = true;
        } else if (std::abs(estimate) + spread <= t * noise && trial_judged < judged_) {
          accepted = true;
          if (!chord_) ++noise_accepts_;  // chord steps are ranked by the error by design
        }
      }
      if (accepted) {
        dE = estimate;
        if (t < 1) ++damped_;
        accept(t, dE);
        return true;
      }
      if (!energy_difference(t, dE)) {
        last = Validity::BadLength;
        continue;
      }
      accepted = !rounding_level && dE <= kArmijo * t * slope_;
      if (!accepted && std::abs(dE) <= t * noise && trial_judged < judged_) {
        accepted = true;
        if (!chord_) ++noise_accepts_;  // chord steps are ranked by the error by design
      }
    }
    if (!accepted) continue;
    if (t < 1) ++damped_;
    accept(t, dE);
    return true;
  }
  undo_flips_after(0);  // back to the current triangulation
  if (rounding_level) {
    fail(Status::LineSearchFailed, "Newton step " + std::to_string(iteration_) +
                                       " stalled at max |K̄ − K| = " + format_double("%.3g", error_) +
                                       ", the rounding level of the curvatures of this mesh: the tolerance " +
                                       format_double("%.3g", tolerance_) +
                                       " is below what double precision resolves here");
    return false;
  }
  fail(Status::LineSearchFailed,
       "the line search found no acceptable step at Newton step " + std::to_string(iteration_) +
           (last != Validity::Ok ? " (the last trial was rejected: " + validity_text(last) + ")"
                                 : " (the merit function did not decrease enough)"));
  return false;
}

void FlowSolver::accept(double step_length, double dE) {
  const double judged_before = judged_;
  u_.swap(u_trial_);
  cur_.swap(trial_);
  if (trial_flipped_) {
    // The trial's Delaunay triangulation (in place) becomes the current one.
    journal_.clear();
    trial_flipped_ = false;
    pattern_stale_ = true;
  }
  effective_target(t_, target_, cur_.l, K_target_, s_.geometry);
  if (modes_.active) {
    modes_.alpha = modes_.alpha_trial;
    modes_.beta = modes_.beta_trial;
    modes_.add(modes_.alpha, modes_.beta, K_target_);
    double relative = 0;
    for (std::size_t i = 0; i < modes_.vertices.size(); ++i) {
      const Index v = modes_.vertices[i];
      const double base = K_target_[v] - modes_.alpha * modes_.a[i] - modes_.beta * modes_.b[i];
      if (base != 0) relative = std::max(relative, std::abs(modes_.alpha * modes_.a[i] + modes_.beta * modes_.b[i]) / std::abs(base));
    }
    modes_.largest = relative;
  }
  error_ = max_error(cur_.K, K_target_, vc_.condition);
  resolution_.current = false;
  judged_ = resolution_.active ? judged_error(cur_.K, K_target_) : error_;
  if (!chord_) {
    const bool full = step_length == 1 && judged_before > 0;
    newton_gain_ = full ? judged_ / judged_before : 1;
    newton_constant_ = full ? judged_ / (judged_before * judged_before) : 0;
  }
  energy_ += dE;
  IterationRecord record;
  record.iteration = iteration_;
  record.max_error = error_;
  record.energy = energy_;
  record.step = step_length;
  record.chord = chord_;
  record.seconds = seconds();
  // The trial's derivative blocks are the next step's kernels (see line_search()).
  blocks_at_u_ = blocks_at_trial_;
  blocks_at_trial_ = false;
  iter_.derivatives += search_kernels_;
  iter_.line_search = std::chrono::duration<double>(Clock::now() - search_start_).count() - search_kernels_;
  search_kernels_ = 0;
  record.timings = iter_;
  add_timings(iter_);
  iteration_recorded_ = true;
  r_.history.push_back(record);
  if (options_.on_iteration) options_.on_iteration(record);
}

bool FlowSolver::newton_step() {
  iter_ = FlowTimings{};
  iteration_recorded_ = false;
  Clock::time_point mark = Clock::now();
  const bool direction = compute_direction();
  // Whatever compute_direction() spent outside the kernels, assembly and factorization: solves.
  iter_.solve = std::max(0.0, lap(mark) - iter_.derivatives - iter_.assembly - iter_.factorization);
  search_start_ = mark;
  const bool ok = direction && line_search();
  if (!iteration_recorded_) {
    iter_.line_search = lap(mark);
    add_timings(iter_);
  }
  if (!chord_) chords_in_row_ = 0;
  return ok;
}

// One more Newton step after the tolerance is met (FlowOptions::polish_steps), with the solve's
// analysis: kept only when it lowers the maximal error (the line search rejects every other trial).
// False when no step is left, the error is at the rounding level, or the step was not kept; u is
// then unchanged.
// Polishing stops once max |K̄ − K| is within this many ulps of the largest angle sum: a
// curvature evaluated from a vertex's angles carries about that much rounding, so a step there
// buys digits no layout can use (a residual of 1e-14 closes a layout to far below its 1e-9).
constexpr double kPolishUlps = 16;

double FlowSolver::curvature_rounding() const {
  double largest_target = 0;
  for (Index v = 0; v < t_.num_vertices; ++v)
    if (vc_.condition[v]) largest_target = std::max(largest_target, std::abs(K_target_[v]));
  return kPolishUlps * kEps * (4 * kPi + largest_target);
}

void FlowSolver::update_resolution() {
  resolution_.update(t_, blocks_, u_, vc_.condition, tolerance_);
  judged_ = judged_error(cur_.K, K_target_);
}

// The resolution at u_ itself (the derivative blocks of u_ are computed when they are not at hand;
// the next Newton step uses them).
void FlowSolver::resolution_at_u() {
  if (resolution_.current) return;
  if (!blocks_at_u_) {
    const Clock::time_point mark = Clock::now();
    angle_derivative_blocks(t_, s_, u_, cur_.l, cur_.theta, block_storage());
    blocks_at_u_ = true;
    r_.timings.derivatives += std::chrono::duration<double>(Clock::now() - mark).count();
  }
  update_resolution();
}

// A tolerance below what the curvatures resolve (a few ulps of the angle sums) is raised to that
// level with a note: no step could be ranked below it.
void FlowSolver::set_tolerance() {
  tolerance_ = options_.tolerance;
  if (const double floor = curvature_rounding(); tolerance_ < floor) {
    tolerance_ = floor;
    r_.notes.push_back("the tolerance " + format_double("%.3g", options_.tolerance) +
                       " is below the rounding level of the curvatures (" + format_double("%.3g", floor) +
                       ", 16 ulps of the largest angle sum); solved to that level");
  }
}

void FlowSolver::note_resolution() {
  r_.notes.push_back(std::to_string(resolution_.vertices) + " vertices resolve their curvature only to " +
                     format_double("%.3g", resolution_.largest) +
                     " (the ends of edges far shorter than their neighbours: their angles follow from the double "
                     "lengths only to about ε·l/s); converged with each of them within its resolution and every other "
                     "vertex within the tolerance " + format_double("%.3g", tolerance_) + ": max |K̄ − K| = " +
                     format_double("%.3g", error_));
}

double FlowSolver::judged_error(std::span<const double> K, std::span<const double> target) const {
  return resolution_.judged_error(K, target, vc_.condition, tolerance_);
}

// A chord step: the last Newton matrix, factorized one step back, for the current residual K̄ − K:
// a solve and one evaluation instead of kernels, assembly and a factorization. Only the full step
// (t = 1) is tried, kept when it lowers the judged error to `bound` or below; only where that
// factor is of the current triangulation and unshifted, with no boundary system to update. False
// (state unchanged) when not tried or not kept.
//
// When (chord_pays()): a full Newton step that took the judged error from e′ to e (gain γ = e/e′,
// quadratic constant M = e/e′²) leaves a factor with which chord steps converge linearly at the
// rate ‖H⁻¹(H_last − H)‖ = O(‖Δu‖ of that step) = O(γ); measured, about kChordRate γ (kitten-5k
// 1.3e-6 → 8.9e-10 after γ = 3.4e-4, camelhead 4.4e-3 → 3.0e-4 after γ = 0.033). The next Newton
// step would reach M e² (or the rounding level); chord steps are taken while the ones needed to
// get there cost less than that Newton step, at most kMaxChords in a row, and each must gain what
// the rate promises within kChordMargin and lower it. Where Newton overshoots the tolerance by
// squaring the error, a run of chord steps goes on to 4 ulps of the largest angle sum, or until
// one no longer lowers the error (not only to the tolerance), so the result has the digits the
// Newton step would have given. Typically the last step of a solve becomes a chord step, and on
// large meshes, where the factorization dominates, one or two before it.
// Costs are counted, not timed (the steps taken must not depend on the machine's load), in flops
// of the factor (CHOLMOD's count), its triangular solves and per face: one evaluation of lengths,
// angles and curvature, and one of the derivative kernels and assembly, each worth about
// kFaceFlops at the factorization's rate (measured with Debian's ATLAS on 2 cores: 150–200 ns per
// face, 1–3 GFlop/s). The spherical gauge adds a solve per pin to every step.
constexpr double kChordRate = 2;
constexpr double kChordMargin = 4;
constexpr int kMaxChords = 4;
constexpr double kChordFloor = 0.25;  // × curvature_rounding() (16 ulps): where a run of chord steps ends
constexpr double kFaceFlops = 500;

bool FlowSolver::chord_possible() const {
  return options_.chord_steps && factor_current_ && !pattern_stale_ && (!coupled_ || split_applied_);
}

bool FlowSolver::chord_pays() {
  if (!chord_possible() || chords_in_row_ >= kMaxChords) return false;
  const double rate = kChordRate * newton_gain_;
  if (!(rate < 0.5) || !(judged_ > 0)) return false;
  // The level the Newton step from here would reach (M e²), or where rounding stops both.
  const double target = std::max(newton_constant_ * judged_ * judged_, kChordFloor * curvature_rounding());
  const double steps = target >= judged_ ? 1 : std::ceil(std::log(target / judged_) / std::log(rate));
  const double solves = 1 + static_cast<double>(vc_.spherical_gauge ? vc_.spherical_pins.size() : 0);
  const double faces = static_cast<double>(t_.num_faces);
  const double chord = solves * 4 * solver_.factor_nonzeros() + kFaceFlops * faces;
  const double newton = solver_.factor_flops() + chord + kFaceFlops * faces;
  return steps <= kMaxChords - chords_in_row_ && steps * chord < newton;
}

bool FlowSolver::chord_step(double bound) {
  if (!chord_possible()) return false;
  const Status status = r_.status;
  const std::string message = r_.message;
  chord_ = true;
  chord_bound_ = bound;
  const bool kept = newton_step();
  chord_ = false;
  if (kept) {
    ++chords_;
    ++chords_in_row_;
  } else {
    r_.status = status;
    r_.message = message;
  }
  return kept;
}

// Smoothing. A layout closes up to the curvature its loops enclose, so what matters after the
// polishing is the residual's smooth part, which its maximum does not show: at max |K̄ − K| of a
// few ulps it can still add up over large regions. The chord step from there changes u by δ =
// H⁻¹(K̄ − K), which the smooth part amplifies (the small eigenvalues of H), and the lengths by
// about δ of themselves; so chord steps — a solve and one evaluation each — go on while the
// largest |δ| is above kSmoothAbove (after the gauge's mean is removed: E's global scale changes
// no angle), each kept when max |K̄ − K| stays within the rounding level and at most
// FlowOptions::smooth_steps of them, a step that is not at most kSmoothGain of the last ending
// them (rounding). genus2-400k (H): after the polish a residual summing to 1.6e-10 over 2·10⁵
// vertices, one propagation off by 2.0e-9 where its front closes; after one such step 1.1e-11.
// torus-2M (E), two steps: one propagation 8.6e-9 → 6.3e-11. Only with polishing (FlowOptions::polish_steps
// > 0), whose callers lay the metric out.
double FlowSolver::step_size() {
  double largest = 0;
  for (Index v = 0; v < t_.num_vertices; ++v) largest = std::max(largest, std::abs(step_[v]));
  return largest;
}

bool FlowSolver::smooth_step() {
  if (options_.polish_steps <= 0 || smoothing_over_ || smoothed_ >= options_.smooth_steps || !chord_possible() ||
      iteration_ >= options_.max_iterations)
    return false;
  ++iteration_;
  smoothing_ = true;
  const bool kept = chord_step(std::numeric_limits<double>::infinity());
  smoothing_ = false;
  if (!kept) {
    --iteration_;
    smoothing_over_ = true;  // the first step not taken ends the smoothing
    return false;
  }
  ++smoothed_;
  return true;
}

bool FlowSolver::polish_step() {
  if (polish_tried_ >= options_.polish_steps || polish_tried_ > polished_) return false;
  // At the rounding level of the curvatures (a few ulps of the angle sums, kPolishUlps) no step
  // can be ranked: stop there instead of paying for a factorization the line search rejects.
  if (!(judged_ > curvature_rounding())) return false;
  if (polish_tried_ == 0) error_before_polish_ = error_;
  ++polish_tried_;
  ++iteration_;
  polishing_ = true;
  // First a chord step (chord_step()).
  bool kept = chord_step(judged_);
  if (kept) ++polish_chords_;
  if (!kept) kept = newton_step();
  polishing_ = false;
  if (kept) ++polished_;
  return kept;
}

bool FlowSolver::gradient_step() {
  iter_ = FlowTimings{};
  search_start_ = Clock::now();
  const Index nv = t_.num_vertices;
  const double eps = options_.gradient_step;
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
  for (Index v = 0; v < nv; ++v) step_[v] = vc_.condition[v] ? eps * (K_target_[v] - cur_.K[v]) : 0.0;
  remove_gauge_mean(step_);
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
  for (Index v = 0; v < nv; ++v) u_trial_[v] = u_[v] + step_[v];
  const Validity validity = evaluate_at(u_trial_, trial_, trial_flipped_);
  if (validity != Validity::Ok) {
    undo_flips_after(0);
    fail(validity == Validity::TriangleInequality ? Status::TriangleInequality : Status::NumericalFailure,
         "gradient descent step " + std::to_string(iteration_) + " with step size " +
             format_double("%g", eps) + " left the admissible metrics: " + validity_text(validity) +
             " (a smaller gradient_step may help; the paper uses at most 0.05)");
    return false;
  }
  // Trapezoidal energy change (the flow takes small steps; no extra curvature evaluations).
  const double dE =
      0.5 * sum_(nv, [&](std::int64_t v) {
        return vc_.condition[v] ? ((cur_.K[v] - K_target_[v]) + (trial_.K[v] - K_target_[v])) * step_[v] : 0.0;
      });
  accept(eps, std::isfinite(dE) ? dE : 0.0);
  return true;
}

void FlowSolver::run() {
  const Index nv = t_.num_vertices, nf = t_.num_faces;
  const bool newton = options_.method == Method::Newton;
  vc_.classify(t_, s_.geometry, target_, options_.method);

  u_trial_.assign(static_cast<std::size_t>(nv), 0.0);
  step_.assign(static_cast<std::size_t>(nv), 0.0);
  grad_.assign(static_cast<std::size_t>(nv), 0.0);
  K_target_.assign(static_cast<std::size_t>(nv), 0.0);
  cur_.allocate(t_);
  if (newton) u_quad_.assign(static_cast<std::size_t>(nv), 0.0);
  r_.history.reserve(static_cast<std::size_t>(std::min(options_.max_iterations, 1 << 16)));

  if (tri_) {
    // Flip to the Delaunay triangulation of the start in place.
    start_flips_ = tri_->flips;
    const DelaunayReport flips = make_delaunay(*tri_, u_);
    flips_refused_ = std::max(flips_refused_, flips.refused);
    vertex_scaling_structure(*tri_, *s_mut_);
    if (!flips.complete) {
      fail(Status::NumericalFailure, "the starting metric is not admissible: " + validity_text(Validity::FlipLimit));
      return;
    }
  }
  const Validity start = evaluate(t_, s_, u_, cur_);
  if (start == Validity::OutOfRange) {
    fail(Status::InvalidArgument,
         "the starting u is outside the admissible range (finite, at most " + format_double("%g", kMaxU) +
             (s_.geometry == Geometry::Hyperbolic && s_.epsilon > 0 ? ", and below 0 for hyperbolic radii)"
                                                                    : ")"));
    r_.u.clear();
    return;
  }
  effective_target(t_, target_, cur_.l, K_target_, s_.geometry);
  error_ = max_error(cur_.K, K_target_, vc_.condition);
  if (start != Validity::Ok) {
    fail(start == Validity::TriangleInequality ? Status::TriangleInequality : Status::NumericalFailure,
         "the starting metric is not admissible: " + validity_text(start));
    return;
  }

  Clock::time_point mark = Clock::now();
  if (newton) {
    pattern_ = detail::build_hessian_pattern(t_, vc_.unknown);
    const Index n = pattern_.num_unknowns;
    blocks_.assign(9 * static_cast<std::size_t>(nf), 0.0);
    rhs_.assign(static_cast<std::size_t>(n), 0.0);
    x_.assign(static_cast<std::size_t>(n), 0.0);
    tmp_.assign(static_cast<std::size_t>(n), 0.0);
    x2_.assign(static_cast<std::size_t>(n), 0.0);
    if (vc_.spherical_gauge) {
      const std::size_t k = vc_.spherical_pins.size();
      compute_pin_edges();
      moebius_.assign(k, std::vector<double>(static_cast<std::size_t>(n), 0.0));
      gram_.assign(k * k, 0.0);
      coefficient_.assign(k, 0.0);
      rhs_projected_.assign(static_cast<std::size_t>(n), 0.0);
    }
    if (t_.num_boundary_loops() > 0 &&
        (target_.boundary == BoundaryMode::Circle || target_.boundary == BoundaryMode::LoopTotals) &&
        target_.loop_total.size() == static_cast<std::size_t>(t_.num_boundary_loops()))
      setup_coupling();
    if (coupled_ && options_.normalize_circle_domains && target_.boundary == BoundaryMode::Circle &&
        s_.geometry == Geometry::Euclidean && t_.num_components == 1 && t_.genus() == 0)
      modes_.setup(t_, target_, cur_.l, vc_.condition, u_);
    residual_merit_ = s_.geometry == Geometry::Spherical || coupled_;
    const detail::FactorKind kind = s_.geometry == Geometry::Spherical ? detail::FactorKind::Indefinite
                                                                       : detail::FactorKind::PositiveDefinite;
    r_.timings.setup += std::chrono::duration<double>(mark - start_).count() + lap(mark);
    std::vector<std::int64_t> ordering;
    if (order_hint_ && !order_hint_->empty()) {
      ordering.reserve(static_cast<std::size_t>(n));
      std::vector<std::uint8_t> placed(static_cast<std::size_t>(n), 0);
      for (const Index v : *order_hint_) {
        const Index j = v >= 0 && v < nv ? pattern_.vertex_unknown[v] : kInvalid;
        if (j == kInvalid || placed[j]) continue;
        placed[j] = 1;
        ordering.push_back(j);
      }
      for (Index j = 0; j < n; ++j)
        if (!placed[j]) ordering.push_back(j);
    }
    solver_.set_layout(options_.factorization == Factorization::Supernodal   ? detail::FactorLayout::Supernodal
                       : options_.factorization == Factorization::Simplicial ? detail::FactorLayout::Simplicial
                                                                             : detail::FactorLayout::Automatic);
    const detail::FactorOutcome analysis = solver_.analyze(n, pattern_.col_ptr, pattern_.row, kind, ordering);
    if (analysis == detail::FactorOutcome::Ok) keep_ordering(true);
    if (analysis == detail::FactorOutcome::Ok && coupled_ && !split_) setup_boundary_direct();
    r_.timings.analysis += lap(mark);
    if (analysis != detail::FactorOutcome::Ok) {
      fail(analysis == detail::FactorOutcome::OutOfMemory ? Status::OutOfMemory : Status::NumericalFailure,
           "the symbolic analysis of the " + std::to_string(n) + "×" + std::to_string(n) +
               " Newton system failed");
      return;
    }
  }

  set_tolerance();
  judged_ = error_;
  while (true) {
    // Within the resolution with the resolution of an earlier point: confirmed at this one.
    if (resolution_.active && judged_ < tolerance_ && !(error_ < tolerance_)) resolution_at_u();
    if (judged_ < tolerance_) {
      // A run of chord steps goes on to the rounding level, while they lower the error, where the
      // Newton step it replaces would have ended too: not at the tolerance.
      if (newton && chords_in_row_ > 0 && judged_ > kChordFloor * curvature_rounding() &&
          iteration_ < options_.max_iterations && chord_pays()) {
        ++iteration_;
        if (chord_step(judged_)) continue;
        --iteration_;
      }
      if (newton && polish_step()) continue;
      if (newton && smooth_step()) continue;
      r_.status = Status::Ok;
      r_.message = "converged";
      if (resolution_.active && !(error_ < tolerance_)) note_resolution();
      if (polished_ > 0)
        r_.notes.push_back("polished by " + std::to_string(polished_) + " Newton step" + (polished_ == 1 ? "" : "s") +
                           (polish_chords_ > 0 ? " (" + std::to_string(polish_chords_) + " of them with the last factor)" : std::string()) +
                           " after the tolerance was met: max |K̄ − K| " + format_double("%.3g", error_before_polish_) +
                           " → " + format_double("%.3g", error_));
      if (smoothed_ > 0)
        r_.notes.push_back("smoothed by " + std::to_string(smoothed_) + " chord step" + (smoothed_ == 1 ? "" : "s") +
                           " after the polishing (the residual's smooth part, which layouts integrate): the largest "
                           "change of u " + format_double("%.3g", smooth_first_) +
                           (smoothed_ > 1 ? " → " + format_double("%.3g", smooth_last_) : std::string()));
      return;
    }
    if (!std::isfinite(error_)) {
      fail(Status::NumericalFailure,
           "the curvature error is not finite at iteration " + std::to_string(iteration_));
      return;
    }
    if (newton && vc_.spherical_gauge && max_error(cur_.K, K_target_, vc_.unknown) < 0.01 * tolerance_) {
      fail(Status::NotConverged,
           "Newton converged on the free vertices but not at the three vertices pinned for the Möbius gauge "
           "of the sphere (their starting u is not reachable by a Möbius transformation of the solution)");
      return;
    }
    if (iteration_ >= options_.max_iterations) {
      fail(Status::NotConverged, "the iteration limit " + std::to_string(options_.max_iterations) +
                                     " was reached with max |K̄ − K| = " + format_double("%.3g", error_) +
                                     " above the tolerance " + format_double("%.3g", tolerance_));
      return;
    }
    ++iteration_;
    if (newton && chord_pays() &&
        chord_step(std::max(kChordMargin * kChordRate * newton_gain_ * judged_, kChordFloor * curvature_rounding())))
      continue;
    if (!(newton ? newton_step() : gradient_step())) return;
    if (newton && tri_ != nullptr && stalled()) return;
  }
}

// True (the run failed NotConverged, saying so) when the last kStallSteps records are full
// Newton steps, each accepted at most kStallStep of the step, that lowered the error by less than
// kStallProgress together.
bool FlowSolver::stalled() {
  const std::vector<IterationRecord>& h = r_.history;
  if (h.size() < static_cast<std::size_t>(kStallSteps) + 1) return false;
  for (std::size_t k = h.size() - kStallSteps; k < h.size(); ++k)
    if (h[k].chord || !(h[k].step <= kStallStep)) return false;
  const double before = h[h.size() - kStallSteps - 1].max_error, after = h.back().max_error;
  if (!(after >= (1 - kStallProgress) * before)) return false;
  fail(Status::NotConverged, "Newton stalled: " + std::to_string(kStallSteps) +
                                 " steps in a row were cut to at most 1/1024 of the Newton step and lowered max |K̄ − K| only from " +
                                 format_double("%.3g", before) + " to " + format_double("%.3g", after));
  return true;
}

void FlowSolver::finish() {
  undo_flips_after(0);  // a trial's flips left by a failure
  // What only the iterations need is freed before the results are copied out (the factor first).
  r_.factor_nonzeros = solver_.factor_nonzeros();
  solver_.reset();
  trial_ = MetricState{};
  quad_ = MetricState{};
  blocks_ = std::vector<double>{};
  const Geometry g = s_.geometry;
  r_.iterations = static_cast<int>(r_.history.size());
  r_.chord_steps = chords_;
  if (r_.status == Status::InvalidArgument || r_.status == Status::OutOfMemory) {
    r_.u.clear();
  } else {
    r_.u = u_;
    r_.l = cur_.l;
    r_.K = cur_.K;
    r_.K_target = K_target_;
    r_.max_curvature_error = error_;
    if (resolution_.active) {
      r_.curvature_resolution = resolution_.largest;
      r_.resolution_vertices = resolution_.vertices;
    }
    area_.assign(static_cast<std::size_t>(t_.num_faces), 0.0);
    face_areas(t_, g, cur_.l, cur_.theta, area_);
    r_.gauss_bonnet_error = std::abs(gauss_bonnet_defect(t_, g, cur_.K, area_));
  }
  if (tri_) {
    r_.flips = tri_->flips - start_flips_;
    r_.flips_refused = flips_refused_;
    if (reanalyses_ + pattern_reuses_ > 0)
      r_.notes.push_back("intrinsic flips changed the Newton matrix's pattern in " +
                         std::to_string(reanalyses_ + pattern_reuses_) + " step(s): " +
                         std::to_string(reanalyses_) + " new symbolic analyses (" +
                         (reorderings_ > 0 ? std::to_string(reorderings_) + " of them with a fresh ordering, the factor having grown by over " +
                                                 format_double("%.3g", kRefillGrowth) + "x in nonzeros or " +
                                                 format_double("%.3g", kRefillFlops) + "x in flops with the carried-over one"
                                           : std::string("each with the ordering carried over from the last")) +
                         "), " + std::to_string(pattern_reuses_) + " with the same pattern");
    if (flips_refused_ > 0)
      r_.notes.push_back(std::to_string(flips_refused_) +
                         " non-Delaunay edge(s) were left unflipped at some point: both sides of the edge lie in one "
                         "face");
  }
  if (vc_.spherical_gauge) {
    r_.notes.push_back(
        "spherical gauge: the round-sphere target is unique only up to Möbius transformations; "
        "vertices " +
        std::to_string(vc_.spherical_pins[0]) + ", " + std::to_string(vc_.spherical_pins[1]) + " and " +
        std::to_string(vc_.spherical_pins[2]) + " kept their starting u");
  }
  if (switched_direct_at_ > 0)
    r_.notes.push_back("the boundary system of the length-dependent target was solved directly from Newton step " +
                       std::to_string(switched_direct_at_) + " on: GMRES had needed " +
                       std::to_string(static_cast<long long>(switched_after_solves_)) +
                       " full solves in the step before, more work than the direct solve's");
  if (direct_fallbacks_ > 0)
    r_.notes.push_back("GMRES did not converge on the boundary system of the length-dependent target in " +
                       std::to_string(direct_fallbacks_) + " solve(s); it was solved directly (dense LU) instead");
  if (split_fallbacks_ > 0)
    r_.notes.push_back("the split of the length-dependent target's derivative failed (no positive definite pinned "
                       "matrix, or a singular small system); the boundary system was solved from then on");
  if (gmres_failures_ > 0)
    r_.notes.push_back("the boundary system of the length-dependent target did not converge in " +
                       std::to_string(gmres_failures_) + " step(s); the step with the target held was used");
  if (projection_skipped_ > 0)
    r_.notes.push_back("the Möbius projection of the right-hand side gave no descent direction in " +
                       std::to_string(projection_skipped_) +
                       " step(s); the plain Newton step was used there");
  if (shifted_ > 0)
    r_.notes.push_back("the Newton matrix was not " +
                       std::string(g == Geometry::Spherical ? "factorizable" : "positive definite") + " in " +
                       std::to_string(shifted_) +
                       " step(s); the shifted matrix H + μI was used (largest μ = " +
                       format_double("%.1e", largest_shift_) + " × the largest diagonal entry)");
  if (gradient_fallbacks_ > 0)
    r_.notes.push_back("the Newton direction was unusable in " + std::to_string(gradient_fallbacks_) +
                       " step(s); the " +
                       std::string(residual_merit_ ? "residual gradient" : "Ricci flow") +
                       " direction was used instead");
  if (damped_ > 0)
    r_.notes.push_back("the line search shortened " + std::to_string(damped_) + " Newton step(s)");
  if (modes_.active)
    r_.notes.push_back(
        "circle domain: the Möbius normalization (the first Fourier modes of u along the outer loop held at their "
        "start) moved the outer loop's target curvature by at most " + format_double("%.3g", modes_.largest) +
        " of its value without the modes" +
        (modes_.failures > 0 ? "; " + std::to_string(modes_.failures) + " step(s) without it (singular 2×2 system)" : ""));
  if (noise_accepts_ > 0)
    r_.notes.push_back(
        std::to_string(noise_accepts_) +
        " step(s) were accepted because the curvature error decreased while the energy change was "
        "below rounding");
  r_.seconds = seconds();
}

}  // namespace

// ---------------------------------------------------------------------------------------------

bool FlowOptions::is_valid(std::string* why) const {
  auto bad = [&](const char* text) {
    if (why) *why = text;
    return false;
  };
  if (method != Method::Newton && method != Method::GradientDescent)
    return bad("method must be Newton or GradientDescent");
  if (factorization != Factorization::Automatic && factorization != Factorization::Supernodal &&
      factorization != Factorization::Simplicial)
    return bad("factorization must be Automatic, Supernodal or Simplicial");
  if (!std::isfinite(tolerance) || tolerance <= 0) return bad("tolerance must be a positive finite number");
  if (max_iterations < 0) return bad("max_iterations must be non-negative");
  if (!std::isfinite(gradient_step) || gradient_step <= 0)
    return bad("gradient_step must be a positive finite number (the paper uses at most 0.05)");
  if (threads < 0) return bad("threads must be non-negative (0 keeps the current OpenMP setting)");
  if (polish_steps < 0) return bad("polish_steps must be non-negative");
  if (smooth_steps < 0 || smooth_steps > 20) return bad("smooth_steps must be in 0..20");
  return true;
}

std::string FlowResult::brief_report() const {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer,
                "%s: %s, %d iteration%s, max |K̄ − K| %.3g, Gauss–Bonnet error %.3g, %.3f s",
                std::string(status_name(status)).c_str(), std::string(geometry_name(geometry)).c_str(),
                iterations, iterations == 1 ? "" : "s", max_curvature_error, gauss_bonnet_error, seconds);
  return buffer;
}

namespace {

FlowResult solve_flow_ordered(const Topology& topology, const ConformalStructure& structure,
                              std::span<const double> u0, const Target& target, const FlowOptions& options,
                              const std::vector<Index>* order_hint, std::vector<Index>* order_out);

// S safeguard (see the top of this file): the direct Newton solve gets this many steps before
// the continuation takes over.
constexpr int kDirectSphericalIterations = 40;

// The caller's progress callback for a stage that starts after `offset` iterations and
// `elapsed` seconds of the solve (records are renumbered and retimed from the solve's start).
std::function<void(const IterationRecord&)> shifted_progress(const FlowOptions& options, int offset, double elapsed) {
  if (!options.on_iteration) return nullptr;
  return [&options, offset, elapsed](const IterationRecord& record) {
    IterationRecord shifted = record;
    shifted.iteration += offset;
    shifted.seconds += elapsed;
    options.on_iteration(shifted);
  };
}

// The vertex sent to infinity by spherical_start_from_plane(): the vertex of largest valence (the
// smallest index among ties) among those whose neighbours all have valence ≥ 4, so that no vertex
// of the disk's boundary lies in a single triangle. kInvalid when there is none.
Index vertex_at_infinity(const Topology& t) {
  Index v = kInvalid;
  for (Index i = 0; i < t.num_vertices; ++i) {
    if (t.valence(i) == 0 || (v != kInvalid && t.valence(i) <= t.valence(v))) continue;
    bool ears = false;
    for (Index k = t.vertex_corner_offsets[i]; k < t.vertex_corner_offsets[i + 1] && !ears; ++k)
      ears = t.valence(t.corner_vertex[next_corner(t.vertex_corners[k])]) < 4;
    if (!ears) v = i;
  }
  return v;
}

// The disk d's circles (planar layout x, radii e^u_disk) carried to the sphere: the disk's
// boundary circle fitted, scaled to bound a cap of area `share`, each circle lifted by inverse
// stereographic projection. Writes the sphere's u, circle centres and radii rho for the disk's
// vertices (to_full: disk vertex → sphere vertex); false when a circle does not lift.
bool lift_circles(const Topology& d, const std::vector<double>& x, const std::vector<double>& u_disk,
                  const std::vector<Index>& to_full, double share, std::vector<double>& u,
                  std::vector<double>& centre, std::vector<double>& rho) {
  // The boundary circle → the unit circle, scaled so that it bounds a cap of v's area share:
  // 1 − cos ψ = 2·share, and the circle at polar angle ψ from the north pole projects to radius
  // cot(ψ/2).
  double cx = 0, cy = 0;
  const Index nb = d.num_boundary_edges();
  for (Index j = 0; j < nb; ++j) {
    cx += x[2 * d.boundary_vertices[j]];
    cy += x[2 * d.boundary_vertices[j] + 1];
  }
  cx /= nb;
  cy /= nb;
  double R = 0;
  for (Index j = 0; j < nb; ++j)
    R += std::hypot(x[2 * d.boundary_vertices[j]] - cx, x[2 * d.boundary_vertices[j] + 1] - cy);
  R /= nb;
  const double cos_psi = 1 - 2 * share;
  const double lambda = std::sqrt(1 - cos_psi * cos_psi) / (1 - cos_psi);
  const double scale = lambda / R;
  auto lift = [](double px, double py, double out[3]) {
    const double q = px * px + py * py;
    out[0] = 2 * px / (q + 1);
    out[1] = 2 * py / (q + 1);
    out[2] = (q - 1) / (q + 1);
  };
  for (Index i = 0; i < static_cast<Index>(to_full.size()); ++i) {
    const double zx = (x[2 * i] - cx) * scale, zy = (x[2 * i + 1] - cy) * scale;
    const double r = std::exp(u_disk[i]) * scale;
    const double norm = std::hypot(zx, zy);
    const double dx = norm > 0 ? zx / norm : 1.0, dy = norm > 0 ? zy / norm : 0.0;
    double a[3], b[3];
    lift((norm - r) * dx, (norm - r) * dy, a);
    lift((norm + r) * dx, (norm + r) * dy, b);
    // Half the angle between the two points, by atan2 (acos loses small circles).
    const double cx3 = a[1] * b[2] - a[2] * b[1], cy3 = a[2] * b[0] - a[0] * b[2], cz3 = a[0] * b[1] - a[1] * b[0];
    const double radius =
        0.5 * std::atan2(std::sqrt(cx3 * cx3 + cy3 * cy3 + cz3 * cz3), a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
    if (!(radius > 0 && radius < std::numbers::pi / 2)) return false;
    const Index full = to_full[i];
    rho[full] = radius;
    const double mx = a[0] + b[0], my = a[1] + b[1], mz = a[2] + b[2], mn = std::sqrt(mx * mx + my * my + mz * mz);
    if (!(mn > 0)) return false;
    centre[3 * full] = mx / mn;
    centre[3 * full + 1] = my / mn;
    centre[3 * full + 2] = mz / mn;
    u[full] = std::log(std::tan(radius / 2));
  }
  return true;
}

// The radius of v (at the north pole) from its neighbours' circles (centre, rho), written to u[v].
bool fit_pole_radius(const Topology& t, const ConformalStructure& s, Index v, const std::vector<double>& centre,
                     const std::vector<double>& rho, std::vector<double>& u) {
  // v at the north pole; its radius from each neighbour j by the spherical cosine law
  // cos d_j = cos ρ_v cos ρ_j − sin ρ_v sin ρ_j η_vj, averaged.
  double sum = 0;
  int count = 0;
  for (Index k = t.vertex_corner_offsets[v]; k < t.vertex_corner_offsets[v + 1]; ++k) {
    const Index c = t.vertex_corners[k];
    const Index j = t.corner_vertex[next_corner(c)];
    const double eta = s.eta[t.corner_edge[prev_corner(c)]];  // the edge from v to j
    const double A = std::cos(rho[j]), B = std::sin(rho[j]) * eta, C = centre[3 * j + 2];
    const double h = std::hypot(A, B);
    if (!(h > 0) || std::abs(C) > h) continue;
    const double value = std::acos(C / h) - std::atan2(B, A);
    if (value > 0 && value < std::numbers::pi) {
      sum += value;
      ++count;
    }
  }
  if (count == 0) return false;
  u[v] = std::log(std::tan(sum / count / 2));
  return true;
}

// A starting point for the round-sphere target (S, genus 0, K̄ = 0) from a planar problem, which
// is convex. Intersection angles and inversive distances are Möbius invariant, so stereographic
// projection from the centre of a vertex v's circle turns a spherical pattern into a planar one
// with the same weights on the mesh without v, whose boundary circles (v's neighbours) cross the
// image of v's circle. That boundary condition is approximated by "boundary centres on a
// circle": the disk (the mesh minus the star of v) is solved in E with a circle boundary (convex,
// Möbius-normalized, a few Newton steps), laid out face by face, scaled so that the outer circle
// bounds a cap of the area share of v's star, and mapped back by inverse stereographic projection,
// circle by circle; v's radius is fitted to its neighbours. Returns an empty vector when a step
// is not possible (another scheme, a degenerate layout, …).
std::vector<double> spherical_start_from_plane(const Topology& t, const ConformalStructure& s,
                                               std::span<const double> u0, const FlowOptions& options,
                                               std::array<Index, 3>* pins, std::vector<Index>* order) {
  const Index nv = t.num_vertices, ne = t.num_edges, nf = t.num_faces;
  if (s.scheme == Scheme::Yamabe || s.geometry != Geometry::Spherical || nv < 5) return {};
  std::vector<double> l(static_cast<std::size_t>(ne)), theta(3 * static_cast<std::size_t>(nf)),
      area(static_cast<std::size_t>(nf));
  if (edge_lengths(t, s, u0, l) != kInvalid || corner_angles(t, s.geometry, l, theta).violations > 0) return {};
  face_areas(t, s.geometry, l, theta, area);
  const Index v = vertex_at_infinity(t);
  if (v == kInvalid) return {};
  // The disk: every face without v, vertices renumbered without v.
  std::vector<Index> to_sub(static_cast<std::size_t>(nv), kInvalid), to_full;
  for (Index i = 0; i < nv; ++i)
    if (i != v && t.valence(i) > 0) {
      to_sub[i] = static_cast<Index>(to_full.size());
      to_full.push_back(i);
    }
  std::vector<Index> faces;
  std::vector<Index> face_full;
  double star_area = 0, total_area = 0;
  for (Index f = 0; f < nf; ++f) {
    total_area += area[f];
    const Index a = t.corner_vertex[3 * f], b = t.corner_vertex[3 * f + 1], c = t.corner_vertex[3 * f + 2];
    if (a == v || b == v || c == v) {
      star_area += area[f];
      continue;
    }
    faces.insert(faces.end(), {to_sub[a], to_sub[b], to_sub[c]});
    face_full.push_back(f);
  }
  const auto n_sub = static_cast<Index>(to_full.size());
  TopologyResult sub = build_topology(faces, n_sub);
  if (sub.status != Status::Ok || sub.topology.num_boundary_loops() != 1 || sub.topology.euler_characteristic() != 1)
    return {};
  const Topology& d = sub.topology;
  // The same weights on the disk's edges (a disk edge is the full edge of the same face slot).
  ConformalStructure plane;
  plane.geometry = Geometry::Euclidean;
  plane.scheme = s.scheme;
  plane.epsilon = s.epsilon;
  plane.eta.assign(static_cast<std::size_t>(d.num_edges), 0.0);
  std::vector<double> disk_l(static_cast<std::size_t>(d.num_edges), 0.0);
  for (Index g = 0; g < d.num_faces; ++g)
    for (Index k = 0; k < 3; ++k) {
      plane.eta[d.corner_edge[3 * g + k]] = s.eta[t.corner_edge[3 * face_full[g] + k]];
      disk_l[d.corner_edge[3 * g + k]] = l[t.corner_edge[3 * face_full[g] + k]];
    }
  // Start: the spherical radii as euclidean ones (small triangles are nearly flat), γ = 2 atan e^u.
  std::vector<double> u_disk(static_cast<std::size_t>(n_sub), 0.0);
  for (Index i = 0; i < n_sub; ++i) u_disk[i] = std::log(2 * std::atan(std::exp(u0[to_full[i]])));
  const Target circle = uniform_target(d, BoundaryMode::Circle);
  FlowOptions plane_options;
  plane_options.tolerance = 1e-8;  // a start: the spherical Newton solve does the rest
  plane_options.max_iterations = 40;
  plane_options.threads = options.threads;
  std::vector<Index> disk_order;
  const FlowResult flat = solve_flow_ordered(d, plane, u_disk, circle, plane_options, nullptr, &disk_order);
  if (flat.u.empty() || !(flat.max_curvature_error < 1e-4)) return {};

  // The planar layout (no normalisation: the circle is fitted below). One propagation without
  // polishing or patches: the disk is solved to 1e-8 only and the result is a start, so the
  // layout's refinements (which cost as much as the spherical analysis on brain-32k) buy nothing.
  LayoutOptions plane_layout;
  plane_layout.normalize = false;
  plane_layout.polish_sweeps = 0;
  plane_layout.polish_steps = 0;
  plane_layout.patches = 0;
  const Layout laid = layout_disk(d, Geometry::Euclidean, flat.l, plane_layout);
  if (laid.status != Status::Ok || laid.unplaced_vertices > 0) return {};
  std::vector<double> u(static_cast<std::size_t>(nv), 0.0), centre(3 * static_cast<std::size_t>(nv), 0.0),
      rho(static_cast<std::size_t>(nv), 0.0);
  if (!lift_circles(d, laid.positions, flat.u, to_full, std::clamp(star_area / total_area, 1e-6, 0.25), u, centre, rho) ||
      !fit_pole_radius(t, s, v, centre, rho, u))
    return {};
  for (Index i = 0; i < nv; ++i)
    if (t.valence(i) > 0 && !std::isfinite(u[i])) return {};
  for (Index i = 0; i < nv; ++i)
    if (t.valence(i) == 0) u[i] = u0[i];
  // The disk's elimination order, as vertices of the sphere.
  if (order) {
    order->resize(disk_order.size());
    for (std::size_t k = 0; k < disk_order.size(); ++k) (*order)[k] = to_full[disk_order[k]];
  }
  // Pins for the Möbius gauge: v at the north pole and the vertices whose circle centres are
  // nearest to (1, 0, 0) and (0, 1, 0) — three nearly orthogonal directions, so that the three
  // pinned radii fix the Möbius transformation well.
  if (pins) {
    Index px = kInvalid, py = kInvalid;
    for (Index i = 0; i < nv; ++i) {
      if (i == v || t.valence(i) == 0) continue;
      if (px == kInvalid || centre[3 * i] > centre[3 * px]) px = i;
      if (py == kInvalid || centre[3 * i + 1] > centre[3 * py + 1]) py = i;
    }
    *pins = {v, px, py};
  }
  return u;
}

// Continuation for S: the targets K̄(s) = K̄ + (1 − s)(K₀ − K̄), K₀ the curvature at u0, from
// s = 0 (solved by u0) to s = 1, each solved by Newton from the previous solution. The step in s
// doubles after a success (up to ½) and halves after a failure (down to 2⁻¹²). Intermediate
// targets are solved to max(tol, 10⁻⁸), the last one to tol. `failed` is the direct attempt.
FlowResult spherical_continuation(const Topology& t, const ConformalStructure& s, std::span<const double> u0,
                                  const Target& target, const FlowOptions& options, FlowResult failed,
                                  const std::string& attempt, Clock::time_point start) {
  const Index nv = t.num_vertices;
  std::vector<double> l(static_cast<std::size_t>(t.num_edges)), theta(3 * static_cast<std::size_t>(t.num_faces)),
      K0(static_cast<std::size_t>(nv));
  if (edge_lengths(t, s, u0, l) != kInvalid || corner_angles(t, s.geometry, l, theta).violations > 0) return failed;
  vertex_curvature(t, theta, K0);

  const std::string direct = failed.message;
  FlowResult best = std::move(failed);
  FlowTimings timings = best.timings;
  std::vector<IterationRecord> history = best.history;
  int used = best.iterations;
  int stages = 0;
  std::vector<double> u(u0.begin(), u0.end());
  Target stage_target = target;
  double done = 0, ds = 0.25;
  constexpr double kMinContinuationStep = 1.0 / 4096;
  FlowResult last;
  while (true) {
    const double next = std::min(1.0, done + ds);
    for (Index v = 0; v < nv; ++v) {
      const bool held = !target.fixed_u.empty() && target.fixed_u[v];
      stage_target.K[v] = held ? target.K[v] : target.K[v] + (1 - next) * (K0[v] - target.K[v]);
    }
    FlowOptions stage = options;
    stage.spherical_safeguards = false;
    if (next < 1) stage.polish_steps = 0;
    stage.tolerance = next < 1 ? std::max(options.tolerance, 1e-8) : options.tolerance;
    stage.max_iterations = std::min(30, options.max_iterations - used);
    const int offset = used;
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    stage.on_iteration = shifted_progress(options, offset, elapsed);
    last = FlowResult{};
    last.geometry = s.geometry;
    {
      FlowSolver solver(t, s, u, stage_target, stage, last);
      solver.run();
      solver.finish();
    }
    ++stages;
    used += last.iterations;
    timings.setup += last.timings.setup;
    timings.analysis += last.timings.analysis;
    timings.derivatives += last.timings.derivatives;
    timings.assembly += last.timings.assembly;
    timings.factorization += last.timings.factorization;
    timings.solve += last.timings.solve;
    timings.line_search += last.timings.line_search;
    for (IterationRecord record : last.history) {
      record.iteration += offset;
      record.seconds += elapsed;
      history.push_back(record);
    }
    if (last.status == Status::Ok) {
      u = last.u;
      done = next;
      if (done >= 1) break;
      ds = std::min(0.5, 2 * ds);
    } else {
      if (last.status == Status::OutOfMemory) break;
      ds /= 2;
      if (ds < kMinContinuationStep) break;
    }
    if (used >= options.max_iterations) break;
  }
  FlowResult r = std::move(last);
  r.timings = timings;
  r.history = std::move(history);
  r.iterations = used;
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const std::string what = attempt + " stopped (" + direct + "); a continuation from the starting "
                           "curvature solved " + std::to_string(stages) + " intermediate target(s)";
  if (r.status == Status::Ok && done >= 1) {
    r.notes.insert(r.notes.begin(), what + " and converged");
  } else {
    if (r.status == Status::Ok) r.status = Status::NotConverged;
    r.message = "the spherical solve did not converge: " + what + " and reached only " +
                format_double("%.4g", done) + " of the way to the target (last stage: " + r.message + ")";
    r.notes.insert(r.notes.begin(), what);
    if (used >= options.max_iterations) r.status = Status::NotConverged;
  }
  return r;
}

// solve_flow() with vertex orders for the symbolic analysis of the (first) Newton system, see
// FlowSolver::set_ordering().
// Checks the inputs of a solve (options, sizes, finite values, the target's feasibility); on a
// problem sets status and message and returns false.
bool valid_flow_inputs(const Topology& topology, const ConformalStructure& structure, std::span<const double> u0,
                       const Target& target, const FlowOptions& options, Status& status, std::string& message) {
  auto reject_inputs = [&](Status s, std::string m) {
    status = s;
    message = std::move(m);
    return false;
  };
  if (std::string why; !options.is_valid(&why))
    return reject_inputs(Status::InvalidArgument, "invalid flow options: " + why);
  const Index nv = topology.num_vertices;
  if (topology.num_faces <= 0) return reject_inputs(Status::InvalidArgument, "the mesh has no faces");
  if (structure.geometry != Geometry::Euclidean && structure.geometry != Geometry::Hyperbolic &&
      structure.geometry != Geometry::Spherical)
    return reject_inputs(Status::InvalidArgument, "the conformal structure has an unknown geometry");
  if (structure.eta.size() != static_cast<std::size_t>(topology.num_edges))
    return reject_inputs(Status::InvalidArgument,
                  "the conformal structure has " + std::to_string(structure.eta.size()) +
                      " edge weights, but the mesh has " + std::to_string(topology.num_edges) + " edges");
  if (!std::isfinite(structure.epsilon) || structure.epsilon < 0)
    return reject_inputs(Status::InvalidArgument, "the conformal structure's ε must be finite and non-negative");
  for (std::size_t e = 0; e < structure.eta.size(); ++e)
    if (!std::isfinite(structure.eta[e]))
      return reject_inputs(Status::InvalidArgument,
                    "the edge weight η of edge " + std::to_string(e) + " is not finite");
  if (u0.size() != static_cast<std::size_t>(nv))
    return reject_inputs(Status::InvalidArgument, "u0 has " + std::to_string(u0.size()) +
                                               " values, but the mesh has " + std::to_string(nv) +
                                               " vertices");
  for (Index v = 0; v < nv; ++v)
    if (!std::isfinite(u0[v]))
      return reject_inputs(Status::InvalidArgument, "u0 of vertex " + std::to_string(v) + " is not finite");
  if (target.K.size() != static_cast<std::size_t>(nv) ||
      (!target.fixed_u.empty() && target.fixed_u.size() != static_cast<std::size_t>(nv)))
    return reject_inputs(Status::InvalidArgument, "the target has " + std::to_string(target.K.size()) +
                                               " curvatures and " + std::to_string(target.fixed_u.size()) +
                                               " fixed_u flags, but the mesh has " + std::to_string(nv) +
                                               " vertices");
  const TargetCheck check = check_target(topology, structure, target);
  if (check.status != Status::Ok)
    return reject_inputs(
        check.status == Status::InfeasibleTarget ? Status::InfeasibleTarget : Status::InvalidArgument,
        check.message);

  return true;
}

FlowResult solve_flow_ordered(const Topology& topology, const ConformalStructure& structure,
                              std::span<const double> u0, const Target& target, const FlowOptions& options,
                              const std::vector<Index>* order_hint, std::vector<Index>* order_out) {
  const auto start = Clock::now();
  FlowResult r;
  r.geometry = structure.geometry;
  auto reject = [&](Status status, std::string message) {
    r.status = status;
    r.message = std::move(message);
    r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return r;
  };
  Status status = Status::Ok;
  if (std::string why; !valid_flow_inputs(topology, structure, u0, target, options, status, why))
    return reject(status, std::move(why));
  const Index nv = topology.num_vertices;
  ThreadScope threads(options.threads, topology.num_faces);
  const bool coupled = !topology.is_closed() && (target.boundary == BoundaryMode::Circle ||
                                                 target.boundary == BoundaryMode::LoopTotals);
  const bool homotopy = options.method == Method::Newton && options.spherical_safeguards &&
                        structure.geometry == Geometry::Spherical && !coupled;
  // The round sphere (closed, genus 0, K̄ = 0): start from the stereographic image of a planar
  // circle-domain solution, which is close to a solution; Step 2's radii are for a surface that
  // is usually far from round.
  bool round = homotopy && topology.is_closed() && topology.num_components == 1 &&
               topology.euler_characteristic() == 2 && target.fixed_u.empty();
  for (Index v = 0; v < nv && round; ++v) round = target.K[v] == 0;
  std::vector<double> planar_u;
  std::array<Index, 3> pins = {kInvalid, kInvalid, kInvalid};
  // The planar disk is the sphere without one vertex star: its fill-reducing ordering, restricted,
  // serves the spherical system too (one ordering instead of two).
  std::vector<Index> planar_order;
  if (round) planar_u = spherical_start_from_plane(topology, structure, u0, options, &pins, &planar_order);
  if (!planar_u.empty() && !order_hint) order_hint = &planar_order;
  const std::span<const double> first_u = planar_u.empty() ? u0 : std::span<const double>(planar_u);
  const std::string first_name = planar_u.empty() ? "the direct Newton solve"
                                                  : "Newton from the stereographic image of a planar circle-domain "
                                                    "solution";
  FlowOptions direct = options;
  if (homotopy) direct.max_iterations = std::min(options.max_iterations, kDirectSphericalIterations);
  // Times count from the call, the planar start included.
  const double before = std::chrono::duration<double>(Clock::now() - start).count();
  direct.on_iteration = shifted_progress(options, 0, before);
  {
    FlowSolver solver(topology, structure, first_u, target, direct, r);
    if (!planar_u.empty()) solver.set_sphere_pins(pins);
    solver.set_ordering(order_hint, order_out);
    solver.run();
    solver.finish();
  }
  for (IterationRecord& record : r.history) record.seconds += before;
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (!planar_u.empty() && r.status == Status::Ok)
    r.notes.insert(r.notes.begin(), "started from the stereographic image of a planar circle-domain solution");
  const bool retry = r.status == Status::NotConverged || r.status == Status::LineSearchFailed ||
                     r.status == Status::TriangleInequality || r.status == Status::NumericalFailure;
  if (!homotopy || !retry || r.iterations >= options.max_iterations) return r;
  // Otherwise: a continuation from the starting curvature of the same start.
  return spherical_continuation(topology, structure, first_u, target, options, std::move(r), first_name, start);
}

}  // namespace

FlowResult solve_flow(const Topology& topology, const ConformalStructure& structure,
                      std::span<const double> u0, const Target& target, const FlowOptions& options) {
  FlowResult r = solve_flow_ordered(topology, structure, u0, target, options, nullptr, nullptr);
  // A circle-packing (or inversive-distance) solve that stalled: where its radii went, Theorem 4
  // may fail on a set of vertices that the checks before the solve (single vertices, single loops)
  // do not look at.
  const bool stalled = r.status == Status::LineSearchFailed || r.status == Status::NotConverged ||
                       r.status == Status::TriangleInequality;
  if (stalled && r.u.size() == static_cast<std::size_t>(topology.num_vertices)) {
    const TargetCheck why = check_theorem4_levels(topology, structure, target, r.u);
    if (why.status == Status::InfeasibleTarget) {
      r.notes.push_back(std::string(status_name(r.status)) + ": " + r.message);
      r.status = Status::InfeasibleTarget;
      r.message = why.message;
    }
  }
  return r;
}

FlowResult solve_flow_with_flips(IntrinsicTriangulation& triangulation, std::span<const double> u0,
                                 const Target& target, const FlowOptions& options) {
  return detail::solve_flow_with_flips_ordered(triangulation, u0, target, options, nullptr, nullptr);
}

FlowResult detail::solve_flow_with_flips_ordered(IntrinsicTriangulation& triangulation, std::span<const double> u0,
                                                 const Target& target, const FlowOptions& options,
                                                 const std::vector<Index>* order_hint, std::vector<Index>* order_out) {
  const auto start = Clock::now();
  FlowResult r;
  r.geometry = triangulation.geometry;
  const Topology& topology = triangulation.topology;
  ConformalStructure structure;
  Status status = Status::Ok;
  if (triangulation.log_chord.size() != static_cast<std::size_t>(topology.num_edges) ||
      triangulation.boundary_position.size() != static_cast<std::size_t>(topology.num_edges)) {
    status = Status::InvalidArgument;
    r.message = "the intrinsic triangulation has " + std::to_string(triangulation.log_chord.size()) +
                " log-chords for " + std::to_string(topology.num_edges) + " edges";
  } else {
    vertex_scaling_structure(triangulation, structure);
    valid_flow_inputs(topology, structure, u0, target, options, status, r.message);
  }
  if (status != Status::Ok) {
    r.status = status;
    r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return r;
  }
  // The round sphere: the spherical energy is not convex, so start from the planar problem with
  // one vertex at infinity (sphere_start.h), which is.
  std::vector<double> sphere_u;
  std::vector<Index> sphere_order;  // the planar system's last ordering, for the spherical one
  if (options.spherical_safeguards && options.method == Method::Newton && triangulation.geometry == Geometry::Spherical &&
      topology.is_closed() && topology.euler_characteristic() == 2 && target.fixed_u.empty() &&
      std::all_of(target.K.begin(), target.K.end(), [](double k) { return k == 0; })) {
    const detail::SphereStart planar = detail::round_sphere_start(triangulation, options);
    if (planar.status == Status::Ok) {
      sphere_u = planar.u;
      sphere_order = planar.order;
      r.notes.push_back("started from the planar solution with vertex " + std::to_string(planar.vertex_at_infinity) +
                        " at infinity (" + std::to_string(planar.iterations) + " Newton steps), projected to the sphere");
    } else {
      r.notes.push_back("no planar start for the round sphere (" + planar.message + ", after " + std::to_string(planar.iterations) + " planar Newton steps); Newton from the given u");
    }
  }
  ThreadScope threads(options.threads, topology.num_faces);
  const IntrinsicTriangulation before = sphere_u.empty() ? IntrinsicTriangulation{} : triangulation;
  {
    FlowSolver solver(topology, structure, sphere_u.empty() ? u0 : std::span<const double>(sphere_u), target, options, r);
    solver.set_intrinsic(triangulation, structure);
    // The planar disk is the sphere without one vertex star: its ordering (the star's vertices
    // last) serves the spherical system too, one fill-reducing ordering instead of two.
    solver.set_ordering(order_hint || sphere_order.empty() ? order_hint : &sphere_order, order_out);
    solver.run();
    solver.finish();
  }
  if (!sphere_u.empty() && r.status != Status::Ok) {
    // The start did not lead to the sphere: Newton from the given u instead.
    const std::string why = r.message;
    triangulation = before;
    vertex_scaling_structure(triangulation, structure);
    r = FlowResult{};
    r.geometry = triangulation.geometry;
    r.notes.push_back("the planar start for the round sphere did not converge (" + why + "); Newton from the given u");
    FlowSolver solver(topology, structure, u0, target, options, r);
    solver.set_intrinsic(triangulation, structure);
    solver.set_ordering(order_hint, order_out);
    solver.run();
    solver.finish();
  }
  return r;
}

}  // namespace ricci
