#include "ricci/topology.h"

#include <algorithm>
#include <string>

#include "edge_table.h"

namespace ricci {

namespace {

TopologyResult failure(Status status, Element element, std::int64_t index, std::string message) {
  TopologyResult r;
  r.status = status;
  r.element = element;
  r.element_index = index;
  r.message = std::move(message);
  return r;
}

std::string face_list(const detail::EdgeTable& table, Index g) {
  std::string s;
  for (Index i = table.group_offsets[g]; i < table.group_offsets[g + 1]; ++i) {
    if (i - table.group_offsets[g] == 6) return s + ", …";
    s += (s.empty() ? "" : ", ") + std::to_string(table.group_corners[i] / 3);
  }
  return s;
}

// Orders the corners of every vertex counter-clockwise (see conventions.h). Returns the first
// vertex whose faces do not form a single fan, or kInvalid.
Index order_fans(Topology& t) {
  const Index nv = t.num_vertices;
  std::vector<Index> unordered = t.vertex_corners;
  for (Index v = 0; v < nv; ++v) {
    const Index b = t.vertex_corner_offsets[v], e = t.vertex_corner_offsets[v + 1];
    if (b == e) continue;
    // Start: the corner with no clockwise neighbour if there is one (boundary), else the smallest.
    Index start = unordered[b];
    for (Index i = b; i < e; ++i) {
      if (t.opposite[prev_corner(unordered[i])] == kInvalid) {
        start = unordered[i];
        break;
      }
    }
    Index c = start, i = b;
    do {
      t.vertex_corners[i++] = c;
      const Index o = t.opposite[next_corner(c)];
      c = (o == kInvalid) ? kInvalid : next_corner(o);
    } while (c != kInvalid && c != start && i < e);
    if (i != e || (c != kInvalid && c != start)) return v;  // several fans around v
  }
  return kInvalid;
}

void trace_boundary_loops(Topology& t, std::span<const Index> faces) {
  const Index nc = t.num_corners();
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(nc), 0);
  t.boundary_offsets.assign(1, 0);
  for (Index start = 0; start < nc; ++start) {
    if (t.opposite[start] != kInvalid || seen[start]) continue;
    Index c = start;
    do {
      seen[c] = 1;
      t.boundary_corners.push_back(c);
      t.boundary_vertices.push_back(faces[next_corner(c)]);
      // The boundary edge leaving the end vertex is opposite prev() of the first corner of its fan.
      const Index w = faces[prev_corner(c)];
      c = prev_corner(t.vertex_corners[t.vertex_corner_offsets[w]]);
    } while (c != start);
    t.boundary_offsets.push_back(static_cast<Index>(t.boundary_corners.size()));
  }
}

void label_components(Topology& t) {
  const Index nf = t.num_faces;
  t.face_component.assign(static_cast<std::size_t>(nf), kInvalid);
  std::vector<Index> queue;
  queue.reserve(static_cast<std::size_t>(nf));
  for (Index seed = 0; seed < nf; ++seed) {
    if (t.face_component[seed] != kInvalid) continue;
    const Index label = t.num_components++;
    t.face_component[seed] = label;
    queue.assign(1, seed);
    for (std::size_t head = 0; head < queue.size(); ++head) {
      for (Index c = 3 * queue[head]; c < 3 * queue[head] + 3; ++c) {
        const Index o = t.opposite[c];
        if (o != kInvalid && t.face_component[o / 3] == kInvalid) {
          t.face_component[o / 3] = label;
          queue.push_back(o / 3);
        }
      }
    }
  }
}

}  // namespace

TopologyResult build_topology(std::span<const Index> faces, Index num_vertices) {
  if (faces.size() % 3 != 0)
    return failure(Status::InvalidArgument, Element::None, -1,
                   "the face buffer holds " + std::to_string(faces.size()) + " indices, not a multiple of 3");
  if (num_vertices < 0)
    return failure(Status::InvalidArgument, Element::None, -1, "negative vertex count");
  if (faces.size() > static_cast<std::size_t>(INT32_MAX - 2))
    return failure(Status::InvalidArgument, Element::None, -1, "too many faces for 32-bit corner indices");
  const Index nc = static_cast<Index>(faces.size());
  const Index nf = nc / 3;
  for (Index f = 0; f < nf; ++f) {
    for (Index k = 0; k < 3; ++k) {
      const Index v = faces[3 * f + k];
      if (v < 0 || v >= num_vertices)
        return failure(Status::IndexOutOfRange, Element::Face, f,
                       "face " + std::to_string(f) + " refers to vertex " + std::to_string(v) + ", but there are " +
                           std::to_string(num_vertices) + " vertices");
    }
    if (!detail::face_is_proper(faces, f, num_vertices))
      return failure(Status::DegenerateFace, Element::Face, f, "face " + std::to_string(f) + " repeats a vertex");
  }

  return detail::topology_from_edge_table(faces, num_vertices, detail::build_edge_table(faces, num_vertices));
}

