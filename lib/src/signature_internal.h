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

}  // namespace ricci
