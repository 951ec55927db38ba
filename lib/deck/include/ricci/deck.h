// ricci — deck transformations of a laid-out fundamental polygon and the universal cover.
//
//   CutResult cut = cut_surface(mesh, topology);                   // canonical, closed, genus g ≥ 1
//   std::vector<double> uv = …;                                    // #Vc×2 layout per cut vertex
//   DeckResult deck = fit_deck_transformations(cut, Geometry::Hyperbolic, uv);
//   CoverResult cover = universal_cover(cut, uv, deck, {.depth = 3});
//   Mesh tiling = cover_mesh(cut, uv, cover);          std::string svg = cover_svg(cut, uv, cover);
//
// Layouts: E (genus 1) in the plane, H (genus ≥ 2) in the Poincaré disk |z| < 1 with the metric
// 2|dz|/(1 − |z|²) (curvature −1); positions are (x, y) = (Re z, Im z) per cut vertex.
//
// ---- Which side maps to which -------------------------------------------------------------
// The disk boundary reads a1 b1 a1^-1 b1^-1 … ag bg ag^-1 bg^-1 counter-clockwise (disk on the
// left). For each letter x ∈ {a_i, b_i} let s be the side labelled x (orientation +1) and p its
// partner x^-1, n vertices each. The deck generator X is the orientation-preserving isometry that
// maps side s onto side p, reversing its direction:
//     X(z_s[k]) = z_p[n−1−k],   k = 0 … n−1     (z_s[k]: position of side_vertices of s, k-th)
// so X carries the polygon P to its neighbour across p (X(P) ∩ P = side p), and X^-1(P) is the
// neighbour across s. A_i, B_i denote the generators of a_i, b_i.
//
// ---- The relation ---------------------------------------------------------------------------
// Composition M·N means "apply N first". Following the single vertex cycle of the polygon
// (Poincaré's theorem: corner angles sum to 2π) gives, up to a cyclic rotation,
//     R = [A_1^-1, B_1] [A_2^-1, B_2] … [A_g^-1, B_g] = 1,   [x, y] = x y x^-1 y^-1.
// With corners v0 … v(4g−1) (v_j the start of side j), A_i maps v(4i−4) ↦ v(4i−1) and
// v(4i−3) ↦ v(4i−2), B_i maps v(4i−3) ↦ v(4i) and v(4i−2) ↦ v(4i−1) (indices mod 4g). Applied to
// v0, R's letters (rightmost first) visit every corner once and return: for g = 2
// v0 →B2⁻¹ v5 →A2 v6 →B2 v7 →A2⁻¹ v4 →B1⁻¹ v1 →A1 v2 →B1 v3 →A1⁻¹ v0, so R fixes v0, and with the
// corner angles summing to 2π it is the identity (the other order Π [A_i, B_i] is not).
// H: relation_error = min ‖R' ∓ I‖ (largest entry modulus) for R' = C R C^-1, C the Möbius map
// moving v0 to the origin, in 113-bit arithmetic (R formed first, then conjugated; R itself is
// reported as `relator`, in double). In double, the partial products' rounding grows with the
// polygon's circumradius (≈ 4e-12 at genus 4 for the exact regular 16-gon); in 113 bits it stays
// far below any fit residual for the polygons met in practice (≤ 6.2e-17 on the shared meshes).
// E: every deck map is additionally fitted as a rigid motion (Procrustes) and relation_error is
// the largest displacement of a polygon vertex by the rigid-motion product R, divided by the
// largest translation of the fitted rigid motions (a relative figure, independent of the units;
// translations alone commute, so the translation relation holds exactly; the rigid fit checks
// the layout).
//
// Bad input (sizes, non-finite positions, |z| ≥ 1 in H, a cut that is not canonical, not closed,
// or of the wrong genus for the geometry) is a status with a message, never NaN or a crash.
#pragma once

#include <array>
#include <complex>
#include <span>
#include <string>
#include <vector>

#include "ricci/cut.h"
#include "ricci/mesh.h"
#include "ricci/metric.h"
#include "ricci/status.h"

namespace ricci {

// ---- Möbius maps of the Poincaré disk -------------------------------------------------------

/// An orientation-preserving isometry of the Poincaré disk as an SU(1,1) matrix [[a, b], [b̄, ā]]
/// with |a|² − |b|² = 1, acting by z ↦ (a z + b)/(b̄ z + ā). M and −M are the same map.
/// Equivalently z ↦ e^{iθ}(z − z₀)/(1 − z̄₀ z) with a = e^{iθ/2}/s, b = −e^{iθ/2} z₀/s,
/// s = √(1 − |z₀|²); z₀ = M^-1(0) is the point sent to the origin.
struct Moebius {
  std::complex<double> a{1, 0};  ///< matrix entry a (the default {1, 0}, {0, 0} is the identity)
  std::complex<double> b{0, 0};  ///< matrix entry b

