// Layout by coarse frames (layout.h, FaceFrames): the development of a surface whose faces each
// lie in a face of a coarser, well-shaped triangulation of it.
//
// Takes: a disk (or a closed genus-0 surface), its FaceFrames, a seed face and the isometry of the
// seed's coarse face. Gives: positions of every vertex (E plane, H Poincaré disk, S unit sphere),
// from one development of the coarse faces across the faces' adjacency.
//
// Isometries are 3×3 matrices on model points (E: on (x, y, 1), i.e. affine rigid motions; H:
// Lorentz transformations of (x, y, z) with x² + y² − z²; S: rotations). A point P with a unit
// direction at it has the frame F = [T N P]: T the direction, N = T turned a quarter to the left
// (counter-clockwise seen from +z), P itself (E: (Px, Py, 1)); F maps the pole's standard frame
// onto it, so F·F'⁻¹ is the isometry taking P' to P and its direction to P's. In a coarse face's
// own frame (corner 0 at the pole, corner 1 along +x) the frame at each corner, pointing along
// each of its sides, is a product of rotations about the pole R(φ) and translations along +x T(r)
// by the face's angles and lengths — exact to rounding however short the sides. Crossing a coarse
// edge from coarse face f to g, the frames at the same end of the shared edge, pointing along it,
// in f and in g give the transition from g's frame into f's: only coarse lengths and angles —
// never the faces' own, possibly tiny, edges, nor differences of model points — set it. In H the
// developed isometries are composed as SU(1,1) maps of the Poincaré disk instead (the same
// rotations and translations; entries e^{r/2} at distance r, renormalised after each product),
// whose products stay exact isometries far out; the seed's 3×3 map is converted once.
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <deque>
#include <limits>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include "layout_internal.h"
#include "model_geometry.h"

