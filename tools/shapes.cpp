#include "shapes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdint>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

namespace ricci_shapes {

namespace {

using Vec3 = std::array<double, 3>;

constexpr double kPi = 3.141592653589793238462643383279502884;

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

Vec3 position(const Mesh& m, Index v) {
  return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
}
void push_position(Mesh& m, const Vec3& p) {
  m.positions.push_back(p[0]);
  m.positions.push_back(p[1]);
  m.positions.push_back(p[2]);
}
void push_face(Mesh& m, Index a, Index b, Index c) {
  m.faces.push_back(a);
  m.faces.push_back(b);
  m.faces.push_back(c);
}

// cos and sin of 2π·num/den computed with + − × only (a Taylor series on [0, π/2) after an exact
// integer quadrant reduction), so the result does not depend on the C library.
std::pair<double, double> cos_sin_turns(std::int64_t num, std::int64_t den) {
  num %= den;
  if (num < 0) num += den;
  const std::int64_t quadrant = (4 * num) / den;          // 0..3
  const std::int64_t rest = 4 * num - quadrant * den;      // in [0, den)
  const double x = (kPi / 2) * static_cast<double>(rest) / static_cast<double>(den);
  const double x2 = x * x;
  // Horner forms of the series up to x^22 / x^23 (error far below one ulp on [0, π/2)).
  double c = 1.0, s = 1.0;
  for (int k = 11; k >= 1; --k) {
    c = 1.0 - x2 / static_cast<double>((2 * k - 1) * (2 * k)) * c;
    s = 1.0 - x2 / static_cast<double>((2 * k) * (2 * k + 1)) * s;
  }
  s *= x;
  switch (quadrant) {
    case 0: return {c, s};
    case 1: return {-s, c};
    case 2: return {-c, -s};
    default: return {s, -c};
  }
}

std::uint64_t undirected_key(Index a, Index b) {
  const auto lo = static_cast<std::uint32_t>(std::min(a, b));
  const auto hi = static_cast<std::uint32_t>(std::max(a, b));
  return (std::uint64_t{lo} << 32) | hi;
}
std::uint64_t directed_key(Index a, Index b) {
  return (std::uint64_t{static_cast<std::uint32_t>(a)} << 32) | static_cast<std::uint32_t>(b);
}

// 1→4 midpoint split; new vertices appended in the order their edges are first met.
Mesh split_midpoints(const Mesh& mesh) {
  Mesh out;
  out.positions = mesh.positions;
  std::unordered_map<std::uint64_t, Index> mid;
  mid.reserve(mesh.faces.size());
  auto midpoint = [&](Index a, Index b) {
    const auto [it, inserted] = mid.try_emplace(undirected_key(a, b), out.num_vertices());
    if (inserted) {
      const Vec3 pa = position(mesh, a), pb = position(mesh, b);
      push_position(out, {0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.5 * (pa[2] + pb[2])});
    }
    return it->second;
  };
  out.faces.reserve(4 * mesh.faces.size());
  for (Index f = 0; f < mesh.num_faces(); ++f) {
    const Index a = mesh.faces[3 * f], b = mesh.faces[3 * f + 1], c = mesh.faces[3 * f + 2];
    const Index ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    push_face(out, a, ab, ca);
    push_face(out, ab, b, bc);
    push_face(out, ca, bc, c);
    push_face(out, ab, bc, ca);
  }
  return out;
}

void normalize_positions(Mesh& m) {
  for (Index v = 0; v < m.num_vertices(); ++v) {
    const double len = norm(position(m, v));
    for (int d = 0; d < 3; ++d) m.positions[3 * v + d] /= len;
  }
}


// One umbrella step p ← p + factor·(mean of neighbours − p), all vertices at once.
void umbrella_step(Mesh& m, const std::vector<Index>& offsets, const std::vector<Index>& nbrs,
                   double factor) {
  const std::vector<double> old = m.positions;
  for (Index v = 0; v < m.num_vertices(); ++v) {
    const Index b = offsets[v], e = offsets[v + 1];
    if (b == e) continue;
    for (int d = 0; d < 3; ++d) {
      double sum = 0;
      for (Index i = b; i < e; ++i) sum += old[3 * nbrs[i] + d];
      const double mean = sum / static_cast<double>(e - b);
      m.positions[3 * v + d] = old[3 * v + d] + factor * (mean - old[3 * v + d]);
    }
  }
}

// Lifts a planar mesh slightly off the z = 0 plane (a gentle saddle).
void lift_saddle(Mesh& m) {
  for (Index v = 0; v < m.num_vertices(); ++v) {
    const double x = m.positions[3 * v], y = m.positions[3 * v + 1];
    m.positions[3 * v + 2] = 0.15 * (x * x - y * y);
  }
}

void shuffle_indices(std::vector<Index>& a, std::mt19937_64& rng) {
  for (Index i = static_cast<Index>(a.size()) - 1; i > 0; --i) std::swap(a[i], a[uniform_index(rng, i + 1)]);
}

double twice_area(const Vec3& a, const Vec3& b, const Vec3& c) { return norm(cross(sub(b, a), sub(c, a))); }
double longest_edge_sq(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e0 = sub(b, a), e1 = sub(c, b), e2 = sub(a, c);
  return std::max({dot(e0, e0), dot(e1, e1), dot(e2, e2)});
}

}  // namespace

// ---------------------------------------------------------------------------------------------

double unit_double(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

Index uniform_index(std::mt19937_64& rng, Index n) {
  return static_cast<Index>(rng() % static_cast<std::uint64_t>(n));
}

Mesh icosphere(int subdivisions) {
  if (subdivisions < 0 || subdivisions > 10) throw std::invalid_argument("icosphere: subdivisions must be in [0, 10]");
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  Mesh m;
  m.positions = {-1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, 0,  //
                 0, -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t,  //
                 t, 0, -1, t, 0, 1, -t, 0, -1, -t, 0, 1};
  m.faces = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4,
             11, 10, 2, 10, 7, 6, 7, 1, 8, 3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8,
             3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1};
  // Make every face outward (normal along its centroid) whatever the table above says.
  for (Index f = 0; f < m.num_faces(); ++f) {
    const Vec3 a = position(m, m.faces[3 * f]), b = position(m, m.faces[3 * f + 1]),
               c = position(m, m.faces[3 * f + 2]);
    if (dot(cross(sub(b, a), sub(c, a)), a) < 0) std::swap(m.faces[3 * f + 1], m.faces[3 * f + 2]);
  }
  normalize_positions(m);
  for (int s = 0; s < subdivisions; ++s) {
    m = split_midpoints(m);
    normalize_positions(m);
  }
  return m;
}

Mesh torus(int n_major, int n_minor, double R, double r) {
  if (n_major < 3 || n_minor < 3 || !(r > 0) || !(r < R)) throw std::invalid_argument("torus: bad arguments");
  Mesh m;
  m.positions.reserve(3 * static_cast<std::size_t>(n_major) * n_minor);
  for (int i = 0; i < n_major; ++i) {
    const auto [cu, su] = cos_sin_turns(i, n_major);
    for (int j = 0; j < n_minor; ++j) {
      const auto [cv, sv] = cos_sin_turns(j, n_minor);
      const double rho = R + r * cv;
      push_position(m, {rho * cu, rho * su, r * sv});
    }
  }
  // (∂/∂u) × (∂/∂v) points outward, so (i,j) → (i+1,j) → (i+1,j+1) is counter-clockwise outside.
  auto id = [&](int i, int j) { return static_cast<Index>((i % n_major) * n_minor + (j % n_minor)); };
  for (int i = 0; i < n_major; ++i) {
    for (int j = 0; j < n_minor; ++j) {
      const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      push_face(m, a, b, c);
      push_face(m, a, c, d);
    }
  }
  return m;
}

namespace {

/// The boundary of a solid of voxels: n[0] × n[1] × n[2] voxels, voxel (i, j, k) in the solid
/// when inside(i, j, k) (only asked within those bounds). Each exposed voxel face becomes two
/// triangles, vertices welded on the integer grid; then Taubin-smoothed (λ/μ) and scaled to lie
/// in [−1, 1] along x, centred at the origin. The solid must have a manifold boundary (no two
/// voxels meeting only along an edge or at a corner).
template <class Inside>
Mesh voxel_surface(const int (&n)[3], const Inside& inside) {
  auto filled = [&](int i, int j, int k) {
    if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) return false;
    return static_cast<bool>(inside(i, j, k));
  };
  const std::int64_t gx = n[0] + 1, gy = n[1] + 1, gz = n[2] + 1;
  std::vector<Index> grid_vertex(static_cast<std::size_t>(gx * gy * gz), ricci::kInvalid);
  Mesh m;
  auto vertex = [&](const std::array<int, 3>& p) {
    Index& id = grid_vertex[static_cast<std::size_t>((p[0] * gy + p[1]) * gz + p[2])];
    if (id == ricci::kInvalid) {
      id = m.num_vertices();
      push_position(m, {static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])});
    }
    return id;
  };
  for (int i = 0; i < n[0]; ++i) {
    for (int j = 0; j < n[1]; ++j) {
      for (int k = 0; k < n[2]; ++k) {
        if (!filled(i, j, k)) continue;
        const int cell[3] = {i, j, k};
        for (int axis = 0; axis < 3; ++axis) {
          const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // u × v = axis
          for (int side = 0; side < 2; ++side) {
            int nb[3] = {i, j, k};
            nb[axis] += side ? 1 : -1;
            if (filled(nb[0], nb[1], nb[2])) continue;
            // Quad corners (du, dv), counter-clockwise seen from the outside of this face.
            static constexpr int kPos[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
            static constexpr int kNeg[4][2] = {{0, 0}, {0, 1}, {1, 1}, {1, 0}};
            Index q[4];
            for (int corner = 0; corner < 4; ++corner) {
              std::array<int, 3> p = {cell[0], cell[1], cell[2]};
              p[axis] += side;
              p[u] += side ? kPos[corner][0] : kNeg[corner][0];
              p[v] += side ? kPos[corner][1] : kNeg[corner][1];
              q[corner] = vertex(p);
            }
            push_face(m, q[0], q[1], q[2]);
            push_face(m, q[0], q[2], q[3]);
          }
        }
      }
    }
  }
  // Taubin λ/μ smoothing: rounds the voxel edges without shrinking the whole shape.
  std::vector<Index> offsets, nbrs;
  vertex_neighbours(m, offsets, nbrs);
  for (int it = 0; it < 24; ++it) {
    umbrella_step(m, offsets, nbrs, 0.5);
    umbrella_step(m, offsets, nbrs, -0.53);
  }
  // Centre and scale to x ∈ [−1, 1].
  double lo[3], hi[3];
  for (int d = 0; d < 3; ++d) lo[d] = hi[d] = m.positions[d];
  for (Index v = 0; v < m.num_vertices(); ++v) {
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], m.positions[3 * v + d]);
      hi[d] = std::max(hi[d], m.positions[3 * v + d]);
    }
  }
  const double scale = 2.0 / (hi[0] - lo[0]);
  for (Index v = 0; v < m.num_vertices(); ++v)
    for (int d = 0; d < 3; ++d) m.positions[3 * v + d] = (m.positions[3 * v + d] - 0.5 * (lo[d] + hi[d])) * scale;
  return m;
}

