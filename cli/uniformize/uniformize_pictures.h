// ricci command-line driver — the pictures of `ricci uniformize`: the fundamental domain (and,
// in H, the canonical polygon) with paired sides in one colour, the universal cover tiling, the
// surface rendered with a checkerboard from its parameterization from three viewpoints, the
// histogram of corner-angle ratios and the convergence plots. Pure functions of the result.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "ricci/deck.h"
#include "ricci/mesh.h"
#include "ricci/uniformize.h"

namespace ricci_cli {

/// One picture: file stem, title and caption for the report, PNG bytes and SVG text (may be empty).
struct NamedPicture {
  std::string id;
  std::string title;
  std::string caption;
  std::string png;
  std::string svg;
};

/// How far a texture map is from conformal: per face, the ratio σ_max/σ_min of the singular
/// values of the linear map from the 3D triangle (in its plane) to its texture triangle (1 for a
/// similarity: square checks stay square). Faces with a degenerate triangle on either side are
/// skipped.
struct ConformalDistortion {
  ricci::Index faces = 0;  ///< faces measured
  double mean = 0, median = 0, p95 = 0, max = 0;
};
ConformalDistortion conformal_distortion(std::span<const double> positions, std::span<const ricci::Index> faces,
                                         std::span<const double> corner_uv);

/// Per-corner texture coordinates (2 per corner of `surface`): the layout through the cut (E, H),
/// or the Mercator projection of the sphere layout (conformal), longitudes unwrapped per face.
std::vector<double> corner_uv(const ricci::UniformizeResult& r, const ricci::Mesh& surface);

/// The pictures of a successful run. `surface` is the mesh written as mesh.obj (with texture
/// coordinates when the result has a cut); `cover` the tiling (nullptr: no cover picture).
/// `distortion`, when given, receives conformal_distortion() of the checkerboard's texture map
/// (E and H layouts).
std::vector<NamedPicture> uniformize_pictures(const ricci::UniformizeResult& r, const ricci::Mesh& surface,
                                              const ricci::CoverResult* cover, ConformalDistortion* distortion);

}  // namespace ricci_cli
