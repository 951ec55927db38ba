// ricci — conformal shape signatures: numbers that depend only on a surface's conformal structure,
// normalized so that two surfaces of the same topology can be compared.
//
// Takes a successful UniformizeResult; gives:
//   closed genus 1   the modulus τ = ω_b/ω_a of the deck translations (a1, b1), with b1 reversed
//                    when needed so that Im τ > 0, reduced by SL(2,ℤ) to the standard fundamental
//                    domain |Re τ| ≤ ½, |τ| ≥ 1, with the conventions Re τ ∈ [−½, ½) and Re τ ≤ 0
//                    on the unit circle (ties within 1e-12 resolved that way), and the reduction
//                    matrix [[a, b], [c, d]] (ad − bc = 1): τ_reduced = (aτ + b)/(cτ + d), i.e.
//                    the reduced generators are ω_b' = a·ω_b + b·ω_a and ω_a' = c·ω_b + d·ω_a.
//   closed genus ≥ 2 the hyperbolic lengths 2·arccosh(|tr|/2) of a fixed list of words in the
//                    canonical generators a1 b1 … ag bg (the same list on every surface of that
//                    genus): every generator, then every two-letter word x·y of generators and
//                    their inverses (y ∉ {x, x^-1}), one representative per class under cyclic
//                    rotation and inversion, in the order the letters a1 a1^-1 b1 b1^-1 a2 …
//                    enumerate them; and the systole among those words (the shortest).
// Each number carries an uncertainty estimated from the deck fits' residuals: a fitted map whose
// images of the side's vertices are off by δ (residual_max, in the geometry's distance) moves a
// translation length by at most 2δ; τ's uncertainty is (|τ|·δ_a + δ_b)/|ω_a| carried through the
// reduction (|dτ'/dτ| = 1/|cτ + d|²).
#pragma once

#include <array>
#include <complex>
#include <string>
#include <vector>

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

struct ConformalSignature {
  /// Ok; InvalidArgument when the result is not Ok or its topology has no signature here (only
  /// closed genus 1 and closed genus ≥ 2 so far; the message says which).
  Status status = Status::NotRun;
  std::string message = "not run";
  Index genus = 0;
  Index boundary_loops = 0;
  bool has_torus = false;
  TorusModulus torus;             ///< valid when has_torus
  std::vector<WordLength> words;  ///< closed genus ≥ 2: generators first, then the two-letter words
  WordLength systole;             ///< the shortest of `words`
};

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