/// The plate of pretzel() and pretzel_grid(): cols × rows square holes at the odd units along x
/// and y, through the whole thickness.
Mesh holed_plate(int cols, int rows, int cells_per_unit) {
  const int c = cells_per_unit;
  const int n[3] = {(2 * cols + 1) * c, (2 * rows + 1) * c, c};  // voxels along x, y, z
  return voxel_surface(n, [c](int i, int j, int) { return !(((j / c) % 2 == 1) && ((i / c) % 2 == 1)); });
}

}  // namespace

Mesh pretzel(int genus, int cells_per_unit) {
  if (genus < 1 || genus > 64 || cells_per_unit < 2 || cells_per_unit > 32)
    throw std::invalid_argument("pretzel: genus must be in [1, 64] and cells_per_unit in [2, 32]");
  return holed_plate(genus, 1, cells_per_unit);
}

Mesh pretzel_grid(int cols, int rows, int cells_per_unit) {
  if (cols < 1 || rows < 1 || cols * rows > 256 || cells_per_unit < 2 || cells_per_unit > 32)
    throw std::invalid_argument("pretzel_grid: cols, rows >= 1 with cols * rows <= 256 and cells_per_unit in [2, 32]");
  return holed_plate(cols, rows, cells_per_unit);
}

Mesh tube_pretzel(int genus, int tube_units, int finger_units, int cells_per_unit) {
  if (genus < 0 || genus > 16 || tube_units < 1 || tube_units > 200 || finger_units < 0 || finger_units > 200 ||
      cells_per_unit < 2 || cells_per_unit > 16 || (genus <= 1 && finger_units == 0))
    throw std::invalid_argument(
        "tube_pretzel: genus in [0, 16] (genus 0 and 1 with a finger), tube_units in [1, 200], finger_units in "
        "[0, 200], cells_per_unit in [2, 16]");
  const int c = cells_per_unit, period = 3 + tube_units;  // one ring of 3 × 3 units, then a tube
  const int rings = (std::max(genus, 1) - 1) * period + 3;  // units along x up to the last ring's end
  const int n[3] = {(rings + finger_units) * c, 3 * c, c};
  return voxel_surface(n, [c, period, rings, genus](int i, int j, int) {
    const int x = i / c, y = j / c;              // units
    if (x >= rings) return y == 1;               // the finger
    const int xp = x % period;                   // units within one period
    if (xp >= 3) return y == 1;                  // a tube: the middle unit of the three
    return genus == 0 || !(xp == 1 && y == 1);   // the ring around its hole (genus 0: a block)
  });
}

