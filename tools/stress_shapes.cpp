#include "stress_shapes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "ricci/flow.h"
#include "shapes.h"

namespace ricci_shapes {

namespace {

using Vec3 = std::array<double, 3>;

constexpr double kPi = std::numbers::pi;

Vec3 at(const Mesh& m, Index v) { return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]}; }
void push(Mesh& m, const Vec3& p) {
  m.positions.push_back(p[0]);
  m.positions.push_back(p[1]);
  m.positions.push_back(p[2]);
}
void face(Mesh& m, Index a, Index b, Index c) {
  m.faces.push_back(a);
  m.faces.push_back(b);
  m.faces.push_back(c);
}
/// Two triangles per quad of a (columns+1) × (rows+1) vertex grid numbered i·(rows+1) + j.
void grid_faces(Mesh& m, int columns, int rows) {
  auto id = [&](int i, int j) { return static_cast<Index>(i * (rows + 1) + j); };
  for (int i = 0; i < columns; ++i)
    for (int j = 0; j < rows; ++j) {
      face(m, id(i, j), id(i + 1, j), id(i + 1, j + 1));
      face(m, id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
}
Vec3 lerp(const Vec3& a, const Vec3& b, double t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

/// Disk: a centre vertex, then circles of `segments` vertices at `radii` (increasing), each lifted
/// to z = 0.15·(x² − y²) when `lift`. Counter-clockwise seen from +z.
Mesh ring_disk(int segments, const std::vector<double>& radii, bool lift) {
  Mesh m;
  push(m, {0, 0, 0});
  for (double rho : radii) {
    for (int j = 0; j < segments; ++j) {
      const double phi = 2 * kPi * j / segments;
      const double x = rho * std::cos(phi), y = rho * std::sin(phi);
      push(m, {x, y, lift ? 0.15 * (x * x - y * y) : 0.0});
    }
  }
  auto id = [&](int k, int j) { return static_cast<Index>(1 + k * segments + (j % segments)); };
  for (int j = 0; j < segments; ++j) face(m, 0, id(0, j), id(0, j + 1));
  for (int k = 0; k + 1 < static_cast<int>(radii.size()); ++k) {
    for (int j = 0; j < segments; ++j) {
      face(m, id(k, j), id(k + 1, j), id(k + 1, j + 1));
      face(m, id(k, j), id(k + 1, j + 1), id(k, j + 1));
    }
  }
  return m;
}

/// Closed torus (R = 1, r = 0.4) over the given major angles (turns, increasing in [0, 1)) and
/// n_minor equally spaced minor angles; outward normals.
Mesh torus_over(const std::vector<double>& major_turns, int n_minor) {
  const int n_major = static_cast<int>(major_turns.size());
  Mesh m;
  for (double tu : major_turns) {
    const double cu = std::cos(2 * kPi * tu), su = std::sin(2 * kPi * tu);
    for (int j = 0; j < n_minor; ++j) {
      const double tv = 2 * kPi * j / n_minor;
      const double rho = 1.0 + 0.4 * std::cos(tv);
      push(m, {rho * cu, rho * su, 0.4 * std::sin(tv)});
    }
  }
  auto id = [&](int i, int j) { return static_cast<Index>((i % n_major) * n_minor + (j % n_minor)); };
  for (int i = 0; i < n_major; ++i) {
    for (int j = 0; j < n_minor; ++j) {
      face(m, id(i, j), id(i + 1, j), id(i + 1, j + 1));
      face(m, id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  }
  return m;
}

}  // namespace

Mesh insert_needles_and_caps(const Mesh& mesh, std::mt19937_64& rng, double fraction, double angle) {
  if (!(angle > 0 && angle <= 0.1) || !(fraction >= 0 && fraction <= 1))
    throw std::invalid_argument("insert_needles_and_caps: bad arguments");
  Mesh m;
  m.positions = mesh.positions;
  const Index nf = mesh.num_faces();
  bool needle = true;
  for (Index f = 0; f < nf; ++f) {
    const Index a = mesh.faces[3 * f], b = mesh.faces[3 * f + 1], c = mesh.faces[3 * f + 2];
    if (!(unit_double(rng) < fraction)) {
      face(m, a, b, c);
      continue;
    }
    const Vec3 pa = at(mesh, a), pb = at(mesh, b), pc = at(mesh, c);
    const Vec3 g = {(pa[0] + pb[0] + pc[0]) / 3, (pa[1] + pb[1] + pc[1]) / 3, (pa[2] + pb[2] + pc[2]) / 3};
    // Needle: towards the centroid from corner a, so the angles at b (in a b p) and c (in c a p)
    // are about angle. Cap: off the midpoint of a b, so a b p has two angles of about angle.
    const Vec3 p = needle ? lerp(pa, g, 2 * angle) : lerp(lerp(pa, pb, 0.5), g, std::sqrt(3.0) * angle);
    needle = !needle;
    const Index v = m.num_vertices();
    push(m, p);
    face(m, a, b, v);
    face(m, b, c, v);
    face(m, c, a, v);
  }
  return m;
}

Mesh polar_sphere(int segments, int rings) {
  if (segments < 3 || rings < 1) throw std::invalid_argument("polar_sphere: bad arguments");
  Mesh m;
  push(m, {0, 0, 1});
  for (int k = 1; k <= rings; ++k) {
    const double theta = kPi * k / (rings + 1);
    for (int j = 0; j < segments; ++j) {
      const double phi = 2 * kPi * j / segments;
      push(m, {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
    }
  }
  push(m, {0, 0, -1});
  const Index south = m.num_vertices() - 1;
  auto id = [&](int k, int j) { return static_cast<Index>(1 + k * segments + (j % segments)); };
  for (int j = 0; j < segments; ++j) face(m, 0, id(0, j), id(0, j + 1));
  for (int k = 0; k + 1 < rings; ++k) {
    for (int j = 0; j < segments; ++j) {
      face(m, id(k, j), id(k + 1, j), id(k + 1, j + 1));
      face(m, id(k, j), id(k + 1, j + 1), id(k, j + 1));
    }
  }
  for (int j = 0; j < segments; ++j) face(m, south, id(rings - 1, j + 1), id(rings - 1, j));
  return m;
}

Mesh fan_disk(int segments, int rings) {
  if (segments < 3 || rings < 1) throw std::invalid_argument("fan_disk: bad arguments");
  std::vector<double> radii;
  for (int k = 1; k <= rings; ++k) radii.push_back(static_cast<double>(k) / rings);
  return ring_disk(segments, radii, true);
}

Mesh scaled(const Mesh& mesh, double factor) {
  Mesh m = mesh;
  for (double& x : m.positions) x *= factor;
  return m;
}

Mesh pancake(int subdivisions, double flatness) {
  Mesh m = icosphere(subdivisions);
  for (Index v = 0; v < m.num_vertices(); ++v) m.positions[3 * v + 2] *= flatness;
  return m;
}

Mesh accordion(int folds, int columns_per_fold, int rows, double gap) {
  if (folds < 1 || columns_per_fold < 1 || rows < 1 || !(gap > 0)) throw std::invalid_argument("accordion: bad arguments");
  const int columns = folds * columns_per_fold;
  Mesh m;
  for (int i = 0; i <= columns; ++i) {
    const int layer = i / columns_per_fold, r = i % columns_per_fold;
    const double frac = static_cast<double>(r) / columns_per_fold;
    const double x = layer % 2 == 0 ? frac : 1.0 - frac;
    const double s = static_cast<double>(i) / columns_per_fold;
    for (int j = 0; j <= rows; ++j) push(m, {x, static_cast<double>(j) / rows, gap * s});
  }
  grid_faces(m, columns, rows);
  return m;
}

Mesh strip(int columns, int rows, double length, double width) {
  if (columns < 1 || rows < 1 || !(length > 0) || !(width > 0)) throw std::invalid_argument("strip: bad arguments");
  Mesh m;
  for (int i = 0; i <= columns; ++i)
    for (int j = 0; j <= rows; ++j) push(m, {length * i / columns, width * j / rows, 0.0});
  grid_faces(m, columns, rows);
  return m;
}

Mesh graded_disk(int segments, int rings, double r_min) {
  if (segments < 3 || rings < 2 || !(r_min > 0 && r_min < 1)) throw std::invalid_argument("graded_disk: bad arguments");
  std::vector<double> radii;
  const double q = std::pow(1.0 / r_min, 1.0 / (rings - 1));
  for (int k = 0; k < rings; ++k) radii.push_back(k + 1 == rings ? 1.0 : r_min * std::pow(q, k));
  return ring_disk(segments, radii, true);
}

Mesh tiny_huge_torus(int pairs, int n_minor, double tiny) {
  if (pairs < 2 || n_minor < 3 || !(tiny > 0 && tiny < 1)) throw std::invalid_argument("tiny_huge_torus: bad arguments");
  std::vector<double> turns;
  for (int p = 0; p < pairs; ++p) {
    turns.push_back(static_cast<double>(p) / pairs);
    turns.push_back((p + tiny) / pairs);
  }
  return torus_over(turns, n_minor);
}

Mesh nearly_flat_faces(const Mesh& mesh, std::mt19937_64& rng, int count, double exponent_min, double exponent_max) {
  if (count < 0 || !(exponent_min >= 0 && exponent_min <= exponent_max))
    throw std::invalid_argument("nearly_flat_faces: bad arguments");
  Mesh m = mesh;
  for (int i = 0; i < count; ++i) {
    const Index f = uniform_index(rng, m.num_faces());
    const Index a = m.faces[3 * f], b = m.faces[3 * f + 1], c = m.faces[3 * f + 2];
    const double left = std::pow(10.0, -(exponent_min + (exponent_max - exponent_min) * unit_double(rng)));
    const bool cap = i % 2 == 1;
    for (int k = 0; k < 3; ++k) {
      const double goal = cap ? 0.5 * (m.positions[3 * b + k] + m.positions[3 * c + k]) : m.positions[3 * b + k];
      m.positions[3 * a + k] = goal + left * (m.positions[3 * a + k] - goal);
    }
  }
  return m;
}

Mesh random_order(const Mesh& mesh, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const Mesh v = permute_vertices(mesh, rng);
  return permute_faces(v, rng);
}

std::vector<StressMesh> stress_meshes(StressSize size, std::uint64_t seed) {
  const bool small = size == StressSize::Small;
  std::mt19937_64 rng(seed);
  std::vector<StressMesh> out;
  auto add = [&](std::string name, std::string what, Mesh mesh) {
    out.push_back(StressMesh{std::move(name), std::move(what), std::move(mesh)});
  };
  add("needles-caps-torus", "torus, 30% of faces split into needles and caps (angles ~1e-4 rad), E",
      insert_needles_and_caps(small ? torus(24, 12, 1, 0.4) : torus(96, 48, 1, 0.4), rng, 0.3, 1e-4));
  add("needles-caps-sphere", "icosphere, 30% of faces split into needles and caps (angles ~1e-4 rad), S",
      insert_needles_and_caps(icosphere(small ? 3 : 5), rng, 0.3, 1e-4));
  add("needles-caps-pretzel", "genus-2 pretzel, 30% of faces split into needles and caps (angles ~1e-4 rad), H",
      insert_needles_and_caps(pretzel(2, small ? 3 : 6), rng, 0.3, 1e-4));
  add("high-valence-sphere", "latitude-longitude sphere, two poles of valence 512 (1024 medium), S",
      small ? polar_sphere(512, 4) : polar_sphere(1024, 10));
  add("high-valence-disk", "disk with a centre of valence 512 (2048 medium), E",
      small ? fan_disk(512, 3) : fan_disk(2048, 5));
  const Mesh pretzel2 = pretzel(2, small ? 3 : 6);
  add("scale-1e-8-pretzel", "genus-2 pretzel with coordinates x 1e-8, H", scaled(pretzel2, 1e-8));
  add("scale-1e8-pretzel", "genus-2 pretzel with coordinates x 1e8, H", scaled(pretzel2, 1e8));
  add("scale-1e-8-disk", "disk with coordinates x 1e-8, E", scaled(disk(small ? 20 : 50), 1e-8));
  add("scale-1e8-sphere", "icosphere with coordinates x 1e8, S", scaled(icosphere(small ? 3 : 5), 1e8));
  add("pancake", "icosphere squashed to z x 1e-6: top and bottom nearly coplanar, folded at the rim, S",
      pancake(small ? 3 : 5, 1e-6));
  add("accordion", "rectangle folded 6 times (12 medium) into nearly coplanar layers 1e-6 apart, E",
      small ? accordion(6, 8, 12, 1e-6) : accordion(12, 24, 40, 1e-6));
  add("strip-100", "long thin strip, 100 x 1 (flat grid), E",
      small ? strip(200, 2, 100, 1) : strip(1000, 4, 100, 1));
  add("strip-1000", "long thin strip, 1000 x 1 (flat grid; mapped to a disk its ends shrink beyond double range), E",
      small ? strip(1000, 1, 1000, 1) : strip(4000, 2, 1000, 1));
  add("needle-annulus", "annulus of 60 x 40 thin quads (120 x 60 medium): its circle domain squeezes one side into "
      "needles that a face-by-face layout cannot follow, E",
      small ? annulus(60, 40) : annulus(120, 60));
  add("graded-disk", "disk with edges from ~1e-6 to ~0.1 (geometric rings), E",
      small ? graded_disk(32, 60, 1e-6) : graded_disk(64, 150, 1e-6));
  add("tiny-huge-torus", "torus whose meridians alternate gaps of 1e-3 and 1 (relative): tiny edges beside long ones, E",
      small ? tiny_huge_torus(16, 16, 1e-3) : tiny_huge_torus(64, 64, 1e-3));
  add("nearly-flat-torus", "torus with 8 faces made nearly flat (short edges and caps, 1e-8 to 1e-15 of the way left): "
      "mollified, E", nearly_flat_faces(small ? torus(24, 12, 1, 0.4) : torus(96, 48, 1, 0.4), rng, 8, 8, 15));
  add("nearly-flat-pretzel", "genus-2 pretzel with 8 faces made nearly flat (1e-8 to 1e-15 of the way left), H",
      nearly_flat_faces(pretzel2, rng, 8, 8, 15));
  add("scale-1e-300-sphere", "icosphere with coordinates x 1e-300 (positions scaled by a power of two first), S",
      scaled(icosphere(small ? 3 : 5), 1e-300));
  add("scale-1e300-pretzel", "genus-2 pretzel with coordinates x 1e300, H", scaled(pretzel2, 1e300));
  add("random-order-torus", "torus with vertices and faces in random order, E",
      random_order(small ? torus(40, 20, 1, 0.4) : torus(100, 100, 1, 0.4), seed + 1));
  return out;
}

StressMesh large_random_order(std::int64_t faces, std::uint64_t seed) {
  const int n = std::max(3, static_cast<int>(std::lround(std::sqrt(static_cast<double>(faces) / 2))));
  return StressMesh{"random-order-torus-" + std::to_string(2 * static_cast<std::int64_t>(n) * n),
                    "torus with vertices and faces in random order, E", random_order(torus(n, n, 1, 0.4), seed)};
}

double min_angle_radians(const Mesh& mesh) { return min_angle_degrees(mesh) * kPi / 180.0; }

}  // namespace ricci_shapes

namespace ricci_shapes {

namespace {

/// Random vertices whose closed stars are pairwise disjoint and interior (for remove_vertex_stars).
std::vector<Index> disjoint_star_centres(const Mesh& m, std::mt19937_64& rng, int count) {
  std::vector<Index> offsets, nbrs;
  vertex_neighbours(m, offsets, nbrs);
  const Index nv = m.num_vertices();
  std::vector<std::uint8_t> blocked(static_cast<std::size_t>(nv), 0);
  std::vector<Index> centres;
  for (int attempt = 0; attempt < 64 * count && static_cast<int>(centres.size()) < count; ++attempt) {
    const Index v = uniform_index(rng, nv);
    if (blocked[v]) continue;
    centres.push_back(v);
    // Block everything within two steps: the star's link and the links of its link.
    blocked[v] = 1;
    for (Index i = offsets[v]; i < offsets[v + 1]; ++i) {
      const Index w = nbrs[i];
      blocked[w] = 1;
      for (Index j = offsets[w]; j < offsets[w + 1]; ++j) blocked[nbrs[j]] = 1;
    }
  }
  return centres;
}

/// Moves each vertex by up to `amount` × its shortest edge, in the plane of its vertex normal.
void jitter_vertices(Mesh& m, std::mt19937_64& rng, double amount) {
  const Index nv = m.num_vertices();
  std::vector<Vec3> normal(static_cast<std::size_t>(nv), Vec3{0, 0, 0});
  std::vector<double> shortest(static_cast<std::size_t>(nv), INFINITY);
  auto p = [&](Index v) { return Vec3{m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]}; };
  for (Index f = 0; f < m.num_faces(); ++f) {
    const Index a = m.faces[3 * f], b = m.faces[3 * f + 1], c = m.faces[3 * f + 2];
    const Vec3 pa = p(a), pb = p(b), pc = p(c);
    const Vec3 u{pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]}, w{pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
    const Vec3 n{u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    const Index vs[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      for (int d = 0; d < 3; ++d) normal[vs[k]][d] += n[d];
      const Vec3 x = p(vs[k]), y = p(vs[(k + 1) % 3]);
      const double e = std::sqrt((x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) + (x[2] - y[2]) * (x[2] - y[2]));
      shortest[vs[k]] = std::min(shortest[vs[k]], e);
      shortest[vs[(k + 1) % 3]] = std::min(shortest[vs[(k + 1) % 3]], e);
    }
  }
  for (Index v = 0; v < nv; ++v) {
    Vec3 n = normal[v];
    const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(nn > 0) || !std::isfinite(shortest[v])) continue;
    for (double& x : n) x /= nn;
    // A random direction, made tangent.
    Vec3 r{2 * unit_double(rng) - 1, 2 * unit_double(rng) - 1, 2 * unit_double(rng) - 1};
    const double dn = r[0] * n[0] + r[1] * n[1] + r[2] * n[2];
    for (int d = 0; d < 3; ++d) r[d] -= dn * n[d];
    const double rn = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (!(rn > 0)) continue;
    const double step = amount * unit_double(rng) * shortest[v] / rn;
    for (int d = 0; d < 3; ++d) m.positions[3 * v + d] += step * r[d];
  }
}

}  // namespace

RandomSurface random_surface(std::uint64_t seed, Index target_faces) {
  if (target_faces < 500 || target_faces > 200000)
    throw std::invalid_argument("random_surface: target_faces must be in [500, 200000]");
  std::mt19937_64 rng(seed);
  RandomSurface s;
  s.genus = static_cast<int>(uniform_index(rng, 13));
  s.loops = static_cast<int>(uniform_index(rng, 9));
  // About 1/3 of the target from the base; flips keep the count, splits add 2 faces each.
  const double split_fraction = 0.3 * unit_double(rng);
  const double base_target = static_cast<double>(target_faces) / (1 + 2 * split_fraction);
  std::string base;
  if (s.genus == 0) {
    int sub = 1;
    while (sub < 8 && 20.0 * std::pow(4.0, sub + 1) <= base_target * 1.3) ++sub;
    s.mesh = icosphere(sub);
    base = "icosphere(" + std::to_string(sub) + ")";
  } else {
    std::vector<int> divisors;
    for (int d = 1; d <= s.genus; ++d)
      if (s.genus % d == 0) divisors.push_back(d);
    const int rows = divisors[uniform_index(rng, static_cast<Index>(divisors.size()))], cols = s.genus / rows;
    int cells = 2;
    Mesh m = pretzel_grid(cols, rows, cells);
    while (cells < 32 && static_cast<double>(m.num_faces()) < base_target / 1.3) {
      Mesh bigger = pretzel_grid(cols, rows, cells + 1);
      if (static_cast<double>(bigger.num_faces()) > base_target * 1.3) break;
      m = std::move(bigger);
      ++cells;
    }
    s.mesh = std::move(m);
    base = "pretzel_grid(" + std::to_string(cols) + ", " + std::to_string(rows) + ", " + std::to_string(cells) + ")";
  }
  s.mesh = flip_random_edges(s.mesh, rng, 0.3 * unit_double(rng));
  s.mesh = split_random_faces(s.mesh, rng, split_fraction);
  const std::vector<Index> centres = disjoint_star_centres(s.mesh, rng, s.loops);
  s.loops = static_cast<int>(centres.size());
  if (!centres.empty()) s.mesh = remove_vertex_stars(s.mesh, centres);
  s.jitter = 0.3 * unit_double(rng);
  jitter_vertices(s.mesh, rng, s.jitter);
  s.aspect = std::pow(100.0, unit_double(rng));
  for (Index v = 0; v < s.mesh.num_vertices(); ++v) s.mesh.positions[3 * v] *= s.aspect;
  char buf[200];
  std::snprintf(buf, sizeof buf, "seed %llu: genus %d, %d loops, %lld faces, aspect %.1f, jitter %.2f, %s",
                static_cast<unsigned long long>(seed), s.genus, s.loops, static_cast<long long>(s.mesh.num_faces()),
                s.aspect, s.jitter, base.c_str());
  s.description = buf;
  return s;
}

Index random_surface_faces(std::uint64_t seed, Index min_faces, Index max_faces) {
  std::mt19937_64 size_rng(seed ^ 0x5eed5eedULL);
  const double t = unit_double(size_rng);
  return static_cast<Index>(std::lround(static_cast<double>(min_faces) *
                                        std::pow(static_cast<double>(max_faces) / static_cast<double>(min_faces), t)));
}

ricci::ValidateResult validate_as_cli(const Mesh& mesh) {
  ricci::ValidateResult v = ricci::validate_mesh(mesh);
  if (v.status != ricci::Status::Ok || v.topology.is_closed()) return v;
  const ricci::BoundaryMode mode = ricci::natural_boundary_mode(v.topology, ricci::natural_geometry(v.topology));
  const std::vector<Index> ears = ricci::infeasible_ears(v.topology, ricci::uniform_target(v.topology, mode));
  std::string why;
  const ricci::Status split = ears.empty() ? ricci::Status::Ok : ricci::split_ears(v, ears, &why);
  if (split != ricci::Status::Ok) {
    v.status = split;
    v.message = "splitting ears: " + why;
  }
  return v;
}

}  // namespace ricci_shapes