  /// z ↦ e^{iθ}(z − z₀)/(1 − z̄₀ z); requires |z₀| < 1.
  static Moebius from_theta_z0(double theta, std::complex<double> z0);
  /// z ↦ e^{iθ} z.
  static Moebius rotation(double theta);
  /// The hyperbolic translation along the real axis by distance d (0 ↦ tanh(d/2)).
  static Moebius translation_real(double d);
  /// The map z ↦ (z − p)/(1 − p̄ z) sending p (|p| < 1) to 0.
  static Moebius to_origin(std::complex<double> p);

  /// M(z) = (a z + b)/(b̄ z + ā).
  std::complex<double> apply(std::complex<double> z) const;
  /// 1 − |M(z)|² = (1 − |z|²)/|b̄ z + ā|², exact for |z| near 1 (given 1 − |z|²).
  double one_minus_abs2_of_image(std::complex<double> z, double one_minus_abs2_z) const;
  /// M^-1 = [[ā, −b], [−b̄, a]] (exact for |a|² − |b|² = 1).
  Moebius inverse() const { return {std::conj(a), -b}; }
  /// Rescales to |a|² − |b|² = 1 (removes rounding drift after many products); unchanged when
  /// |a|² − |b|² is not positive.
  Moebius normalized() const;
  /// θ ∈ (−π, π] and z₀ of the e^{iθ}(z − z₀)/(1 − z̄₀ z) form.
  double theta() const;
  /// z₀ = −b/a = M^-1(0) of that form.
  std::complex<double> z0() const;
  /// Translation length 2 arccosh |Re a| of a hyperbolic element (0 when |Re a| ≤ 1).
  double translation_length() const;
};

/// Composition: (M * N)(z) = M(N(z)).
Moebius operator*(const Moebius& m, const Moebius& n);

/// min over the sign of the largest entry modulus of M ∓ N (both taken as SU(1,1) matrices).
double moebius_difference(const Moebius& m, const Moebius& n);
/// moebius_difference(M, identity).
double distance_to_identity(const Moebius& m);

/// Hyperbolic distance d(z, w) = 2 artanh |(z − w)/(1 − w̄ z)| in the disk (curvature −1),
/// accurate in relative terms for tiny distances and near the unit circle (uses
/// 1 − x² = (1 − |z|²)(1 − |w|²)/|1 − w̄ z|²). +∞ when |z| ≥ 1 or |w| ≥ 1.
double hyperbolic_distance(std::complex<double> z, std::complex<double> w);

/// The Möbius map sending z1 ↦ w1 and the geodesic direction z1→z2 to w1→w2 (exact when
/// d(z1, z2) = d(w1, w2)). Identity when z1 = z2 or w1 = w2.
Moebius moebius_from_two_points(std::complex<double> z1, std::complex<double> z2,
                                std::complex<double> w1, std::complex<double> w2);

// ---- Deck transformations -----------------------------------------------------------------

/// Options of the hyperbolic fits of fit_deck_transformations(), deck_through_domain() and
/// fit_domain_pairings().
/// Where deck_through_domain() centres the canonical polygon (DomainDeck::polygon_frame).
enum class PolygonCentre {
  CentreOfMass,  ///< its vertices' hyperboloid centre of mass
  Minimax,       ///< the centre of the smallest hyperbolic disk holding it (approximately)
};

struct DeckOptions {
  /// Ceres: iteration limit and tolerances of the Levenberg–Marquardt fit (H only).
  int max_iterations = 100;            ///< Ceres iteration limit per fit round
  double function_tolerance = 1e-20;   ///< Ceres Solver::Options::function_tolerance
  double gradient_tolerance = 1e-20;   ///< Ceres Solver::Options::gradient_tolerance
  double parameter_tolerance = 1e-18;  ///< Ceres Solver::Options::parameter_tolerance
  /// Fit rounds: each round re-linearises the parametrization M = M_k · N(δ) at the last fit.
  int rounds = 2;
  /// Compact domain (H): move the fitted side pairings to the nearest ones whose vertex cycles
  /// are exactly the identity (see DomainDeck), so that the group they generate is a surface
  /// group to quad precision and every relation holds however far its words reach.
  bool adjust_pairings = true;
  /// The canonical polygon's frame (deck_through_domain()): far-reaching polygons keep the most
  /// digits in double coordinates around their minimax centre.
  PolygonCentre polygon_centre = PolygonCentre::Minimax;
  /// Refuse (NumericalFailure) when that adjustment moves a domain side vertex by more than this
  /// hyperbolic distance: the layout is then not consistent with any surface group, and the
  /// adjustment would hide it. ∞ accepts any.
  double max_pairing_adjustment = 1e-6;
  /// Compact domain (H), with adjust_pairings: after closing the vertex cycles in quad, close them
  /// again in quad-double (about 212 bits) and keep the pairings so (DeckGenerator::map_low2,
  /// map_low3; DomainDeck::wide). canonical_generators() and geodesic_polygon() then evaluate the
  /// generators' words and their polygon in quad-double: the retry of uniformize() for polygons
  /// that reach beyond what quad resolves (a row of 20 holes reaches 28 from its centre, where
  /// quad leaves its relation at 5e-11).
  bool wide_pairings = false;