Mesh disk(int rings) {
  if (rings < 1 || rings > 1000) throw std::invalid_argument("disk: rings must be in [1, 1000]");
  Mesh m;
  push_position(m, {0, 0, 0});
  // Ring k (k ≥ 1) has 6k vertices at angles j/(6k) turns, starting at index 1 + 3k(k−1).
  auto ring_start = [](int k) { return k == 0 ? 0 : 1 + 3 * k * (k - 1); };
  auto ring_size = [](int k) { return k == 0 ? 1 : 6 * k; };
  for (int k = 1; k <= rings; ++k) {
    const double radius = static_cast<double>(k) / rings;
    for (int j = 0; j < 6 * k; ++j) {
      const auto [cs, sn] = cos_sin_turns(j, 6 * k);
      push_position(m, {radius * cs, radius * sn, 0});
    }
  }
  // Zip ring k−1 (inner) and ring k (outer) by angle, advancing whichever next vertex comes
  // first (exact rational comparison); ties advance the outer ring.
  for (int k = 1; k <= rings; ++k) {
    const int n0 = ring_size(k - 1), n1 = ring_size(k), s0 = ring_start(k - 1), s1 = ring_start(k);
    int a = 0, b = 0;
    while (a < n0 || b < n1) {
      const Index ia = static_cast<Index>(s0 + a % n0), ib = static_cast<Index>(s1 + b % n1);
      // Next angles (a+1)/n0 and (b+1)/n1 (an inner ring of one vertex never advances).
      const bool advance_outer =
          (k == 1) || (b < n1 && (a >= n0 || static_cast<std::int64_t>(b + 1) * n0 <=
                                                 static_cast<std::int64_t>(a + 1) * n1));
      if (advance_outer) {
        push_face(m, ia, ib, static_cast<Index>(s1 + (b + 1) % n1));
        ++b;
        if (k == 1 && b == n1) break;
      } else {
        push_face(m, ia, ib, static_cast<Index>(s0 + (a + 1) % n0));
        ++a;
      }
    }
  }
  lift_saddle(m);
  return m;
}