namespace ricci::detail {

namespace {

using model::P3;
/// Rounding a renormalised SU(1,1) product [a b; b̄ ā] moves the point its map takes the origin
/// to by about 2ε·(|a| + |b|)·|b| in that point's own frame (ε·e^r at distance r from the
/// origin, ε·2|b| near it); independent roundings add in quadrature along a chain.
constexpr double kFrameRounding = 2 * 0x1p-53;
/// A face whose map has drifted beyond this fraction of its coarse face's shortest side is not
/// resolved by the development: two charts disagree there by more than the atlas's transitions
/// may (AtlasOptions::max_transition_error).
constexpr double kDriftLimit = 1e-6;
using Cx = std::complex<double>;

P3 apply(Geometry g, const M3& a, P3 m) {
  if (g == Geometry::Euclidean) m[2] = 1;
  return {a[0] * m[0] + a[1] * m[1] + a[2] * m[2], a[3] * m[0] + a[4] * m[1] + a[5] * m[2],
          a[6] * m[0] + a[7] * m[1] + a[8] * m[2]};
}

// F(P, Q) (columns T, N, P); NaN entries when P and Q coincide in double.
M3 frame_of(Geometry g, const P3& p, const P3& q) {
  P3 t, n, o = p;
  switch (g) {
    case Geometry::Euclidean: {
      const double dx = q[0] - p[0], dy = q[1] - p[1], s = std::hypot(dx, dy);
      t = {dx / s, dy / s, 0};
      n = {-t[1], t[0], 0};
      o = {p[0], p[1], 1};
      break;
    }
    case Geometry::Hyperbolic: {
      t = model::add(q, model::mul(p, model::lorentz(p, q)));  // q's part tangent at p
      t = model::mul(t, 1 / std::sqrt(model::lorentz(t, t)));
      n = model::cross(p, t);
      n[2] = -n[2];
      break;
    }
    case Geometry::Spherical: {
      t = model::sub(q, model::mul(p, model::dot(p, q)));
      t = model::mul(t, 1 / std::sqrt(model::dot(t, t)));
      n = model::cross(p, t);
      break;
    }
  }
  return {t[0], n[0], o[0], t[1], n[1], o[1], t[2], n[2], o[2]};
}

// F⁻¹ of a frame: E the inverse rigid motion; H J Fᵀ J (J = diag(1, 1, −1)); S Fᵀ.
M3 frame_inverse(Geometry g, const M3& f) {
  M3 r{f[0], f[3], f[6], f[1], f[4], f[7], f[2], f[5], f[8]};  // Fᵀ
  if (g == Geometry::Euclidean) {
    // [R t; 0 1]⁻¹ = [Rᵀ −Rᵀt; 0 1]
    const double tx = f[2], ty = f[5];
    return {f[0], f[3], -(f[0] * tx + f[3] * ty), f[1], f[4], -(f[1] * tx + f[4] * ty), 0, 0, 1};
  }
  if (g == Geometry::Hyperbolic) {
    r[2] = -r[2];
    r[5] = -r[5];
    r[6] = -r[6];
    r[7] = -r[7];
  }
  return r;
}

bool finite(const M3& a) {
  return std::all_of(a.begin(), a.end(), [](double v) { return std::isfinite(v); });
}

P3 model_point(const std::vector<double>& buffer, Index k) {
  return {buffer[3 * static_cast<std::size_t>(k)], buffer[3 * static_cast<std::size_t>(k) + 1],
          buffer[3 * static_cast<std::size_t>(k) + 2]};
}

// Rotation about the pole by φ, and translation from the pole along +x by r.
M3 rotation(double phi) {
  const double c = std::cos(phi), s = std::sin(phi);
  return {c, -s, 0, s, c, 0, 0, 0, 1};
}
M3 translation(Geometry g, double r) {
  switch (g) {
    case Geometry::Euclidean: return {1, 0, r, 0, 1, 0, 0, 0, 1};
    case Geometry::Hyperbolic: return {std::cosh(r), 0, std::sinh(r), 0, 1, 0, std::sinh(r), 0, std::cosh(r)};
    case Geometry::Spherical: return {std::cos(r), 0, std::sin(r), 0, 1, 0, -std::sin(r), 0, std::cos(r)};
  }
  return {};
}

// A coarse face's lengths (opposite corners 0, 1, 2) and angles.
struct CoarseFace {
  double l[3], theta[3];
};
CoarseFace coarse_face(Geometry g, const FaceFrames& fr, Index f) {
  CoarseFace c;
  for (int k = 0; k < 3; ++k) c.l[k] = fr.frame_lengths[3 * static_cast<std::size_t>(f) + static_cast<std::size_t>(k)];
  for (int k = 0; k < 3; ++k) c.theta[k] = angle_from_lengths(g, c.l[k], c.l[(k + 1) % 3], c.l[(k + 2) % 3]);
  return c;
}

// The frame at corner k of coarse face `face` (in its own frame), pointing along its side to
// corner next(k) (towards_next) or prev(k).
M3 corner_frame(Geometry g, const CoarseFace& c, int k, bool towards_next) {
  constexpr double pi = std::numbers::pi;
  switch (k) {
    case 0: return towards_next ? M3{1, 0, 0, 0, 1, 0, 0, 0, 1} : rotation(c.theta[0]);
    case 1: return multiply(translation(g, c.l[2]), rotation(towards_next ? pi - c.theta[1] : pi));
    default:
      return multiply(multiply(rotation(c.theta[0]), translation(g, c.l[1])), rotation(towards_next ? pi : pi + c.theta[2]));
  }
}

// corner_frame() as a map of the Poincaré disk (H): rotations about the origin and translations
// along +x by the same angles and lengths.
Moebius corner_frame_h(const CoarseFace& c, int k, bool towards_next) {
  constexpr double pi = std::numbers::pi;
  switch (k) {
    case 0: return towards_next ? Moebius{} : Moebius::rotation(c.theta[0]);
    case 1: return Moebius::translation_real(c.l[2]) * Moebius::rotation(towards_next ? pi - c.theta[1] : pi);
    default:
      return Moebius::rotation(c.theta[0]) * Moebius::translation_real(c.l[1]) *
             Moebius::rotation(towards_next ? pi : pi + c.theta[2]);
  }
}

// The disk map of a Lorentz matrix: the pole to the image of its point column P at w, and the +x
// direction there to the image of its T column.
Moebius moebius_of_lorentz(const M3& m) {
  const Cx p(m[2], m[5]), t(m[0], m[3]);
  const double pt = m[8], tt = m[6];
  const Cx w = p / (1 + pt);
  const Cx dir = t * (1 + pt) - p * tt;
  return (Moebius::to_origin(w).inverse() * Moebius::rotation(std::arg(dir))).normalized();
}

bool finite(const Moebius& m) {
  return std::isfinite(m.a.real()) && std::isfinite(m.a.imag()) && std::isfinite(m.b.real()) && std::isfinite(m.b.imag());
}

// Corner k's model point in its coarse face's frame.
P3 corner_point(Geometry g, const CoarseFace& c, int k) {
  if (k == 0) return model::pole(g);
  return k == 1 ? model::polar(g, c.l[2], 0) : model::polar(g, c.l[1], c.theta[0]);
}

// How far a and b lie off the coarse side P → Q (E: distances to its line; H, S: |det| of the
// plane through the origin spanned by P, Q, relative).
double off_side(Geometry g, const P3& p, const P3& q, const P3& a, const P3& b) {
  if (g == Geometry::Euclidean) {
    const double dx = q[0] - p[0], dy = q[1] - p[1], s = std::hypot(dx, dy);
    auto d = [&](const P3& x) { return std::abs(dx * (x[1] - p[1]) - dy * (x[0] - p[0])) / s; };
    return d(a) + d(b);
  }
  const P3 n = model::cross(p, q);
  const double nn = std::sqrt(model::dot(n, n));
  auto d = [&](const P3& x) { return std::abs(model::dot(n, x)) / (nn * std::sqrt(model::dot(x, x))); };
  return d(a) + d(b);
}

}  // namespace

M3 multiply(const M3& a, const M3& b) {
  M3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
  return c;
}

std::string check_frames(const Topology& t, const FaceFrames& fr) {
  const auto nf = static_cast<std::size_t>(t.num_faces);
  if (fr.face_frame.size() != nf || fr.corner_model.size() != 9 * nf)
    return "frames: face_frame and corner_model must have #F = " + std::to_string(nf) + " and 9·#F entries";
  const std::size_t nc = fr.frame_opposite.size() / 3;
  if (fr.frame_opposite.size() != 3 * nc || fr.frame_lengths.size() != 3 * nc)
    return "frames: frame_opposite and frame_lengths must have 3 entries per coarse face";
  for (std::size_t f = 0; f < nf; ++f)
    if (fr.face_frame[f] < 0 || static_cast<std::size_t>(fr.face_frame[f]) >= nc)
      return "frames: face " + std::to_string(f) + " names coarse face " + std::to_string(fr.face_frame[f]) +
             ", not one of the " + std::to_string(nc);
  for (Index o : fr.frame_opposite)
    if (o != kInvalid && (o < 0 || static_cast<std::size_t>(o) >= 3 * nc))
      return "frames: a coarse opposite corner is out of range";
  for (double v : fr.corner_model)
    if (!std::isfinite(v)) return "frames: a model point is not finite";
  for (double v : fr.frame_lengths)
    if (!(std::isfinite(v) && v > 0)) return "frames: a coarse side length is not a positive finite number";
  return {};
}

M3 disk_map_matrix(Cx c, Cx rot) {
  // z ↦ (z − c)/(1 − c̄ z) is the translation along the line through 0 and c that takes c to the
  // origin: R(arg c)·T(−r)·R(−arg c) with r = 2 atanh|c|, cosh r = (1 + a²)/(1 − a²) and
  // sinh r = 2a/(1 − a²) (a = |c|); then the rotation by rot. Closed form: frames of hyperboloid
  // points far out would cancel their t² − x² − y² = 1 (ε·e^{2r} off the Lorentz group).
  const double a = std::abs(c), d = (1 - a) * (1 + a), phi = std::arg(c);
  const M3 move{(1 + a * a) / d, 0, -2 * a / d, 0, 1, 0, -2 * a / d, 0, (1 + a * a) / d};
  return multiply(rotation(std::arg(rot) + phi), multiply(move, rotation(-phi)));
}

FrameDevelopment::FrameDevelopment(const Topology& t, Geometry g, const FaceFrames& frames, Index seed,
                                   bool keep_going)
    : t_(t), g_(g), fr_(frames), seed_(seed), keep_going_(keep_going) {
  const auto nf = static_cast<std::size_t>(t.num_faces);
  if (g == Geometry::Hyperbolic) {
    mob_.resize(nf);
    drift_.resize(nf);
  } else {
    map_.resize(nf);
  }
  dist_.resize(nf);
  via_.resize(nf);
  taken_.resize(nf);
  placed_.resize(static_cast<std::size_t>(t.num_vertices));
}

M3 FrameDevelopment::seed_map() const {
  // The seed face's corner 0 at the base point, the direction towards the farthest corner of its
  // coarse face along +x (a frame of two points a coarse side apart: a sliver's own corners could
  // round onto one point, or leave the tangent off the model).
  const P3 m0 = model_point(fr_.corner_model, 3 * seed_);
  const CoarseFace c = coarse_face(g_, fr_, fr_.face_frame[seed_]);
  P3 far = corner_point(g_, c, 0);
  for (int k = 1; k < 3; ++k)
    if (model::distance(g_, m0, corner_point(g_, c, k)) > model::distance(g_, m0, far)) far = corner_point(g_, c, k);
  const M3 f = frame_of(g_, m0, far);
  if (finite(f)) return frame_inverse(g_, f);
  return {1, 0, 0, 0, 1, 0, 0, 0, 1};
}

bool FrameDevelopment::shared_side(Index from_corner, Index to_face, int& k, int& ko) const {
  const Index from_face = corner_face(from_corner);
  const Index cf = fr_.face_frame[from_face], cg = fr_.face_frame[to_face];
  const CoarseFace here = coarse_face(g_, fr_, cf);
  // The disk edge opposite from_corner, in the coarse frame of from_face; the coarse side it lies
  // on is the one of cf shared with cg (the nearest to it when they share several).
  const P3 a = model_point(fr_.corner_model, next_corner(from_corner));
  const P3 b = model_point(fr_.corner_model, prev_corner(from_corner));
  Index best = kInvalid;
  double best_off = std::numeric_limits<double>::infinity();
  for (int j = 0; j < 3; ++j) {
    const Index x = 3 * cf + j, o = fr_.frame_opposite[x];
    if (o == kInvalid || corner_face(o) != cg) continue;
    const double off = off_side(g_, corner_point(g_, here, (j + 1) % 3), corner_point(g_, here, (j + 2) % 3), a, b);
    if (best == kInvalid || off < best_off) {
      best = x;
      best_off = off;
    }
  }
  if (best == kInvalid) return false;
  k = static_cast<int>(best - 3 * cf);
  ko = static_cast<int>(fr_.frame_opposite[best] - 3 * cg);
  return true;
}

M3 FrameDevelopment::transition(Index from_corner, Index to_face) const {
  int k = 0, ko = 0;
  if (!shared_side(from_corner, to_face, k, ko)) return M3{std::numeric_limits<double>::quiet_NaN()};
  // The shared side runs from next(x) to prev(x) in cf, and from prev(o) to next(o) in cg: the
  // frames at that first end, pointing along the side.
  const Index from_face = corner_face(from_corner);
  const CoarseFace here = coarse_face(g_, fr_, fr_.face_frame[from_face]), there = coarse_face(g_, fr_, fr_.face_frame[to_face]);
  const M3 in_f = corner_frame(g_, here, (k + 1) % 3, true);
  const M3 in_g = corner_frame(g_, there, (ko + 2) % 3, false);
  return multiply(map_[static_cast<std::size_t>(from_face)], multiply(in_f, frame_inverse(g_, in_g)));
}

Moebius FrameDevelopment::transition_h(Index from_corner, Index to_face) const {
  int k = 0, ko = 0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!shared_side(from_corner, to_face, k, ko)) return Moebius{{nan, nan}, {nan, nan}};
  const Index from_face = corner_face(from_corner);
  const CoarseFace here = coarse_face(g_, fr_, fr_.face_frame[from_face]), there = coarse_face(g_, fr_, fr_.face_frame[to_face]);
  const Moebius in_f = corner_frame_h(here, (k + 1) % 3, true);
  const Moebius in_g = corner_frame_h(there, (ko + 2) % 3, false);
  return (mob_[static_cast<std::size_t>(from_face)] * (in_f * in_g.inverse())).normalized();
}