  /// True when max_iterations ≥ 1, the tolerances are finite and ≥ 0, rounds is in 1..10 and
  /// max_pairing_adjustment is > 0 (∞ allowed);
  /// otherwise false, with the reason in *why (when why is not null).
  bool is_valid(std::string* why) const;
};

/// One fitted deck generator (or side pairing): the map taking a side onto its partner, and how
/// well it does.
struct DeckGenerator {
  std::string name;    ///< "a1", "b1", …
  Index side = -1;     ///< the side labelled `name` (orientation +1)
  Index partner = -1;  ///< the side labelled name^-1; the map sends `side` onto `partner`
  Geometry geometry = Geometry::Hyperbolic;  ///< geometry of the fit (E or H)
  /// H: z ↦ e^{iθ}(z − z₀)/(1 − z̄₀ z) and the same map as SU(1,1) (a, b); translation_length.
  double theta = 0;                 ///< H: θ of the map
  std::complex<double> z0{0, 0};    ///< H: z₀ of the map (the point it sends to 0)
  Moebius map;                      ///< H: the map as an SU(1,1) matrix
  /// H: what rounding `map` to double left out of a map computed in quad (deck_through_domain(),
  /// canonical_generators(), and the adjusted side pairings of fit_domain_pairings()): map +
  /// map_low (entry by entry) is that map to about 106 bits; zero for maps fitted in double.
  /// Maps whose axes lie far from the origin have large entries, and products of them (traces of
  /// words) need these digits.
  Moebius map_low{{0, 0}, {0, 0}};
  /// H: where the map was computed in quad-double (about 212 bits: the pairings, generators and
  /// geodesic polygon of surfaces whose polygon reaches beyond what quad resolves, see
  /// uniformize()), its third and fourth parts: map + map_low + map_low2 + map_low3, entry by
  /// entry. Zero otherwise.
  Moebius map_low2{{0, 0}, {0, 0}};
  Moebius map_low3{{0, 0}, {0, 0}};
  double translation_length = 0;    ///< H: its translation length, map.translation_length()
  /// E: z ↦ z + t, least squares over all pairs (the mean of the differences); `rotation` is the
  /// angle of the rigid-motion (Procrustes) fit, ≈ 0 for a flat torus layout.
  std::array<double, 2> translation{0, 0};  ///< E: t = (x, y)
  double rotation = 0;                      ///< E: angle of the rigid-motion fit, radians
  /// Residuals d(X(z_s[k]), z_p[n−1−k]) over the side's vertex pairs (hyperbolic distance in H,
  /// euclidean in E): max and root mean square, and the number of pairs n.
  double residual_max = 0;  ///< max over the pairs
  double residual_rms = 0;  ///< root mean square over the pairs
  Index pairs = 0;          ///< n, the number of vertex pairs
  /// The maps fitted from single edges (k, k+1) by moebius_from_two_points (E: the translation of
  /// the edge's two pairs): the largest distance, over edges and over the side's vertices, between
  /// the images under the single-edge map and under the fitted map. Small when they agree.
  double single_edge_spread = 0;
  /// Residuals of the closed-form start (the two-point estimate from the side's end vertices;
  /// E: the translation of the first pair) before the fit.
  double initial_residual_max = 0;  ///< max over the pairs, before the fit
  double initial_residual_rms = 0;  ///< root mean square over the pairs, before the fit
};

/// What fit_deck_transformations() returns (and DomainDeck::deck): the generators a1 b1 … and
/// how well they satisfy the relation.
struct DeckResult {
  /// Ok: generators and relation_error are valid. InvalidArgument: options, buffer sizes, a cut
  /// that is not Ok / canonical / closed, a geometry that does not match the genus (E: g = 1,
  /// H: g ≥ 2), |z| ≥ 1 in H (message names the vertex). NonFiniteCoordinate: a position is NaN
  /// or ∞. NumericalFailure: a side is degenerate (coincident ends) or the fit left the disk.
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong; on success the generator count, residual and relation error
  Geometry geometry = Geometry::Hyperbolic;  ///< geometry of the fit (always H in a DomainDeck)
  Index genus = 0;                           ///< genus of the cut (CutResult::genus)
  /// In canonical order a1 b1 a2 b2 … ag bg.
  std::vector<DeckGenerator> generators;
  /// See the header comment: ‖R ∓ I‖ (H) or the largest vertex displacement by R relative to the
  /// largest translation (E).
  double relation_error = 0;
  /// H: the relator R = Π [A_i^-1, B_i] itself (in double, not conjugated).
  Moebius relator;
  double residual_max = 0;        ///< max of the generators' residual_max
  double single_edge_spread = 0;  ///< max of the generators' single_edge_spread
  int ceres_iterations = 0;       ///< Ceres iterations summed over all fits and rounds (0 in E)
  double seconds = 0;             ///< wall-clock time of the call (set on success)

