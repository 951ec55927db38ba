// Layout internals shared with the atlas (layout_atlas.cpp); not part of the public API.
#pragma once

#include <complex>
#include <span>
#include <vector>

#include "ricci/layout.h"

namespace ricci::detail {

/// How far rounding the coordinates of two points of the plane (E) or the Poincaré disk (H) to
/// double can move their distance (Layout::rounding_floor is this over the edge's length).
double rounding_drift_planar(Geometry g, std::complex<double> a, std::complex<double> b);

/// Lays out the faces f with owner[f] == label (connected across edges) by propagation from face
/// `seed`, placed as layout_disk() places its seed (corner 0 at the origin / north pole, corner 1
/// along +x), without normalising. positions is resized to #V×dims (zeros) and holds the placed
/// vertices, listed in `touched`. False with `out` naming the vertex when one leaves the range of
/// double precision.
bool propagate_faces(const Topology& t, Geometry g, std::span<const double> l, Index seed,
                     std::span<const Index> owner, Index label, std::vector<double>& positions,
                     std::vector<Index>& touched, Layout& out);

}  // namespace ricci::detail