bool FrameDevelopment::place(Index f, std::vector<double>& x, Layout& out) {
  const int dims = g_ == Geometry::Spherical ? 3 : 2;
  Index resolved = kInvalid;  // a corner of f with a finite position, for unresolved ones
  // H, kept for an atlas: a face whose map has drifted by more than kDriftLimit of its coarse
  // face's shortest side places its corners as unresolved (in range, but off its neighbours).
  bool drifted = false;
  if (keep_going_ && g_ == Geometry::Hyperbolic) {
    const std::size_t cf = 3 * static_cast<std::size_t>(fr_.face_frame[f]);
    const double side = std::min({fr_.frame_lengths[cf], fr_.frame_lengths[cf + 1], fr_.frame_lengths[cf + 2]});
    drifted = !(drift_[static_cast<std::size_t>(f)] <= kDriftLimit * side);
  }
  for (int k = 0; k < 3; ++k) {
    const Index v = t_.corner_vertex[3 * f + k];
    if (placed_[v]) {
      resolved = v;
      continue;
    }
    const P3 m = model_point(fr_.corner_model, 3 * f + k);
    const P3 X = g_ == Geometry::Hyperbolic ? m : apply(g_, map_[static_cast<std::size_t>(f)], m);
    double* xv = &x[static_cast<std::size_t>(dims) * static_cast<std::size_t>(v)];
    bool ok = true;
    switch (g_) {
      case Geometry::Euclidean:
        xv[0] = X[0];
        xv[1] = X[1];
        ok = std::isfinite(X[0]) && std::isfinite(X[1]);
        break;
      case Geometry::Hyperbolic: {
        // The model point (in its coarse face, near the pole) in the disk, z = (x, y)/(1 + t),
        // then moved by the face's SU(1,1) map.
        const double den = X[2] + 1;
        const Cx z = mob_[static_cast<std::size_t>(f)].apply(Cx(X[0] / den, X[1] / den));
        xv[0] = z.real();
        xv[1] = z.imag();
        ok = !drifted && std::isfinite(xv[0]) && std::isfinite(xv[1]) && std::hypot(xv[0], xv[1]) < 1;
        break;
      }
      case Geometry::Spherical: {
        const double n = std::sqrt(model::dot(X, X));
        for (int d = 0; d < 3; ++d) xv[d] = X[d] / n;
        ok = std::isfinite(xv[0]) && std::isfinite(xv[1]) && std::isfinite(xv[2]);
        break;
      }
    }
    placed_[v] = 1;
    touched_.push_back(v);
    placed_by_.push_back(f);
    if (ok) {
      resolved = v;
      continue;
    }
    if (!keep_going_) {
      out.status = Status::NumericalFailure;
      out.element = Element::Vertex;
      out.element_index = v;
      out.message = "vertex " + std::to_string(v) + " left the range of double precision (" +
                    std::string(g_ == Geometry::Hyperbolic ? "at the boundary of the Poincaré disk" : "not finite") +
                    ") at frame depth " + std::to_string(dist_[static_cast<std::size_t>(f)]);
      return false;
    }
    lost_.push_back(v);
    // Kept for an atlas: at a resolved corner of the same face (else the base point).
    for (int d = 0; d < dims; ++d)
      xv[d] = resolved != kInvalid ? x[static_cast<std::size_t>(dims * resolved + d)] : (d == 2 ? 1.0 : 0.0);
    ++out.unresolved_vertices;
  }
  return true;
}