Mesh annulus(int rings, int segments) {
  if (rings < 1 || segments < 3) throw std::invalid_argument("annulus: rings ≥ 1 and segments ≥ 3 required");
  Mesh m;
  for (int i = 0; i <= rings; ++i) {
    const double radius = 0.5 + 0.5 * static_cast<double>(i) / rings;
    for (int j = 0; j < segments; ++j) {
      const auto [cs, sn] = cos_sin_turns(j, segments);
      push_position(m, {radius * cs, radius * sn, 0});
    }
  }
  auto id = [&](int i, int j) { return static_cast<Index>(i * segments + j % segments); };
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      // Outward then counter-clockwise: counter-clockwise seen from above.
      const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      push_face(m, a, b, c);
      push_face(m, a, c, d);
    }
  }
  lift_saddle(m);
  return m;
}

Mesh conformal_annulus(double r1, double r2, int rings, int segments, bool flat) {
  if (rings < 1 || segments < 3 || !(r1 > 0) || !(r1 < r2) || !(r2 <= 1))
    throw std::invalid_argument("conformal_annulus: 0 < r1 < r2 <= 1, rings >= 1 and segments >= 3 required");
  Mesh m;
  for (int i = 0; i <= rings; ++i) {
    const double rad = r1 * std::pow(r2 / r1, static_cast<double>(i) / rings);
    for (int j = 0; j < segments; ++j) {
      const double a = 2 * std::numbers::pi * (j + 0.5 * (i % 2)) / segments;
      const std::complex<double> z = std::polar(rad, a);
      if (flat) {
        push_position(m, {z.real(), z.imag(), 0});
        continue;
      }
      const std::complex<double> w = 0.8 * (z + 0.2 * z * z);
      const double q = std::norm(w);
      push_position(m, {2 * w.real() / (1 + q), 2 * w.imag() / (1 + q), (q - 1) / (1 + q)});
    }
  }
  // Consistently oriented strips between rings i and i+1 (the offset ring alternates the diagonal).
  auto id = [&](int i, int j) { return static_cast<Index>(i * segments + (j + segments) % segments); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      if (i % 2 == 0) {
        push_face(m, id(i, j), id(i, j + 1), id(i + 1, j));
        push_face(m, id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
      } else {
        push_face(m, id(i, j), id(i + 1, j + 1), id(i + 1, j));
        push_face(m, id(i, j), id(i, j + 1), id(i + 1, j + 1));
      }
    }
  return m;
}

Mesh remove_vertex_stars(const Mesh& mesh, const std::vector<Index>& centres) {
  const Index nv = mesh.num_vertices();
  std::vector<std::uint64_t> directed;
  directed.reserve(mesh.faces.size());
  for (Index f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) directed.push_back(directed_key(mesh.faces[3 * f + k], mesh.faces[3 * f + (k + 1) % 3]));
  std::sort(directed.begin(), directed.end());
  auto has_edge = [&](Index a, Index b) { return std::binary_search(directed.begin(), directed.end(), directed_key(a, b)); };
  std::vector<char> on_boundary(nv, 0);
  for (Index f = 0; f < mesh.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const Index a = mesh.faces[3 * f + k], b = mesh.faces[3 * f + (k + 1) % 3];
      if (!has_edge(b, a)) on_boundary[a] = on_boundary[b] = 1;
    }
  }
  // owner[v]: −1 free, −2 a centre, i ≥ 0 in the link of centres[i].
  std::vector<Index> owner(nv, -1);
  for (const Index v : centres) {
    if (v < 0 || v >= nv) throw std::invalid_argument("remove_vertex_stars: centre out of range");
    if (owner[v] == -2) throw std::invalid_argument("remove_vertex_stars: centre listed twice");
    if (on_boundary[v]) throw std::invalid_argument("remove_vertex_stars: centre on the boundary");
    owner[v] = -2;
  }
  std::vector<char> drop_face(mesh.num_faces(), 0);
  for (std::size_t i = 0; i < centres.size(); ++i) {
    bool used = false;
    for (Index f = 0; f < mesh.num_faces(); ++f) {
      for (int k = 0; k < 3; ++k) {
        if (mesh.faces[3 * f + k] != centres[i]) continue;
        used = true;
        drop_face[f] = 1;
        for (int j = 1; j < 3; ++j) {
          const Index w = mesh.faces[3 * f + (k + j) % 3];
          if (owner[w] == -2) throw std::invalid_argument("remove_vertex_stars: two centres are neighbours");
          if (owner[w] >= 0 && owner[w] != static_cast<Index>(i))
            throw std::invalid_argument("remove_vertex_stars: two holes would touch");
          if (on_boundary[w]) throw std::invalid_argument("remove_vertex_stars: a hole would touch the boundary");
          owner[w] = static_cast<Index>(i);
        }
      }
    }
    if (!used) throw std::invalid_argument("remove_vertex_stars: centre used by no face");
  }
  std::vector<Index> remap(nv, ricci::kInvalid);
  for (Index f = 0; f < mesh.num_faces(); ++f)
    if (!drop_face[f])
      for (int k = 0; k < 3; ++k) remap[mesh.faces[3 * f + k]] = 0;
  Mesh out;
  for (Index v = 0; v < nv; ++v) {
    if (remap[v] == ricci::kInvalid) continue;
    remap[v] = out.num_vertices();
    push_position(out, position(mesh, v));
  }
  for (Index f = 0; f < mesh.num_faces(); ++f)
    if (!drop_face[f])
      push_face(out, remap[mesh.faces[3 * f]], remap[mesh.faces[3 * f + 1]], remap[mesh.faces[3 * f + 2]]);
  return out;
}

