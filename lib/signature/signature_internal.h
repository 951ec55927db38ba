// ricci — internals of the signature: the parts for surfaces with boundary (signature_boundary.cpp),
// called by conformal_signature(), each filling its part of `out` and returning true, or setting
// out.status and out.message and returning false; and the quad helpers of signature_fn.cpp.
#pragma once

#include "moebius_quad.h"
#include "ricci/signature.h"

namespace ricci {

/// Genus 0, n ≥ 2 loops, E, circle boundaries: out.circle_domain.
bool circle_domain_signature(const UniformizeResult& r, ConformalSignature& out);
/// H with geodesic boundaries: out.boundary_geodesics.
bool boundary_geodesic_signature(const UniformizeResult& r, ConformalSignature& out);

/// Generator k in quad: generators[k] + low[k] (low may be empty), normalized.
detail::MoebiusQ quad_generator(std::span<const Moebius> generators, std::span<const Moebius> low, std::size_t k);
/// 2·arccosh(|Re a|) of the normalized map (0 unless hyperbolic), from quad entries.
double translation_length_q(const detail::MoebiusQ& m);
/// |a| + |b| of a map: the size its entries bring into a product.
double matrix_norm(const detail::MoebiusQ& m);
/// Bound on the error of a translation length from the arithmetic: the letters are known to about
/// 2^-106 of their size (map + map_low) and every quad product rounds at 2^-113, so a word of
/// `letters` letters has its trace off by about letters·2^-105·Π‖letter‖ (`norm_product`), and
/// dℓ = 2·d|Re a|/√(|Re a|² − 1). +∞ when the length is 0.
double length_rounding(double length, double norm_product, int letters);

}  // namespace ricci