bool FrameDevelopment::run(std::vector<double>& x, const M3& seed_map, Layout& out) {
  const Topology& t = t_;
  const Index none = std::numeric_limits<Index>::max();
  std::fill(dist_.begin(), dist_.end(), none);
  std::fill(taken_.begin(), taken_.end(), std::uint8_t{0});
  std::fill(placed_.begin(), placed_.end(), std::uint8_t{0});
  out.unresolved_vertices = 0;
  out.depth = 0;
  touched_.clear();
  placed_by_.clear();
  lost_.clear();
  // Breadth-first in the number of coarse edges crossed (0–1 BFS): a face in the same coarse face
  // costs nothing, so every coarse face copy is developed from the fewest transitions.
  std::deque<Index> queue{seed_};
  dist_[seed_] = 0;
  via_[seed_] = kInvalid;
  const bool h = g_ == Geometry::Hyperbolic;
  if (h) {
    mob_[seed_] = moebius_of_lorentz(seed_map);
    drift_[seed_] = 0;
  } else {
    map_[seed_] = seed_map;
  }
  while (!queue.empty()) {
    const Index f = queue.front();
    queue.pop_front();
    if (taken_[f]) continue;
    taken_[f] = 1;
    if (via_[f] != kInvalid) {
      const bool same = fr_.face_frame[f] == fr_.face_frame[corner_face(via_[f])];
      if (h) {
        const Index pf = corner_face(via_[f]);
        mob_[f] = same ? mob_[pf] : transition_h(via_[f], f);
        const double step = kFrameRounding * (std::abs(mob_[f].a) + std::abs(mob_[f].b)) * std::abs(mob_[f].b);
        drift_[f] = same ? drift_[pf] : std::sqrt(drift_[pf] * drift_[pf] + step * step);
      } else {
        map_[f] = same ? map_[corner_face(via_[f])] : transition(via_[f], f);
      }
      if (h ? !finite(mob_[f]) : !finite(map_[f])) {
        out.status = Status::InvalidArgument;
        out.element = Element::Face;
        out.element_index = f;
        out.message = "frames: face " + std::to_string(f) + " lies in coarse face " +
                      std::to_string(fr_.face_frame[f]) + ", which is not across a coarse edge from coarse face " +
                      std::to_string(fr_.face_frame[corner_face(via_[f])]) + " of its neighbour face " +
                      std::to_string(corner_face(via_[f]));
        return false;
      }
    }
    out.depth = std::max(out.depth, dist_[f]);
    if (!place(f, x, out)) return false;
    for (int k = 0; k < 3; ++k) {
      const Index o = t.opposite[3 * f + k];
      if (o == kInvalid) continue;
      const Index nb = corner_face(o);
      if (taken_[nb] || (!owner_.empty() && owner_[nb] != label_)) continue;
      const bool same = fr_.face_frame[nb] == fr_.face_frame[f];
      const Index d = dist_[f] + (same ? 0 : 1);
      if (d >= dist_[nb]) continue;
      dist_[nb] = d;
      via_[nb] = 3 * f + k;
      if (same) queue.push_front(nb);
      else queue.push_back(nb);
    }
  }
  return true;
}