  /// One line: status, geometry, genus, generators, residual, spread, relation error, Ceres
  /// iterations, time.
  std::string brief_report() const;
};

/// Fits one deck generator per pair of partner loop sides of a canonical cut of a closed surface
/// (see the header comment for the direction and the relation). `positions`: #Vc×2 per cut
/// vertex. E: least-squares translation (closed form); H: two-point estimate, then Ceres
/// Levenberg–Marquardt over all vertex pairs with residual vectors of length d(X(z), w).
/// Deterministic.
DeckResult fit_deck_transformations(const CutResult& cut, Geometry geometry,
                                    std::span<const double> positions, const DeckOptions& options = {});

// ---- Through a compact domain (H) ------------------------------------------------------------
//
// A canonical polygon of genus ≥ 3 often reaches far out in the Poincaré disk (thin spikes where
// loops leave the base vertex together), where double coordinates resolve hyperbolic distance
// only to ~2^-52 e^r; its layout, and deck maps fitted to it, inherit that. A compact domain
// (cut_compact(): radius about the surface's own) lays out to rounding. Its side pairings are
// fitted there — one Möbius map per branch of its cut graph, with Ceres over all vertex pairs —
// and the canonical generators follow as exact products of them:
//   every face F of the canonical disk gets the tile h_F (a product of side pairings, long
//   double) in which it lies: breadth-first over the disk from face 0 (h = identity); crossing
//   an input edge that the compact domain cuts multiplies by that edge's pairing N (the map that
//   places the neighbouring face next to the current one: X^-1 when the current face lies on
//   side x, X on side x^-1); crossing anything else keeps h.
//   The canonical polygon's positions are h_F(w), w the compact layout's point (input vertices:
//   their corner in the input face; added vertices: the hyperboloid combination of their record
//   within that face), so each is rounded once, where it lands.
//   The generator of side s (partner p): X = h_{F_p} · N^-1 · h_{F_s}^-1 for the faces F_s, F_p
//   on either side of the surface edge where s begins and N the pairing crossed between them.
// Exact vertex cycles: the fitted pairings satisfy the domain's vertex cycles only to their fit
// residuals (~1e-13), and a relation whose word reaches hyperbolic distance r amplifies that by
// ~e^r (the canonical relation of a genus-4 polygon reaching r ≈ 20: 1e-5). With
// DeckOptions::adjust_pairings the pairings are first moved, by the least change of their
// parameters in a frame centred on each pairing's side (Gauss–Newton, minimum-norm steps; so the
// change is about how far the side's points move, however far out the side lies), onto pairings
// whose every vertex cycle is the
// identity to quad precision (113 bits): a representation of the surface group next to the fitted
// maps. `pairing_adjustment` says how far any domain side vertex moved (the size of the fit
// residuals when the layout is consistent), and side_maps then hold the adjusted maps with their
// residuals. Tiles, positions and generators are products in quad; the relation is computed in
// quad both for the generators and for the same words in the pairings as fitted.
// Residuals of the generators are measured on the canonical positions in quad, in frames
// centred on each side. When a canonical vertex lies beyond the reach of double coordinates
// (hyperbolic distance ≳ 38), the generators and the relation still stand; only
// canonical_positions is left empty and positions_note says why.

/// Side pairings of a compact domain and the canonical generators derived from them.
struct DomainDeck {
  /// Ok; InvalidArgument (sizes, a canonical cut that is not Ok / canonical / closed genus ≥ 2, a
  /// domain that is not a cut of the same input surface); NumericalFailure (a fit left the disk,
  /// a refined vertex whose record does not fit its face, or a tile product that is not finite).
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong; on success what was fitted
  /// The canonical generators a1 b1 … (map, residuals on canonical_positions), the relation.
  DeckResult deck;
  /// The compact domain's side pairings x1, x2, … (each maps side x_k onto x_k^-1, reversed).
  std::vector<DeckGenerator> side_maps;
  /// The same as fitted, before the adjustment (empty when adjust_pairings is off or the domain
  /// has no vertex cycles).
  std::vector<DeckGenerator> fitted_side_maps;
  /// #Vc(canonical)×2: the canonical disk laid out through the compact domain's tiles; empty
  /// when a vertex lies beyond double range (then positions_note names it).
  std::vector<double> canonical_positions;
  std::string positions_note;  ///< why canonical_positions is empty (empty otherwise)
  /// The polygon's frame: canonical_positions and the canonical generators are expressed after
  /// this map of the domain's frame, which moves the polygon's centre (DeckOptions::
  /// polygon_centre) to the origin (a generator X of the domain's frame is polygon_frame · X ·
  /// polygon_frame^-1 here).
  Moebius polygon_frame;
  /// Largest hyperbolic distance between two computations of one canonical cut vertex from
  /// different faces (tiles reached along different paths; 0 up to the side maps' residuals).
  double tile_consistency = 0;
  /// Longest breadth-first path over the canonical disk (number of face steps).
  Index tile_depth = 0;
  /// Poincaré's polygon theorem for the domain: around every vertex of its cut graph the side
  /// pairings crossed compose to the identity. Largest deviation of the pairings as fitted
  /// (|Im a|, |b| of ±M, the product conjugated to that vertex's position), in quad.
  double cycle_error = 0;
  /// The same after the adjustment (quad; equals cycle_error when adjust_pairings is off).
  double adjusted_cycle_error = 0;
  /// What the pairings' quad entries leave of the cycles: 2^-112 × Σ (|a|² + |b|²) over a cycle's
  /// letters, the largest over the cycles (a pairing between sides at distance r from the origin
  /// has entries of size e^r, and its rounding shows at those sides multiplied by e^r again): ~1e-33
  /// for domains near the origin, ~1e-22 for sides at r ≈ 14. The adjustment has closed the cycles
  /// when adjusted_cycle_error is within 1e14 × 2^-112 or 64 times this.
  double cycle_rounding = 0;
  /// Largest hyperbolic distance between the images of a domain side vertex under a fitted and
  /// under the adjusted pairing (0 when adjust_pairings is off).
  double pairing_adjustment = 0;
  /// With DeckOptions::wide_pairings: the cycles closed again in quad-double, the side maps stored
  /// so (map_low2, map_low3), and the largest cycle residual left there (the quad figures above
  /// stay those of the quad adjustment).
  bool wide = false;
  double wide_cycle_error = 0;
  /// The canonical relation evaluated on the same words in the pairings as fitted (deck's
  /// relation_error uses the adjusted pairings; equal when adjust_pairings is off).
  double fitted_relation_error = 0;
  double seconds = 0;  ///< wall-clock time of the call (set on success)
};

/// See the block comment above. `domain` is cut_compact() of the same input surface (no
/// refinement), `domain_positions` its layout (#Vc(domain)×2, Poincaré disk), `canonical` a
/// canonical cut_surface() of that surface (refined or not). `surface`: the input surface's
/// topology when the caller has it (used when it is that of domain.surface_faces, else built);
/// the canonical disk's is taken from canonical.disk_topology in the same way.
DomainDeck deck_through_domain(const CutResult& canonical, const CutResult& domain,
                               std::span<const double> domain_positions, const DeckOptions& options = {},
                               const Topology* surface = nullptr);

/// The compact domain's side pairings alone (Ceres fits over all vertex pairs) and the check of
/// its vertex cycles: status, side_maps, cycle_error (deck has status NotRun; no positions).
/// `surface` as for deck_through_domain().
DomainDeck fit_domain_pairings(const CutResult& domain, std::span<const double> domain_positions,
                               const DeckOptions& options = {}, const Topology* surface = nullptr);

/// fit_domain_pairings()'s result `pairings` (Ok) with its vertex cycles closed again, in quad and
/// then in quad-double (DeckOptions::wide_pairings; adjust_pairings on), without fitting the
/// pairings again: side_maps carry the quad-double maps, fitted_side_maps and cycle_error stay
/// those of the fits. The same domain and positions as for `pairings`.
DomainDeck widen_domain_pairings(const CutResult& domain, std::span<const double> domain_positions,
                                 const DomainDeck& pairings, const DeckOptions& options = {},
                                 const Topology* surface = nullptr);

// ---- Canonical generators and the geodesic canonical polygon (H, closed, genus ≥ 2) ----------
//
// canonical_generators() needs no canonical cut of the mesh. The compact domain's pairings are
// first read as a polygon with one vertex class: each pairing's dual loop at an interior point
// crosses its side once; dropping the loops of a spanning tree of the domain's corner classes
// (the longest pairings) leaves 2g loops that cut the surface into one disk, whose sides are
// paired by the kept pairings conjugated by the walk around it. Its word (x1 x2 x1^-1 …) is
// brought to the normal form a1 b1 a1^-1 b1^-1 … by the classification proof's moves on the word
// alone: cancel x x^-1; then, for a linked pair a … b … a^-1 … b^-1, two cuts and pastes make
// the block c^-1 e c e^-1 (only when that gives no fundamental polygon are the domain's corners
// joined into one class by such moves instead: cut off the triangle of the two sides at a corner
// of the smallest class and reglue it along one of them). A cut along a diagonal into P1 and P2,
// reglued along x, moves P2 by g = X^-1 (x's side in P1) or X; the new letter's pairing is g, and
// the pairings of the sides moved with P2 are conjugated or multiplied by g. So every canonical
// generator is a word in the side pairings, evaluated in quad (map + map_low). Among the moves
// available at each step the one leaving the shortest words is taken; the generators are then
// reduced by substitutions that keep the relation letter for letter (per handle, and per pair
// of adjacent handles: two swaps and a twist), each taken where it shortens the geodesic polygon,
// measured in the polygon's centred frame. The cost depends on the word's length (the domain's
// side count), not on the mesh.
//
// geodesic_polygon() lays out the canonical polygon with deck.h's side convention (A_i maps side
// a_i onto side a_i^-1, reversed): from a vertex p, block i's corners are u, A^-1 B^-1 A u,
// B^-1 A u, A u and the next block starts at [B, A^-1] u; the polygon closes because the relation
// holds. p minimises the perimeter (each side length is the displacement of an isometry at p, a
// convex function; Newton in a frame moved with p), and the polygon is then centred on its
// vertices' centre of mass (on the hyperboloid). The polygon is a fundamental domain when it is simple with angle sum
// 2π (Poincaré's theorem); both are checked, not assumed.

/// What canonical_generators() returns.
struct CanonicalGenerators {
  /// Ok; InvalidArgument (not a cut of a closed surface of genus ≥ 2, a side without a pairing,
  /// one pairing per generator not given); NumericalFailure (the word did not reach the normal
  /// form, or the relation is not finite).
  Status status = Status::NotRun;
  std::string message = "not run";
  /// The generators a1 b1 … ag bg in the side pairings' frame; side/partner −1 (no sides of a
  /// cut), residual_max the largest residual of the pairings they are products of, relation
  /// error at the working frame's origin (below).
  DeckResult deck;
  std::vector<std::string> words;   ///< per generator, its word in the pairings ("x3 x1^-1 x7")
  std::vector<Index> word_lengths;  ///< per generator, the length of that word
  /// Per generator, the same word as signed 1-based pairing numbers (k: side_maps[k − 1], −k: its
  /// inverse), in order: what evaluate_canonical_words() evaluates again.
  std::vector<std::vector<int>> word_letters;
  Index moves = 0;                  ///< cut-and-paste moves on the word
  Index handle_moves = 0;           ///< substitutions made (per handle, and per pair of adjacent handles)
  /// The relation of the same words in `fitted_maps` (at the working frame's origin, below,
  /// quad); equal to deck.relation_error when none are given.
  double fitted_relation_error = 0;
  /// The same generators in the frame where the moves left them (`working_frame`: the pairings'
  /// frame → that frame, map + map_low), where they move points least. deck.relation_error is
  /// measured at its origin. Conjugating by a map that moves points a distance d costs about e^d
  /// of the digits (a genus-12 grid of holes: d = 13.2, and the relation at the pairings' origin
  /// 4e-4 against 1e-14 here), so geodesic_polygon(CanonicalGenerators) starts from these.
  DeckResult working;
  DeckGenerator working_frame;
  /// NumericalFailure because the words' relation is not finite in the arithmetic they were
  /// evaluated in (quad; quad-double when the pairings carry it): the generators found reach
  /// beyond its range (uniformize() then retries in quad-double, or keeps the domain's pairings
  /// and tries no mesh-path polygon, whose view in double resolves less).
  bool beyond_quad = false;
};

/// See the block comment above. `domain` is a closed cut of genus ≥ 2 whose sides are all
/// paired (cut_compact(), or any cut_surface() of a closed surface); `side_maps` one map per
/// generator of it, each sending the generator's side onto its partner (fit_domain_pairings()'s
/// side_maps, whose map_low carry the adjusted maps to quad precision).
/// `fitted_maps` (optional, same order): the pairings as fitted, in which the same words give
/// fitted_relation_error.
CanonicalGenerators canonical_generators(const CutResult& domain, std::span<const DeckGenerator> side_maps,
                                         std::span<const DeckGenerator> fitted_maps = {});

/// The generators of found.word_letters evaluated again in `side_maps` (the same pairings, or
/// the same closed further: DeckOptions::wide_pairings) — in quad-double when every one carries a
/// quad-double map, else in quad — and conjugated into found's working frame: deck, working, the
/// relation and words as canonical_generators() gives them, without repeating its search (moves
/// and handle_moves are found's). InvalidArgument when found is not Ok or its words name
/// pairings side_maps lacks (found may also be a NumericalFailure with beyond_quad, whose words
/// are kept); NumericalFailure (beyond_quad) when the relation is not finite.
CanonicalGenerators evaluate_canonical_words(const CanonicalGenerators& found, std::span<const DeckGenerator> side_maps,
                                             std::span<const DeckGenerator> fitted_maps = {});

/// What geodesic_polygon() returns.
struct GeodesicPolygon {
  /// Ok; InvalidArgument (not 2g ≥ 4 hyperbolic generators); NumericalFailure (a value is not
  /// finite). Ok does not mean simple: see `simple`.
  Status status = Status::NotRun;
  std::string message = "not run";
  std::string word;  ///< "a1 b1 a1^-1 b1^-1 …"
  /// The 4g corners in the polygon's frame, counter-clockwise; corner j starts side j.
  std::vector<std::complex<double>> vertices;
  /// The generators' frame → the polygon's frame.
  Moebius frame;
  /// The generators conjugated into the polygon's frame (names, residuals kept); relation_error
  /// of Π [A_i^-1, B_i] conjugated to corner 0, in quad (quad-double for generators that carry it).
  DeckResult deck;
  std::vector<double> side_lengths;  ///< 4g hyperbolic lengths
  std::vector<double> angles;        ///< 4g interior angles, in (0, 2π)
  double perimeter = 0;
  double angle_sum = 0;  ///< 2π for a fundamental polygon
  double area = 0;       ///< (4g − 2)π − angle_sum: 4π(g − 1) for a fundamental polygon
  /// Largest hyperbolic distance of a corner from the centre; double coordinates resolve lengths
  /// there to about 2^-52·e^reach.
  double reach = 0;
  /// What the generators' arithmetic resolves of the relation at this reach: ε·e^(2·reach), ε =
  /// 2^-112 in quad, 2^-209 in quad-double (generators that carry map_low2/map_low3). A
  /// generator carrying a corner to another has entries up to e^reach in the polygon's frame, and
  /// the relator's factors in the corners' frames multiply their rounding by up to e^reach again
  /// (pretzel(20, 4), reach 29.7: quad's floor 1.2e-8, relation in quad 6.2e-9; in quad-double
  /// 7.8e-28).
  double relation_floor = 0;
  /// The bits of the arithmetic the polygon and its relation were formed in: 113 (quad), or 212
  /// (quad-double: generators that carry map_low2/map_low3).
  int arithmetic_bits = 113;
  /// Simple, with a relation error above 1e-12 but within 16 × relation_floor: what generators in
  /// this arithmetic can verify at this reach, not an inconsistent group (canonical_generators()
  /// scores such a polygon by its perimeter and tries no second round; the pipeline evaluates
  /// the words again in quad-double, and where that is at its floor too keeps the domain's
  /// pairings and says why).
  bool at_quad_floor = false;
  /// NumericalFailure because a corner or the centre lies on the unit circle in the generators'
  /// arithmetic: the polygon reaches beyond what its 113 (quad) or 212 (quad-double) bits resolve
  /// in the disk (uniformize() then retries in quad-double, or keeps the domain's pairings and
  /// tries no mesh-path polygon, whose view in double resolves less).
  bool beyond_quad = false;
  /// Hyperbolic distance between corner 0 and where the walk around the 4g sides ends (quad).
  double closure_error = 0;
  /// No two non-adjacent sides meet and adjacent sides meet only at their corner.
  bool simple = false;
  /// How far the angle sum may be from 2π for this polygon: max(1e-9, relation error · e^reach).
  /// The corners are images of one point under the generators' partial products, so a relator
  /// off the identity by δ moves them by up to about δ·e^reach (measured: 1.9e2–1e7 · δ at reach
  /// 17–22), and the angles with them.
  double angle_tolerance = 1e-9;
  /// A fundamental domain: simple and the angle sum 2π within angle_tolerance (a polygon whose
  /// corners wrap around more than once sums to 4π, 6π, …).
  bool fundamental = false;
  int newton_steps = 0;  ///< steps of the perimeter minimisation
  double seconds = 0;
};

/// See the block comment above. `canonical`: generators a1 b1 … ag bg (g ≥ 2) in deck.h's
/// convention, with map_low when they come from quad products.
GeodesicPolygon geodesic_polygon(const DeckResult& canonical);
/// The same for canonical_generators()'s result, from its working frame (its polygon's frame
/// and generators then keep the digits a conjugation into the pairings' frame would lose); the
/// polygon's frame is still reported from the pairings' frame.
GeodesicPolygon geodesic_polygon(const CanonicalGenerators& canonical);

// ---- Universal cover ----------------------------------------------------------------------

/// Options of universal_cover().
struct CoverOptions {
  /// H: reduced words in A_i^±1, B_i^±1 up to this length. E: a depth×depth block of translates
  /// a1^m b1^n (m, n centred on 0).
  Index depth = 3;
  /// H: keep (and extend) only elements moving the polygon's reference point (the mean of its
  /// vertices) into |z| ≤ radius. 1: no limit.
  double radius = 1;
  /// H: two words are the same element when the images of the reference point are closer than
  /// this hyperbolic distance (the group acts freely, so distinct elements move it apart).
  double dedup_tolerance = 1e-6;
  /// Stop after this many copies (the result then says truncated).
  Index max_copies = 20000;