// ---------------------------------------------------------------------------------------------

Mesh permute_vertices(const Mesh& mesh, std::mt19937_64& rng) {
  const Index nv = mesh.num_vertices();
  std::vector<Index> new_index(nv);
  for (Index v = 0; v < nv; ++v) new_index[v] = v;
  shuffle_indices(new_index, rng);
  Mesh out = mesh;
  for (Index v = 0; v < nv; ++v)
    for (int d = 0; d < 3; ++d) out.positions[3 * new_index[v] + d] = mesh.positions[3 * v + d];
  for (auto& v : out.faces) v = new_index[v];
  return out;
}

Mesh permute_faces(const Mesh& mesh, std::mt19937_64& rng) {
  const Index nf = mesh.num_faces();
  std::vector<Index> order(nf);
  for (Index f = 0; f < nf; ++f) order[f] = f;
  shuffle_indices(order, rng);
  Mesh out = mesh;
  const bool tex = mesh.has_texcoords();
  for (Index f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      out.faces[3 * f + k] = mesh.faces[3 * order[f] + k];
      if (tex) out.corner_texcoords[3 * f + k] = mesh.corner_texcoords[3 * order[f] + k];
    }
  }
  return out;
}

Mesh rotate_face_corners(const Mesh& mesh, std::mt19937_64& rng) {
  Mesh out = mesh;
  const bool tex = mesh.has_texcoords();
  for (Index f = 0; f < mesh.num_faces(); ++f) {
    const Index r = uniform_index(rng, 3);
    for (int k = 0; k < 3; ++k) {
      out.faces[3 * f + k] = mesh.faces[3 * f + (k + r) % 3];
      if (tex) out.corner_texcoords[3 * f + k] = mesh.corner_texcoords[3 * f + (k + r) % 3];
    }
  }
  return out;
}