bool propagate_faces_by_frames(const Topology& t, Geometry g, const FaceFrames& frames, Index seed,
                               std::span<const Index> owner, Index label, std::vector<double>& positions,
                               std::vector<Index>& touched, std::vector<double>& drift, Layout& out) {
  const int dims = g == Geometry::Spherical ? 3 : 2;
  positions.assign(static_cast<std::size_t>(dims) * static_cast<std::size_t>(t.num_vertices), 0.0);
  drift.assign(static_cast<std::size_t>(t.num_vertices), 0.0);
  const bool h = g == Geometry::Hyperbolic;
  FrameDevelopment dev(t, g, frames, seed, h);
  dev.restrict_to(owner, label);
  const bool ok = dev.run(positions, dev.seed_map(), out);
  touched = dev.touched();
  if (h) {
    for (std::size_t i = 0; i < touched.size(); ++i)
      drift[static_cast<std::size_t>(touched[i])] = dev.drift()[static_cast<std::size_t>(dev.placed_by()[i])];
    for (Index v : dev.lost()) drift[static_cast<std::size_t>(v)] = std::numeric_limits<double>::infinity();
  }
  return ok;
}

Index FrameDevelopment::unplaced() const {
  return static_cast<Index>(std::count(placed_.begin(), placed_.end(), std::uint8_t{0}));
}

}  // namespace ricci::detail