  /// True when depth is in 0..64, radius in (0, 1], dedup_tolerance finite and > 0 and
  /// max_copies ≥ 1; otherwise false, with the reason in *why (when why is not null).
  bool is_valid(std::string* why) const;
};

/// One element of the deck group: its word in the generators and the map.
struct CoverElement {
  std::string word;  ///< e.g. "a1 b2^-1"; "" for the identity (E: "a1^2 b1^-1")
  Index length = 0;  ///< word length (E: |m| + |n|)
  Moebius map;       ///< H: the element as a map of the Poincaré disk (identity in E)
  std::array<double, 2> translation{0, 0};  ///< E: the element's translation (x, y); (0, 0) in H
};

/// What universal_cover() returns.
struct CoverResult {
  /// Ok: elements are valid. InvalidArgument: options, a deck result that is not Ok, or positions
  /// that are not #Vc×2 finite values.
  Status status = Status::NotRun;
  std::string message = "not run";  ///< what went wrong; on success how many elements were found
  Geometry geometry = Geometry::Hyperbolic;  ///< the deck result's geometry
  /// Distinct group elements, the identity first, then by word length (BFS order).
  std::vector<CoverElement> elements;
  Index words_generated = 0;  ///< reduced words tried (before deduplication)
  bool truncated = false;     ///< max_copies was reached
};

/// Group elements of the deck group for tiling (see CoverOptions).
CoverResult universal_cover(const CutResult& cut, std::span<const double> positions,
                            const DeckResult& deck, const CoverOptions& options = {});

/// The tiling as one mesh: every element's copy of the disk (cut_faces over the copy's own
/// vertices, positions (x, y, 0)), then vertices on the polygon boundary of different copies that
/// coincide are merged: within hyperbolic distance `merge_tolerance` (H), or euclidean distance
/// merge_tolerance × (polygon diameter) (E); the first copy's vertex is kept. Interior vertices
/// are never merged. Empty mesh when the inputs do not match.
Mesh cover_mesh(const CutResult& cut, std::span<const double> positions, const CoverResult& cover,
                double merge_tolerance = 1e-6);

/// The tiling as an SVG document: H the unit circle and every copy's boundary polygon, E the
/// copies in a box around them; filled with a colour per word length and outlined. Empty string
/// when the inputs do not match.
std::string cover_svg(const CutResult& cut, std::span<const double> positions, const CoverResult& cover);

}  // namespace ricci