Mesh subdivide_midpoint(const Mesh& mesh) { return split_midpoints(mesh); }

Mesh subdivide_midpoint(const Mesh& mesh, std::mt19937_64& /*rng*/) { return split_midpoints(mesh); }

Mesh split_random_faces(const Mesh& mesh, std::mt19937_64& rng, double fraction) {
  Mesh out;
  out.positions = mesh.positions;
  out.faces.reserve(mesh.faces.size());
  for (Index f = 0; f < mesh.num_faces(); ++f) {
    const Index a = mesh.faces[3 * f], b = mesh.faces[3 * f + 1], c = mesh.faces[3 * f + 2];
    if (!(unit_double(rng) < fraction)) {
      push_face(out, a, b, c);
      continue;
    }
    // Uniform point of the simplex, shrunk so that every barycentric coordinate is ≥ 0.1.
    double s = unit_double(rng), t = unit_double(rng);
    if (s + t > 1) {
      s = 1 - s;
      t = 1 - t;
    }
    const double w[3] = {0.1 + 0.7 * s, 0.1 + 0.7 * t, 0.1 + 0.7 * (1 - s - t)};
    const Vec3 pa = position(mesh, a), pb = position(mesh, b), pc = position(mesh, c);
    Vec3 p;
    for (int d = 0; d < 3; ++d) p[d] = w[0] * pa[d] + w[1] * pb[d] + w[2] * pc[d];
    const Index x = out.num_vertices();
    push_position(out, p);
    push_face(out, a, b, x);
    push_face(out, b, c, x);
    push_face(out, c, a, x);
  }
  return out;
}