namespace detail {

TopologyResult topology_from_edge_table(std::span<const Index> faces, Index num_vertices, const EdgeTable& table) {
  const Index nc = static_cast<Index>(faces.size());
  const Index nf = nc / 3;
  TopologyResult r;
  Topology& t = r.topology;
  t.num_vertices = num_vertices;
  t.num_faces = nf;
  t.num_edges = table.num_groups();
  t.corner_vertex.assign(faces.begin(), faces.end());
  t.opposite.assign(static_cast<std::size_t>(nc), kInvalid);
  t.corner_edge.assign(static_cast<std::size_t>(nc), kInvalid);
  t.edge_vertices.resize(2 * static_cast<std::size_t>(t.num_edges));
  t.edge_corners.resize(2 * static_cast<std::size_t>(t.num_edges));
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index size = table.group_size(e);
    const Index c0 = table.group_corners[table.group_offsets[e]];
    if (size > 2) {
      return failure(Status::NonManifoldEdge, Element::Face, c0 / 3,
                     "edge (" + std::to_string(faces[next_corner(c0)]) + ", " + std::to_string(faces[prev_corner(c0)]) +
                         ") is shared by " + std::to_string(size) + " faces (" + face_list(table, e) + ")");
    }
    const Index c1 = size == 2 ? table.group_corners[table.group_offsets[e] + 1] : kInvalid;
    if (c1 != kInvalid && detail::edge_from(faces, c0) == detail::edge_from(faces, c1)) {
      return failure(Status::InconsistentOrientation, Element::Face, c1 / 3,
                     "faces " + std::to_string(c0 / 3) + " and " + std::to_string(c1 / 3) + " traverse edge (" +
                         std::to_string(detail::edge_from(faces, c0)) + ", " + std::to_string(detail::edge_to(faces, c0)) +
                         ") in the same direction");
    }
    t.edge_corners[2 * e] = c0;
    t.edge_corners[2 * e + 1] = c1;
    t.edge_vertices[2 * e] = detail::edge_from(faces, c0);
    t.edge_vertices[2 * e + 1] = detail::edge_to(faces, c0);
    t.corner_edge[c0] = e;
    if (c1 != kInvalid) {
      t.corner_edge[c1] = e;
      t.opposite[c0] = c1;
      t.opposite[c1] = c0;
    }
  }

  // Vertex → corners, by counting sort, then ordered into fans.
  t.vertex_corner_offsets.assign(static_cast<std::size_t>(num_vertices) + 1, 0);
  for (Index c = 0; c < nc; ++c) ++t.vertex_corner_offsets[faces[c] + 1];
  for (Index v = 0; v < num_vertices; ++v) t.vertex_corner_offsets[v + 1] += t.vertex_corner_offsets[v];
  t.vertex_corners.resize(static_cast<std::size_t>(nc));
  {
    std::vector<Index> fill(t.vertex_corner_offsets.begin(), t.vertex_corner_offsets.end() - 1);
    for (Index c = 0; c < nc; ++c) t.vertex_corners[fill[faces[c]]++] = c;
  }
  if (const Index v = order_fans(t); v != kInvalid) {
    return failure(Status::NonManifoldVertex, Element::Vertex, v,
                   "the faces around vertex " + std::to_string(v) + " form more than one fan (pinched vertex)");
  }
  trace_boundary_loops(t, faces);
  label_components(t);
  r.status = Status::Ok;
  r.message = "ok";
  return r;
}

}  // namespace detail

