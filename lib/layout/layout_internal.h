// Layout internals shared with the atlas (layout_atlas.cpp) and the development by coarse frames
// (layout_frames.cpp); not part of the public API.
#pragma once

#include <array>
#include <complex>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "model_geometry.h"
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

// angle_from_lengths(): model_geometry.h.

/// An isometry of the model as a 3×3 row-major matrix (layout_frames.cpp: E affine on (x, y, 1),
/// H Lorentz, S a rotation).
using M3 = std::array<double, 9>;

/// propagate_faces() by coarse frames (FrameDevelopment restricted to the faces of `label`, the seed
/// face's corner 0 at the base point). drift (#V, H): the drift estimate of the map of the face
/// that placed each touched vertex (FrameDevelopment::drift()), 0 elsewhere and in E. H develops
/// with keep_going: a vertex it cannot resolve gets drift +∞ (its faces are beyond the chart)
/// instead of failing the call.
bool propagate_faces_by_frames(const Topology& t, Geometry g, const FaceFrames& frames, Index seed,
                               std::span<const Index> owner, Index label, std::vector<double>& positions,
                               std::vector<Index>& touched, std::vector<double>& drift, Layout& out);

/// The product a·b of two isometries (apply b first).
M3 multiply(const M3& a, const M3& b);

/// Empty when `frames` fit the faces of t (sizes, coarse face indices, finite model points);
/// otherwise why not.
std::string check_frames(const Topology& t, const FaceFrames& frames);

/// The Lorentz matrix of the Poincaré disk map z ↦ rot·(z − c)/(1 − c̄ z) (|rot| = 1, |c| < 1).
M3 disk_map_matrix(std::complex<double> c, std::complex<double> rot);

/// One development of a surface by its coarse frames (layout.h, FaceFrames): from the seed face,
/// whose coarse face is placed by `seed_map`, every face reached across an edge takes the isometry
/// of its coarse face — its neighbour's when both lie in one coarse face, else the neighbour's
/// composed with the transition across the coarse edge between them — and places its corners not
/// placed yet. Faces are taken in the order of the fewest coarse edges crossed (Layout::depth: the
/// most), first in first out. Positions as layout_disk() writes them (E, H: 2 per vertex, the
/// plane and the Poincaré disk; S: 3). Precondition: check_frames() is empty.
class FrameDevelopment {
 public:
  FrameDevelopment(const Topology& t, Geometry g, const FaceFrames& frames, Index seed, bool keep_going);
  /// The seed's map: the seed face's corner 0 at the base point, the farthest corner of its coarse
  /// face along +x.
  M3 seed_map() const;
  /// Develops every face reachable from the seed into x (#V×dims). False with `out` naming the
  /// element when a vertex leaves double range (unless keep_going: then it sits at a resolved
  /// corner of its face and is counted in out.unresolved_vertices) or two adjacent faces lie in
  /// coarse faces that share no coarse edge.
  bool run(std::vector<double>& x, const M3& seed_map, Layout& out);
  Index unplaced() const;  ///< vertices no face placed (none on a connected surface)
  /// Develops only the faces f with owner[f] == label (connected across edges to the seed).
  void restrict_to(std::span<const Index> owner, Index label) {
    owner_ = owner;
    label_ = label;
  }
  /// The vertices the last run placed, in the order it placed them.
  const std::vector<Index>& touched() const { return touched_; }
  /// H: the drift estimate of each taken face's map (see drift_); empty in E and S.
  const std::vector<double>& drift() const { return drift_; }
  /// The face that placed each touched vertex.
  const std::vector<Index>& placed_by() const { return placed_by_; }
  /// keep_going: the vertices the last run could not resolve (beyond double range, or placed by a
  /// face whose map drifted too far), in the order it met them.
  const std::vector<Index>& lost() const { return lost_; }

 private:
  /// The corners k of from_corner's coarse face and ko of to_face's whose sides are the coarse
  /// edge the disk edge opposite from_corner lies on; false when they share none.
  bool shared_side(Index from_corner, Index to_face, int& k, int& ko) const;
  M3 transition(Index from_corner, Index to_face) const;
  Moebius transition_h(Index from_corner, Index to_face) const;
  bool place(Index f, std::vector<double>& x, Layout& out);

  const Topology& t_;
  Geometry g_;
  const FaceFrames& fr_;
  Index seed_;
  bool keep_going_;
  std::span<const Index> owner_;
  Index label_ = 0;
  std::vector<Index> touched_, placed_by_, lost_;
  std::vector<M3> map_;
  /// H: each face's coarse isometry as an SU(1,1) map of the disk (map_ is not used). A product
  /// of Lorentz matrices reaching distance r has entries e^r and drifts off the Lorentz group by
  /// ε·e^{2r} a product (depth 100 at r = 8: faces' edges off by 2e-7); SU(1,1) entries are
  /// e^{r/2} and each product is renormalised to an exact isometry.
  std::vector<Moebius> mob_;
  /// H: an estimate of how far rounding has moved each face's map, in the face's own frame: each
  /// product at distance r from the origin adds about ε·e^r (2ε·(|a| + |b|)·|b|), in quadrature along
  /// the chain, and a face reached through a far region keeps what it gathered there when the
  /// development comes back (its corners then resolve in double but sit off the faces developed
  /// along other paths).
  std::vector<double> drift_;
  std::vector<Index> dist_, via_;  // via_[f]: the corner of the face before f across whose opposite edge f was reached
  std::vector<std::uint8_t> taken_, placed_;
};

}  // namespace ricci::detail
