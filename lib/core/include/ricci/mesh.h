// ricci — the triangle mesh as flat buffers (structure of arrays). See conventions.h.
#pragma once

#include <cstdint>
#include <vector>

#include "ricci/conventions.h"

namespace ricci {

/// A triangle mesh in flat row-major buffers. Plain data: no invariants are enforced here; use
/// validate_mesh() (validate.h) to check and repair it, and build_topology() (topology.h) for
/// connectivity.
struct Mesh {
  /// #V×3 vertex positions, positions[3*v + d].
  std::vector<double> positions;
  /// #F×3 vertex indices, faces[3*f + k] = vertex of corner 3f+k, counter-clockwise.
  std::vector<Index> faces;
  /// Optional texture coordinates, #T×2, texcoords[2*t + d]. Empty when the mesh has none.
  std::vector<double> texcoords;
  /// Optional per-corner texture coordinate index into `texcoords`, #F×3. Either empty or of
  /// the same size as `faces` (a file with texture indices on only some faces loads with none).
  std::vector<Index> corner_texcoords;

  /// #V = positions.size() / 3 (rounded down).
  Index num_vertices() const { return static_cast<Index>(positions.size() / 3); }
  /// #F = faces.size() / 3 (rounded down).
  Index num_faces() const { return static_cast<Index>(faces.size() / 3); }
  /// #T = texcoords.size() / 2 (rounded down).
  Index num_texcoords() const { return static_cast<Index>(texcoords.size() / 2); }
  /// True when corner_texcoords is non-empty (the sizes are not checked here).
  bool has_texcoords() const { return !corner_texcoords.empty(); }
};

}  // namespace ricci