Mesh flip_random_edges(const Mesh& mesh, std::mt19937_64& rng, double fraction) {
  Mesh out;
  out.positions = mesh.positions;
  out.faces = mesh.faces;
  std::vector<Index>& F = out.faces;
  // Directed edge a→b → the face that contains it.
  std::unordered_map<std::uint64_t, Index> face_of;
  face_of.reserve(F.size());
  for (Index f = 0; f < out.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) face_of[directed_key(F[3 * f + k], F[3 * f + (k + 1) % 3])] = f;
  // Interior edges (a < b), in face order, then shuffled.
  std::vector<Index> cand_a, order;
  std::vector<Index> cand_b;
  for (Index f = 0; f < out.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const Index a = F[3 * f + k], b = F[3 * f + (k + 1) % 3];
      if (a < b && face_of.count(directed_key(b, a))) {
        order.push_back(static_cast<Index>(cand_a.size()));
        cand_a.push_back(a);
        cand_b.push_back(b);
      }
    }
  }
  shuffle_indices(order, rng);
  const auto attempts = static_cast<std::size_t>(std::floor(fraction * static_cast<double>(order.size()) + 0.5));
  auto third = [&](Index f, Index a, Index b) {
    for (int k = 0; k < 3; ++k)
      if (F[3 * f + k] != a && F[3 * f + k] != b) return F[3 * f + k];
    return ricci::kInvalid;
  };
  for (std::size_t i = 0; i < attempts && i < order.size(); ++i) {
    const Index a = cand_a[order[i]], b = cand_b[order[i]];
    const auto it1 = face_of.find(directed_key(a, b)), it2 = face_of.find(directed_key(b, a));
    if (it1 == face_of.end() || it2 == face_of.end()) continue;  // flipped away earlier
    const Index f1 = it1->second, f2 = it2->second;  // f1 = (a, b, c), f2 = (b, a, d)
    const Index c = third(f1, a, b), d = third(f2, a, b);
    if (c == d || face_of.count(directed_key(c, d)) || face_of.count(directed_key(d, c))) continue;
    const Vec3 pa = position(out, a), pb = position(out, b), pc = position(out, c), pd = position(out, d);
    if (!(twice_area(pc, pa, pd) > 1e-3 * longest_edge_sq(pc, pa, pd))) continue;
    if (!(twice_area(pd, pb, pc) > 1e-3 * longest_edge_sq(pd, pb, pc))) continue;
    // No fold: both new triangles face the same side as the two old ones (the quad is convex
    // seen along their summed normal).
    const Vec3 n_old_1 = cross(sub(pb, pa), sub(pc, pa)), n_old_2 = cross(sub(pa, pb), sub(pd, pb));
    const Vec3 n_old = {n_old_1[0] + n_old_2[0], n_old_1[1] + n_old_2[1], n_old_1[2] + n_old_2[2]};
    if (!(dot(cross(sub(pa, pc), sub(pd, pc)), n_old) > 0)) continue;
    if (!(dot(cross(sub(pb, pd), sub(pc, pd)), n_old) > 0)) continue;
    // The quad a, d, b, c (counter-clockwise) gets the diagonal c–d: (c, a, d) and (d, b, c).
    F[3 * f1] = c, F[3 * f1 + 1] = a, F[3 * f1 + 2] = d;
    F[3 * f2] = d, F[3 * f2 + 1] = b, F[3 * f2 + 2] = c;
    face_of.erase(it1);
    face_of.erase(directed_key(b, a));
    face_of[directed_key(c, a)] = f1;
    face_of[directed_key(a, d)] = f1;
    face_of[directed_key(d, c)] = f1;
    face_of[directed_key(d, b)] = f2;
    face_of[directed_key(b, c)] = f2;
    face_of[directed_key(c, d)] = f2;
  }
  return out;
}

