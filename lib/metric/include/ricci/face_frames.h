// ricci — frames of a coarse triangulation: where each face of a surface lies in a coarser
// triangulation of the same surface, for developments that place the coarse triangles instead of
// the faces (layout.h develops them; intrinsic_trace.h's common subdivision gives them).
#pragma once

#include <vector>

#include "ricci/conventions.h"

namespace ricci {

/// Where each face of a surface lies in a coarser triangulation of the same surface — its
/// "frames" — for a layout that develops the coarse triangles instead of the faces themselves.
///
/// A fine triangulation can hold faces that no development through its own edges places well: the
/// common subdivision of two triangulations (intrinsic_trace.h) has vertices a hair apart on one
/// coarse edge and slivers between them, and a vertex placed from a short edge carries the error of
/// its ends times long/short. When every face lies in one coarse face whose triangles are well
/// shaped (the intrinsic Delaunay triangulation of the metric), the layout develops the coarse faces
/// across their own edges (an isometry per coarse face copy, from the two ends of the shared coarse
/// edge: no short edge ever enters) and puts each vertex where its coarse face's isometry takes its
/// model point; the error is that of laying out the coarse triangulation.
///
/// Model points are those of the geometry's model: E the plane z = 0 (x, y, 0); H the hyperboloid
/// x² + y² − z² = −1, z > 0; S the unit sphere; the pole is the origin (E) or (0, 0, 1). Each
/// coarse face has its own frame, fixed by its side lengths: corner 0 at the pole, corner 1 at
/// distance l₂ along +x, corner 2 at distance l₁ from the pole at the angle θ₀ of corner 0
/// (counter-clockwise seen from +z). A face's corners are given in the frame of the coarse face it
/// lies in. Two faces adjacent across an edge of the surface lie in the same coarse face, or the
/// edge lies on the coarse edge between their two coarse faces; the transition between two coarse
/// frames is built from the coarse faces' lengths and angles alone (exact to rounding however
/// short the shared coarse edge).
struct FaceFrames {
  std::vector<Index> face_frame;      ///< #F: the coarse face each face lies in
  std::vector<double> corner_model;   ///< #F×9: the face's corners 0, 1, 2 (x, y, z each) in that frame
  std::vector<double> frame_lengths;  ///< #F(coarse)×3: each coarse face's sides opposite its corners 0, 1, 2
  std::vector<Index> frame_opposite;  ///< #F(coarse)×3: the coarse triangulation's Topology::opposite
};

}  // namespace ricci
