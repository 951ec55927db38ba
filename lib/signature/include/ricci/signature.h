// ricci — conformal shape signatures: numbers that depend only on a surface's conformal structure,
// normalized so that two surfaces of the same topology can be compared.
//
// Takes a successful UniformizeResult; gives, by topology:
//   closed genus 1   the modulus τ = ω_b/ω_a of the deck translations (a1, b1), with b1 reversed
//                    when needed so that Im τ > 0, reduced by SL(2,ℤ) to the standard fundamental
//                    domain |Re τ| ≤ ½, |τ| ≥ 1, with the conventions Re τ ∈ [−½, ½) and Re τ ≤ 0
//                    on the unit circle (ties within 1e-12 resolved that way), and the reduction
//                    matrix [[a, b], [c, d]] (ad − bc = 1): τ_reduced = (aτ + b)/(cτ + d), i.e.
//                    the reduced generators are ω_b' = a·ω_b + b·ω_a and ω_a' = c·ω_b + d·ω_a.
//   closed genus ≥ 2 (a) the hyperbolic lengths 2·arccosh(|tr|/2) of a fixed list of words in the
//                    canonical generators a1 b1 … ag bg (the same list on every surface of that
//                    genus): every generator, then every two-letter word x·y of generators and
//                    their inverses (y ∉ {x, x^-1}), one representative per class under cyclic
//                    rotation and inversion, in the order the letters a1 a1^-1 b1 b1^-1 a2 …
//                    enumerate them;
//                    (b) the length spectrum's short end and the systole among all cyclically
//                    reduced words up to a length L set by the genus (6 at genus 2, 5 at 3 and 4,
//                    4 at 5 to 8, 3 above; spectrum_word_length) — an upper bound of the surface's
//                    systole, equal to it when a shortest closed geodesic is such a word (with the
//                    short canonical loops the cut picks, it usually is);
//                    (c) Fenchel–Nielsen coordinates (fenchel_nielsen() below): 3g − 3 lengths and
//                    twists of the pants decomposition the canonical basis defines.
//   genus 0, n ≥ 2 boundary loops, circle boundaries (E): the circle domain (CircleDomain
//                    below), normalized by a Möbius map, its Möbius-invariant separations, and for
//                    n = 2 the annulus modulus.
//   hyperbolic with geodesic boundaries (H, BoundaryMode::Geodesic): the length of every boundary
//                    geodesic (the paper's Fig. 9c), the sum of the metric's boundary edge lengths.
// Each number carries an uncertainty (below). Marking: τ is independent of the generators chosen;
// word lengths and Fenchel–Nielsen coordinates refer to the canonical basis the cut found, so they
// compare two surfaces only as far as their canonical bases correspond (a different basis of the
// same surface is a different point of Teichmüller space, the same point of moduli space).
//
// Uncertainties. Deck fits: a fitted map whose images of the side's vertices are off by δ
// (residual_max, in the geometry's distance) moves a translation length by at most 2δ; a word's
// length carries 2 × the sum of its letters' δ; a twist the same over the letters its axes use;
// τ's is (|τ|·δ_a + δ_b)/|ω_a| carried through the reduction (|dτ'/dτ| = 1/|cτ + d|²).
// Arithmetic (genus ≥ 2): products are formed in quad from map + map_low (deck.h), whose letters
// are known to about 2^-106 of their size; a word of k letters has its trace off by about
// k·2^-105·Π(|a| + |b|), which adds 2/sinh(ℓ/2) times that to its length (words whose bound exceeds
// 1e-9 are left out of the spectrum and the systole: canonical loops far from the polygon's
// centre have entries of 10⁷ and more). Circle
// domains: the largest distance of a loop's laid-out vertices from its fitted circle, relative to
// the radius (at rounding: BoundaryMode::Circle makes every loop an inscribed polygon in E, unless
// a loop had to fall back to the length-proportional target), plus the layout's
// relative edge error, carried through the normalization. Boundary geodesics: the sum of
// |K̄ − K| over the loop's vertices (by Gauss–Bonnet the area between the boundary polygon and the
// geodesic, which bounds the difference of their lengths), plus the lengths' rounding.
//
// Distances (signature_distance()): genus 1, the hyperbolic distance between the two τ in the
// modular surface ℍ/PSL(2,ℤ); circle domains, the largest difference of the separation matrices
// minimized over relabellings of the loops; boundary geodesics, the largest difference of the
// sorted lengths; genus ≥ 2, the largest difference of the two length spectra's first K values
// (K the shorter spectrum's size, at most 16; marking-free as far as the word search finds the
// shortest geodesics of both surfaces — a long canonical basis can hide some), and
// as `marked_distance` the Euclidean distance between Fenchel–Nielsen coordinate vectors minimized
// over the g cyclic rotations of the handles (a re-marking that keeps the canonical relation),
// with each twist difference taken modulo the curve's mean length (Dehn twists about the pants
// curves). Other re-markings are not quotiented: two cuts that chose unrelated bases can be far
// apart in the marked distance while the surfaces are conformally equivalent.
#pragma once

