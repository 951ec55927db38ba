#include "edge_table.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

namespace ricci::detail {

DisjointSets::DisjointSets(Index n) : parent_(static_cast<std::size_t>(n)) {
  std::iota(parent_.begin(), parent_.end(), Index{0});
}

Index DisjointSets::find(Index x) {
  while (parent_[x] != x) {
    parent_[x] = parent_[parent_[x]];
    x = parent_[x];
  }
  return x;
}

void DisjointSets::unite(Index a, Index b) {
  a = find(a);
  b = find(b);
  if (a == b) return;
  if (a < b) std::swap(a, b);
  parent_[a] = b;
}

namespace {

bool included(std::span<const std::uint8_t> face_ok, Index f) { return face_ok.empty() || face_ok[f]; }

// Counting sort of items by an integer key in [0, num_keys): returns CSR offsets and the items
// in key order (stable: items of one key keep their input order).
template <class KeyOf>
void bucket_by_key(Index num_items, Index num_keys, KeyOf key_of, std::vector<Index>* offsets,
                   std::vector<Index>* items) {
  offsets->assign(static_cast<std::size_t>(num_keys) + 1, 0);
  for (Index i = 0; i < num_items; ++i) {
    const Index k = key_of(i);
    if (k >= 0) ++(*offsets)[k + 1];
  }
  for (Index k = 0; k < num_keys; ++k) (*offsets)[k + 1] += (*offsets)[k];
  items->resize(static_cast<std::size_t>(offsets->back()));
  std::vector<Index> fill(offsets->begin(), offsets->end() - 1);
  for (Index i = 0; i < num_items; ++i) {
    const Index k = key_of(i);
    if (k >= 0) (*items)[fill[k]++] = i;
  }
}

}  // namespace

EdgeTable build_edge_table(std::span<const Index> faces, Index num_vertices,
                           std::span<const std::uint8_t> face_ok) {
  const Index nc = static_cast<Index>(faces.size());
  auto lo_of = [&](Index c) -> Index {
    if (!included(face_ok, c / 3)) return kInvalid;
    return std::min(edge_from(faces, c), edge_to(faces, c));
  };
  auto hi_of = [&](Index c) { return std::max(edge_from(faces, c), edge_to(faces, c)); };
  std::vector<Index> offsets, corners;
  bucket_by_key(nc, num_vertices, lo_of, &offsets, &corners);

  // Per smaller vertex, its corners sorted by (larger vertex, corner); a run of one larger vertex
  // is a group. Buckets are disjoint, so vertices go in parallel: first the sort and the count of
  // groups, then (after the counts' prefix sums) the groups' offsets and labels. The result does
  // not depend on the number of threads.
  std::vector<Index> groups_before(static_cast<std::size_t>(num_vertices) + 1, 0);
  const bool parallel = num_vertices > 4096;
#pragma omp parallel for schedule(static) if (parallel)
  for (Index v = 0; v < num_vertices; ++v) {
    const auto first = corners.begin() + offsets[v], last = corners.begin() + offsets[v + 1];
    // Buckets hold about the valence: insertion sort by (hi, corner) when small (corners arrive
    // ascending, the sort is stable), std::sort for high-valence vertices.
    if (last - first > 32) {
      std::sort(first, last, [&](Index a, Index b) { return std::pair(hi_of(a), a) < std::pair(hi_of(b), b); });
    } else {
      for (auto it = first; it != last; ++it) {
        const Index c = *it;
        auto j = it;
        while (j != first && hi_of(*(j - 1)) > hi_of(c)) {
          *j = *(j - 1);
          --j;
        }
        *j = c;
      }
    }
    Index groups = 0;
    for (auto it = first; it != last; ++it)
      if (it == first || hi_of(*it) != hi_of(*(it - 1))) ++groups;
    groups_before[v + 1] = groups;
  }
  for (Index v = 0; v < num_vertices; ++v) groups_before[v + 1] += groups_before[v];

  EdgeTable t;
  t.corner_group.assign(static_cast<std::size_t>(nc), kInvalid);
  t.group_offsets.resize(static_cast<std::size_t>(groups_before[num_vertices]) + 1);
  t.group_offsets.back() = static_cast<Index>(corners.size());
#pragma omp parallel for schedule(static) if (parallel)
  for (Index v = 0; v < num_vertices; ++v) {
    Index g = groups_before[v];
    for (Index i = offsets[v]; i < offsets[v + 1]; ++g) {
      const Index hi = hi_of(corners[i]);
      t.group_offsets[g] = i;
      for (; i < offsets[v + 1] && hi_of(corners[i]) == hi; ++i) t.corner_group[corners[i]] = g;
    }
  }
  t.group_corners = std::move(corners);
  return t;
}

std::int64_t count_inconsistent_edges(std::span<const Index> faces, const EdgeTable& table) {
  std::int64_t n = 0;
  const Index groups = table.num_groups();
#pragma omp parallel for schedule(static) reduction(+ : n) if (groups > 16384)
  for (Index g = 0; g < groups; ++g) {
    if (table.group_size(g) != 2) continue;
    const Index c0 = table.group_corners[table.group_offsets[g]];
    const Index c1 = table.group_corners[table.group_offsets[g] + 1];
    if (edge_from(faces, c0) == edge_from(faces, c1)) ++n;
  }
  return n;
}

TriangleShape triangle_shape(const double* p, const double* q, const double* r, bool with_angles) {
  TriangleShape s;
  double u[3], v[3], w[3];  // u = q - p, v = r - p, w = r - q
  double scale = 0;
  for (int d = 0; d < 3; ++d) {
    if (!std::isfinite(p[d]) || !std::isfinite(q[d]) || !std::isfinite(r[d])) return s;
    u[d] = q[d] - p[d];
    v[d] = r[d] - p[d];
    w[d] = r[d] - q[d];
    if (!std::isfinite(u[d]) || !std::isfinite(v[d]) || !std::isfinite(w[d])) return s;
    scale = std::max({scale, std::abs(u[d]), std::abs(v[d])});
  }
  s.finite = true;
  if (scale == 0) return s;  // all three points coincide
  for (int d = 0; d < 3; ++d) {
    u[d] /= scale;
    v[d] /= scale;
    w[d] /= scale;
  }
  auto dot = [](const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  auto cross_norm = [](const double* a, const double* b) {
    return std::hypot(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]);
  };
  const double twice_area = cross_norm(u, v);
  const double longest2 = std::max({dot(u, u), dot(v, v), dot(w, w)});
  s.area_ratio = twice_area / longest2;
  if (!with_angles) return s;
  // Angles: at p between u and v; at q between -u and w; at r between -v and -w.
  // |a × b| is the same 2·area for every pair, so only the dot products differ.
  s.angles[0] = std::atan2(twice_area, dot(u, v));
  s.angles[1] = std::atan2(twice_area, -dot(u, w));
  s.angles[2] = std::atan2(twice_area, dot(v, w));
  return s;
}

std::vector<Index> find_duplicate_faces(std::span<const Index> faces, Index nv,
                                        std::span<const std::uint8_t> face_ok) {
  const Index nf = static_cast<Index>(faces.size() / 3);
  auto sorted = [&](Index f) {
    std::array<Index, 3> k{faces[3 * f], faces[3 * f + 1], faces[3 * f + 2]};
    std::sort(k.begin(), k.end());
    return k;
  };
  std::vector<Index> offsets, order;
  bucket_by_key(
      nf, nv, [&](Index f) { return included(face_ok, f) ? sorted(f)[0] : kInvalid; }, &offsets, &order);
  std::vector<Index> dup(static_cast<std::size_t>(nf), kInvalid);
  std::vector<std::pair<std::array<Index, 3>, Index>> bucket;
  for (Index v = 0; v < nv; ++v) {
    if (offsets[v + 1] - offsets[v] < 2) continue;
    bucket.clear();
    for (Index i = offsets[v]; i < offsets[v + 1]; ++i) bucket.emplace_back(sorted(order[i]), order[i]);
    std::sort(bucket.begin(), bucket.end());
    for (std::size_t i = 1; i < bucket.size(); ++i)
      if (bucket[i].first == bucket[i - 1].first)
        dup[bucket[i].second] = dup[bucket[i - 1].second] == kInvalid ? bucket[i - 1].second
                                                                       : dup[bucket[i - 1].second];
  }
  return dup;
}

Index face_components_by_vertex(std::span<const Index> faces, Index num_vertices, std::vector<Index>* label) {
  const Index nf = static_cast<Index>(faces.size() / 3);
  DisjointSets sets(num_vertices);
  for (Index f = 0; f < nf; ++f) {
    sets.unite(faces[3 * f], faces[3 * f + 1]);
    sets.unite(faces[3 * f], faces[3 * f + 2]);
  }
  std::vector<Index> root_label(static_cast<std::size_t>(num_vertices), kInvalid);
  label->assign(static_cast<std::size_t>(nf), kInvalid);
  Index count = 0;
  for (Index f = 0; f < nf; ++f) {
    const Index r = sets.find(faces[3 * f]);
    if (root_label[r] == kInvalid) root_label[r] = count++;
    (*label)[f] = root_label[r];
  }
  return count;
}

Orientation orient_faces(std::span<const Index> faces, const EdgeTable& table,
                         std::span<const std::uint8_t> face_ok) {
  const Index nf = static_cast<Index>(faces.size() / 3);
  Orientation o;
  o.flip.assign(static_cast<std::size_t>(nf), 0);
  o.patch.assign(static_cast<std::size_t>(nf), kInvalid);
  o.inconsistent_edges = count_inconsistent_edges(faces, table);
  std::vector<Index> queue;
  queue.reserve(static_cast<std::size_t>(nf));
  for (Index seed = 0; seed < nf; ++seed) {
    if (!included(face_ok, seed) || o.patch[seed] != kInvalid) continue;
    const Index patch = o.num_patches++;
    o.patch[seed] = patch;
    queue.clear();
    queue.push_back(seed);
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const Index f = queue[head];
      for (Index c = 3 * f; c < 3 * f + 3; ++c) {
        const Index g = table.corner_group[c];
        if (g == kInvalid || table.group_size(g) != 2) continue;
        const Index first = table.group_corners[table.group_offsets[g]];
        const Index other = first == c ? table.group_corners[table.group_offsets[g] + 1] : first;
        const Index h = other / 3;
        // Opposite traversal means the two faces agree as they stand.
        const bool agree = edge_from(faces, other) == edge_to(faces, c);
        const std::uint8_t want = agree ? o.flip[f] : static_cast<std::uint8_t>(1 - o.flip[f]);
        if (o.patch[h] == kInvalid) {
          o.patch[h] = patch;
          o.flip[h] = want;
          queue.push_back(h);
        } else if (o.flip[h] != want && o.orientable) {
          o.orientable = false;
          o.conflict_face = h;
        }
      }
    }
  }
  return o;
}

}  // namespace ricci::detail
