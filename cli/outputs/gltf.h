// ricci command-line tool — the textured surface as binary glTF 2.0 (.glb), written with tinygltf.
//
// Takes a triangle mesh (#V×3 positions, #F×3 faces), two texture coordinates per corner (the
// layout, or the sphere's Mercator projection) and PNG bytes; gives one self-contained .glb:
// vertices split where a vertex's corners disagree on their texture coordinates (the seams of
// the cut), float32 POSITION (with min/max), NORMAL (area-weighted, from the input's faces) and
// TEXCOORD_0 (the coordinates scaled so that the texture repeats `repeats` times across their
// bounding box's longer side), uint32 indices, a double-sided material whose base colour is the
// embedded PNG with a repeating, nearest-neighbour sampler. Deterministic; no printing.
#pragma once

#include <span>
#include <string>

#include "ricci/conventions.h"

namespace ricci_cli {

struct GlbResult {
  std::string bytes;    ///< the .glb file; empty on failure
  std::string message;  ///< why it failed ("" on success)
  std::int64_t vertices = 0;  ///< vertices written (after splitting at the seams)
};

GlbResult textured_glb(std::span<const double> positions, std::span<const ricci::Index> faces,
                       std::span<const double> corner_uv, const std::string& png, double repeats);

/// PNG bytes of a square checkerboard texture of 2×2 checks (`pixels` per side), the colours of
/// the checkerboard pictures; repeated by the sampler.
std::string checker_texture_png(int pixels = 64);

}  // namespace ricci_cli