#include <array>
#include <cmath>
#include <complex>
#include <span>
#include <string>
#include <vector>

#include "ricci/deck.h"
#include "ricci/status.h"
#include "ricci/uniformize.h"

namespace ricci {

/// Closed genus 1: the flat torus's modulus.
struct TorusModulus {
  std::complex<double> tau_computed;  ///< ω_b/ω_a of the computed generators (b1 reversed if needed)
  bool b_reversed = false;            ///< b1 was reversed to make Im τ > 0
  std::complex<double> tau;           ///< reduced to the standard fundamental domain
  std::array<long long, 4> reduction{1, 0, 0, 1};  ///< a, b, c, d: tau = (a·τ_computed + b)/(c·τ_computed + d)
  double uncertainty = 0;             ///< estimated |error| of tau
};

/// A word in the canonical generators and its hyperbolic translation length.
struct WordLength {
  std::string word;          ///< letters separated by spaces: "a1", "a1 b2^-1"
  double length = 0;         ///< 2·arccosh(|tr|/2) of the word's SU(1,1) matrix (0 if not hyperbolic)
  double uncertainty = 0;    ///< 2 × the summed residual_max of its letters' fits
};

/// Fenchel–Nielsen coordinates of a closed surface of genus g ≥ 2 from its canonical generators
/// A1 B1 … Ag Bg, whose relation is Π [A_i^-1, B_i] = 1 (deck.h). With c_i = A_i^-1 B_i A_i B_i^-1
/// (the boundary of handle i; c_1 ⋯ c_g = 1) and d_k = c_1 ⋯ c_k, the pants curves are, in order,
///   a1 … ag          (A_i; the handles' a-loops)
///   c1 … cg          (c_i; for g = 2 only c1, since c2 = c1^-1)
///   d2 … d(g−2)      (d_k, g ≥ 4; they cut the sphere with holes c1 … cg into pants)
/// 3g − 3 curves. Pants: handle i cut along a_i is a pair of pants with boundaries A_i^-1,
/// B_i A_i B_i^-1, c_i; the planar pants are ⟨d_k, c_(k+1)⟩ (d_1 = c_1) with product d_(k+1).
/// Length ℓ = 2·arccosh(|tr|/2). Twist t: along the axis of the curve's element, oriented by it,
/// the signed hyperbolic distance from the foot of the common perpendicular to the seam partner
/// on its first side to that on its second side:
///   a_i   partners c_i (first side) and B_i^-1 c_i B_i (second side, across a_i);
///   c_i   partners A_i (handle side) and the planar pants' other boundary c_2 (for c_1), d_(i−1)
///         (c_i, 2 ≤ i ≤ g − 1) or d_(g−2) (c_g); for g = 2, A_2;
///   d_k   partners c_k and c_(k+1).
/// A Dehn twist about a curve (e.g. B_i ↦ B_i A_i for a_i) changes that curve's twist by ±ℓ and
/// no other coordinate. (ℓ, t) of these curves are global coordinates of the marked surface in
/// Teichmüller space.
struct FenchelNielsen {
  /// Ok; InvalidArgument (genus < 2, wrong generator count, a curve that is not hyperbolic, or
  /// two axes that should be disjoint cross: not the generators of a closed surface).
  Status status = Status::NotRun;
  std::string message = "not run";
  std::vector<std::string> curves;          ///< "a1", …, "c1", …, "d2", …
  std::vector<std::string> words;           ///< each curve as a word in the generators
  std::vector<double> lengths;              ///< ℓ per curve
  std::vector<double> twists;               ///< t per curve
  std::vector<double> length_uncertainty;   ///< per curve (from `residuals`; 0 without)
  std::vector<double> twist_uncertainty;    ///< per curve
};

/// Fenchel–Nielsen coordinates (above) of the canonical generators A1 B1 … (2g maps of the disk,
/// deck.h's convention). `residuals`: per generator, its fit's residual_max (empty: none), for the
/// uncertainties; `low`: per generator, DeckGenerator::map_low (empty: none) — products are formed
/// in quad from map + map_low. Never throws.
FenchelNielsen fenchel_nielsen(std::span<const Moebius> generators, std::span<const double> residuals = {},
                               std::span<const Moebius> low = {});

/// One boundary loop of a circle domain, after normalization.
struct BoundaryCircle {
  Index vertex = kInvalid;          ///< the loop's smallest vertex index (the input's numbering)
  double length_3d = 0;             ///< the loop's length in the input (its units)
  std::complex<double> centre;      ///< normalized centre
  double radius = 0;                ///< normalized radius
  double fit_residual = 0;          ///< max |dist − r|/r of its laid-out vertices to the fitted circle
  double uncertainty = 0;           ///< of centre and radius (normalized units)
};

/// The circle domain of a genus-0 surface with n ≥ 2 boundary loops (E, circle boundaries).
/// Normalization (a documented rule):
///   - the outer circle is the loop with the longest 3D length, mapped to the unit circle;
///   - the first inner circle is the loop with the least separation from it (the conformally
///     largest hole seen from the outer loop), made concentric: centred at 0;
///   - the other inner circles follow by decreasing normalized radius, and the first of them is
///     rotated onto the positive real axis (n ≥ 3).
/// Ties go to the smaller `vertex`: lengths and separations within 1e-9 relative, equal radii.
/// circles[0] is the outer circle, circles[1] the first inner one.
struct CircleDomain {
  std::vector<BoundaryCircle> circles;
  /// n×n row-major in the order of `circles`: σ_ij = arccosh(I_ij), I the inversive distance of
  /// circles i and j (Möbius-invariant; for two concentric circles log(R/r), i.e. 2π × the modulus
  /// of the annulus between them); 0 on the diagonal.
  std::vector<double> separation;
  std::vector<double> separation_uncertainty;  ///< n×n
  /// n = 2: the annulus modulus log(R/r)/2π = σ_01/2π (0 otherwise), and its uncertainty.
  double annulus_modulus = 0;
  double annulus_modulus_uncertainty = 0;
};

/// A boundary geodesic of a hyperbolic surface with geodesic boundaries.
struct BoundaryGeodesic {
  Index vertex = kInvalid;   ///< the loop's smallest vertex index (the input's numbering)
  double length_3d = 0;      ///< the loop's length in the input
  double length = 0;         ///< hyperbolic length of the boundary geodesic
  double uncertainty = 0;
};

struct ConformalSignature {
  /// Ok; InvalidArgument when the result is not Ok or has no signature here (a disk, a closed
  /// sphere, genus ≥ 1 with boundary in E, or a target other than the uniformization's; the
  /// message says which); NumericalFailure when the data are degenerate (e.g. parallel torus
  /// translations).
  Status status = Status::NotRun;
  std::string message = "not run";
  Index genus = 0;
  Index boundary_loops = 0;
  bool has_torus = false;
  TorusModulus torus;             ///< valid when has_torus
  std::vector<WordLength> words;  ///< closed genus ≥ 2: generators first, then the two-letter words
  WordLength systole;             ///< closed genus ≥ 2: the shortest word of the spectrum search (below)
  /// Closed genus ≥ 2: the length spectrum as far as the cyclically reduced words of length
  /// ≤ spectrum_word_length that are not proper powers reach: their distinct lengths (within 1e-9
  /// relative), ascending, at most 32. Multiplicities are dropped. Marking-free as far as the
  /// search finds the shortest geodesics.
  std::vector<double> spectrum;
  /// The word length searched: the largest L ≤ 8 for which the reduced words of length ≤ L number
  /// at most 10⁶ (genus 2: 6; genus 3 and 4: 5; genus 5 to 8: 4; genus 9 to 25: 3).
  int spectrum_word_length = 0;
  /// Closed genus ≥ 2: the canonical generators A1 B1 … (deck.h) and their fits' residual_max,
  /// for the marked distance (re-marked by handle rotations).
  std::vector<Moebius> generators;
  std::vector<Moebius> generator_low;  ///< their DeckGenerator::map_low (zero when fitted in double)
  std::vector<double> generator_residuals;
  bool has_fenchel_nielsen = false;
  FenchelNielsen fenchel_nielsen;  ///< closed genus ≥ 2
  bool has_circle_domain = false;
  CircleDomain circle_domain;      ///< genus 0 with n ≥ 2 loops, E, circle boundaries
  std::vector<BoundaryGeodesic> boundary_geodesics;  ///< H with geodesic boundaries, one per loop
};

/// The closed genus ≥ 2 part of the signature (words, systole, spectrum, Fenchel–Nielsen) of
/// canonical generators A1 B1 … given directly (deck.h's relation Π [A_i^-1, B_i] = 1), e.g. a
/// Fuchsian group of one's own or a re-marked one. `residuals`, `low`: per generator (empty: none),
/// as fenchel_nielsen().
/// Status as fenchel_nielsen(). Never throws.
ConformalSignature hyperbolic_signature(std::span<const Moebius> generators, std::span<const double> residuals = {},
                                        std::span<const Moebius> low = {});

/// How far apart two signatures are (see the header comment).
struct SignatureDistance {
  /// Ok; InvalidArgument when either signature is not Ok or they are of different kinds (genus,
  /// number of loops; the message says which).
  Status status = Status::NotRun;
  std::string message = "not run";
  std::string kind;        ///< "modular" (genus 1), "circle_domain", "boundary_geodesics", "length_spectrum"
  double distance = 0;
  double uncertainty = 0;  ///< from the two signatures' uncertainties
  /// Closed genus ≥ 2 with generators in both: the Fenchel–Nielsen distance (header comment);
  /// NaN otherwise.
  double marked_distance = NAN;
  double marked_uncertainty = NAN;
};

/// The distance between two signatures of the same kind (header comment). Symmetric, 0 for equal
/// signatures. Never throws.
SignatureDistance signature_distance(const ConformalSignature& a, const ConformalSignature& b);

/// The hyperbolic distance between τ1 and τ2 in ℍ/PSL(2,ℤ): min over γ ∈ PSL(2,ℤ) of
/// d_ℍ(τ1, γτ2), exactly: the cosets γ = T^k·γ₀ are enumerated by their bottom row (c, d),
/// coprime, for as long as Im(γτ2) = Im τ2/|cτ2 + d|² can still give a point nearer than the best
/// found (d_ℍ(z, w) ≥ |log(Im z/Im w)|), and within a coset the translates nearest to Re τ1.
/// +∞ when an argument is not in ℍ.
double modular_distance(std::complex<double> tau1, std::complex<double> tau2);

/// The signature of a successful uniformize() result. Never throws.
ConformalSignature conformal_signature(const UniformizeResult& r);

/// Reduces τ (Im τ > 0) to the standard fundamental domain (conventions above). The matrix is
/// returned in `reduction`; false when Im τ ≤ 0 or τ is not finite.
bool reduce_modulus(std::complex<double> tau, std::complex<double>& reduced, std::array<long long, 4>& reduction);

/// The two-letter word list of genus g (generators first), as written in WordLength::word, and
/// each word's letters as generator indices 0 … 2g−1 (a_i = 2i, b_i = 2i+1) with a sign (−1 for
/// the inverse). Depends on g only.
std::vector<std::vector<std::pair<int, int>>> signature_words(Index genus, std::vector<std::string>* names = nullptr);

}  // namespace ricci