// ---------------------------------------------------------------------------------------------

double signed_volume(const Mesh& mesh) {
  double sum = 0;
  for (Index f = 0; f < mesh.num_faces(); ++f) {
    const Vec3 a = position(mesh, mesh.faces[3 * f]), b = position(mesh, mesh.faces[3 * f + 1]),
               c = position(mesh, mesh.faces[3 * f + 2]);
    sum += dot(a, cross(b, c));
  }
  return sum / 6.0;
}

double min_angle_degrees(const Mesh& mesh) {
  double best = 180;
  for (Index f = 0; f < mesh.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = position(mesh, mesh.faces[3 * f + k]);
      const Vec3 e1 = sub(position(mesh, mesh.faces[3 * f + (k + 1) % 3]), p);
      const Vec3 e2 = sub(position(mesh, mesh.faces[3 * f + (k + 2) % 3]), p);
      const double angle = std::atan2(norm(cross(e1, e2)), dot(e1, e2)) * (180.0 / kPi);
      best = std::min(best, angle);
    }
  }
  return best;
}

void vertex_neighbours(const Mesh& m, std::vector<Index>& offsets, std::vector<Index>& nbrs) {
  const Index nv = m.num_vertices();
  std::vector<std::vector<Index>> lists(nv);
  for (std::size_t c = 0; c < m.faces.size(); ++c) {
    const std::size_t f = c / 3, k = c % 3;
    const Index v = m.faces[c];
    lists[v].push_back(m.faces[3 * f + (k + 1) % 3]);
    lists[v].push_back(m.faces[3 * f + (k + 2) % 3]);
  }
  offsets.assign(1, 0);
  nbrs.clear();
  for (auto& l : lists) {
    std::sort(l.begin(), l.end());
    l.erase(std::unique(l.begin(), l.end()), l.end());
    nbrs.insert(nbrs.end(), l.begin(), l.end());
    offsets.push_back(static_cast<Index>(nbrs.size()));
  }
}

}  // namespace ricci_shapes