namespace {

// cut_open()'s vertex copies: the cut faces, the copies' surface vertices and their fans (CSR,
// each fan in the order build_topology() gives it).
void cut_open_fans(const Topology& t, std::span<const char> cut, CutOpenResult& r) {
  Topology& d = r.topology;
  const Index V = t.num_vertices;
  r.faces.assign(static_cast<std::size_t>(t.num_corners()), kInvalid);
  r.to_surface.clear();
  d.vertex_corners.resize(static_cast<std::size_t>(t.num_corners()));
  d.vertex_corner_offsets.assign(1, 0);
  Index pos = 0;
  for (Index v = 0; v < V; ++v) {
    const Index o0 = t.vertex_corner_offsets[v], m = t.valence(v);
    if (m == 0) continue;
    auto corner = [&](Index j) { return t.vertex_corners[o0 + j % m]; };
    // the edge crossed from fan corner j-1 to fan corner j
    auto cut_before = [&](Index j) { return cut[t.corner_edge[next_corner(corner(j + m - 1))]] != 0; };
    Index j0 = 0;
    if (!t.is_boundary_vertex(v))
      for (Index j = 0; j < m; ++j)
        if (cut_before(j)) {
          j0 = j;
          break;
        }
    Index copy = kInvalid;
    for (Index k = 0; k < m; ++k) {
      const Index j = j0 + k;
      if (k == 0 || cut_before(j)) {
        if (k > 0) d.vertex_corner_offsets.push_back(pos);
        copy = static_cast<Index>(r.to_surface.size());
        r.to_surface.push_back(v);
      }
      r.faces[corner(j)] = copy;
      d.vertex_corners[pos++] = corner(j);
    }
    d.vertex_corner_offsets.push_back(pos);
  }
}

// cut_open()'s edges, numbered as build_topology() numbers them: by (smaller, larger) vertex
// copy. Copies are numbered in surface-vertex order, so the order differs from the surface's only
// inside a run of surface edges with the same smaller vertex, which is sorted. False when two
// edges join the same two copies.
bool cut_open_edges(const Topology& t, std::span<const char> cut, CutOpenResult& r) {
  Topology& d = r.topology;
  const std::vector<Index>& f = r.faces;
  struct Rec {
    Index lo, hi, c0, c1;
  };
  std::vector<Rec> run;
  d.edge_vertices.clear();
  d.edge_corners.clear();
  d.edge_vertices.reserve(2 * static_cast<std::size_t>(t.num_edges) + 64);
  d.edge_corners.reserve(2 * static_cast<std::size_t>(t.num_edges) + 64);
  auto add = [&](Index c0, Index c1) {
    const Index a = f[next_corner(c0)], b = f[prev_corner(c0)];
    run.push_back({std::min(a, b), std::max(a, b), c0, c1});
  };
  auto flush = [&]() {
    std::sort(run.begin(), run.end(), [](const Rec& x, const Rec& y) {
      return x.lo != y.lo ? x.lo < y.lo : x.hi < y.hi;
    });
    for (std::size_t i = 0; i < run.size(); ++i) {
      if (i > 0 && run[i].lo == run[i - 1].lo && run[i].hi == run[i - 1].hi) return false;
      const Index e = static_cast<Index>(d.edge_corners.size() / 2), c0 = run[i].c0, c1 = run[i].c1;
      d.edge_corners.push_back(c0);
      d.edge_corners.push_back(c1);
      d.edge_vertices.push_back(f[next_corner(c0)]);
      d.edge_vertices.push_back(f[prev_corner(c0)]);
      d.corner_edge[c0] = e;
      if (c1 != kInvalid) {
        d.corner_edge[c1] = e;
        d.opposite[c0] = c1;
        d.opposite[c1] = c0;
      }
    }
    run.clear();
    return true;
  };
  Index run_lo = kInvalid;
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index lo = std::min(t.edge_vertices[2 * e], t.edge_vertices[2 * e + 1]);
    if (lo != run_lo && !flush()) return false;
    run_lo = lo;
    const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
    if (c1 != kInvalid && cut[e]) {
      add(c0, kInvalid);
      add(c1, kInvalid);
    } else {
      add(c0, c1);
    }
  }
  if (!flush()) return false;
  d.num_edges = static_cast<Index>(d.edge_corners.size() / 2);
  return true;
}

}  // namespace

bool is_topology_of(const Topology& t, std::span<const Index> faces, Index num_vertices) {
  return t.num_vertices == num_vertices && t.corner_vertex.size() == faces.size() &&
         std::equal(faces.begin(), faces.end(), t.corner_vertex.begin());
}

CutOpenResult cut_open(const Topology& t, std::span<const char> cut) {
  CutOpenResult r;
  cut_open(t, cut, r);
  return r;
}

void cut_open(const Topology& t, std::span<const char> cut, CutOpenResult& r) {
  // What the steps below fill by appending or counting starts empty; the rest is assigned whole.
  r.to_surface.clear();
  Topology& d = r.topology;
  d.boundary_offsets.clear();
  d.boundary_vertices.clear();
  d.boundary_corners.clear();
  d.num_components = 0;
  if (cut.size() != static_cast<std::size_t>(t.num_edges)) {
    r.status = Status::InvalidArgument;
    r.message = "cut_open: " + std::to_string(cut.size()) + " cut flags for " + std::to_string(t.num_edges) + " edges";
    r.faces.clear();
    d = Topology{};
    return;
  }
  cut_open_fans(t, cut, r);
  const Index nc = t.num_corners();
  const Index copies = static_cast<Index>(r.to_surface.size());
  d.num_vertices = copies;
  d.num_faces = t.num_faces;
  d.corner_vertex = r.faces;
  d.opposite.assign(static_cast<std::size_t>(nc), kInvalid);
  d.corner_edge.assign(static_cast<std::size_t>(nc), kInvalid);
  if (!cut_open_edges(t, cut, r)) {
    // Two copies of a cut edge join the same two copies: build_topology() decides.
    TopologyResult tr = build_topology(r.faces, copies);
    r.status = tr.status;
    r.message = tr.message;
    r.topology = std::move(tr.topology);
    return;
  }
  trace_boundary_loops(d, r.faces);
  label_components(d);
  r.status = Status::Ok;
  r.message = "ok";
}

}  // namespace ricci
