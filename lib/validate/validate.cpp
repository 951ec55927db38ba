#include "ricci/validate.h"

#include <algorithm>
#include <cmath>
#include <new>
#include <optional>
#include <string>

#include "edge_table.h"

namespace ricci {

std::string_view repair_name(RepairKind k) {
  switch (k) {
    case RepairKind::UnreferencedVerticesDropped: return "unreferenced_vertices_dropped";
    case RepairKind::FacesFlipped: return "faces_flipped";
    case RepairKind::ComponentsDropped: return "components_dropped";
    case RepairKind::PolygonsTriangulated: return "polygons_triangulated";
    case RepairKind::EarsSplit: return "ears_split";
    case RepairKind::LengthsMollified: return "lengths_mollified";
  }
  return "unknown_repair";
}

bool ValidateOptions::is_valid(std::string* why) const {
  if (!(degenerate_tolerance >= 0 && degenerate_tolerance < 1)) {
    if (why) *why = "degenerate_tolerance must be in [0, 1)";
    return false;
  }
  return true;
}

namespace {

using detail::edge_from;
using detail::edge_to;

std::string str(std::int64_t i) { return std::to_string(i); }

ValidateResult fail(Status status, Element element, std::int64_t index, std::string message) {
  ValidateResult r;
  r.status = status;
  r.element = element;
  r.element_index = index;
  r.message = std::move(message);
  return r;
}

const double* position(const Mesh& m, Index v) { return &m.positions[3 * static_cast<std::size_t>(v)]; }

// The face's area ratio (no angles: the zero-area check reads nothing else).
detail::TriangleShape shape_of(const Mesh& m, std::span<const Index> faces, Index f) {
  return detail::triangle_shape(position(m, faces[3 * f]), position(m, faces[3 * f + 1]),
                                position(m, faces[3 * f + 2]), false);
}

// Signed volume enclosed by the faces (with the given flips) after capping every boundary loop
// with a fan from the loop's centroid, and the total area. Used to pick the outward orientation.
struct VolumeArea {
  double volume = 0;
  double area = 0;
};
VolumeArea capped_volume(const Mesh& m, std::span<const Index> faces, const detail::EdgeTable& table,
                         const std::vector<std::uint8_t>& flip) {
  const Index nv = m.num_vertices(), nf = static_cast<Index>(faces.size() / 3);
  double centre[3] = {0, 0, 0};  // centroid of the face vertices (with multiplicity)
  for (Index v : faces)
    for (int d = 0; d < 3; ++d) centre[d] += position(m, v)[d] / static_cast<double>(faces.size());
  auto rel = [&](Index v, double* out) {
    for (int d = 0; d < 3; ++d) out[d] = position(m, v)[d] - centre[d];
  };
  auto det = [](const double* a, const double* b, const double* c) {
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
  };
  VolumeArea va;
  double p[3], q[3], r[3];
  for (Index f = 0; f < nf; ++f) {
    rel(faces[3 * f], p);
    rel(faces[3 * f + (flip[f] ? 2 : 1)], q);
    rel(faces[3 * f + (flip[f] ? 1 : 2)], r);
    va.volume += det(p, q, r) / 6;
    const double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, w[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
    va.area += 0.5 * std::hypot(u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]);
  }
  // Boundary edges as oriented after the flips; loops are the components of the boundary graph.
  detail::DisjointSets loops(nv);
  std::vector<std::pair<Index, Index>> edges;
  for (Index g = 0; g < table.num_groups(); ++g) {
    if (table.group_size(g) != 1) continue;
    const Index c = table.group_corners[table.group_offsets[g]];
    Index a = edge_from(faces, c), b = edge_to(faces, c);
    if (flip[c / 3]) std::swap(a, b);
    edges.emplace_back(a, b);
    loops.unite(a, b);
  }
  std::vector<double> sum(3 * static_cast<std::size_t>(nv), 0.0);
  std::vector<Index> count(static_cast<std::size_t>(nv), 0);
  for (const auto& [a, b] : edges) {
    const Index l = loops.find(a);
    rel(a, p);
    for (int d = 0; d < 3; ++d) sum[3 * l + d] += p[d];
    ++count[l];
  }
  for (const auto& [a, b] : edges) {
    const Index l = loops.find(a);
    double c[3];
    for (int d = 0; d < 3; ++d) c[d] = sum[3 * l + d] / count[l];
    rel(a, p);
    rel(b, q);
    va.volume += det(c, q, p) / 6;  // the cap runs against the loop
  }
  return va;
}

// ---- validate_mesh(), check by check: each returns the failure, if any ----

// 2–4: face indices in range, finite coordinates of used vertices, no face repeating a vertex.
std::optional<ValidateResult> check_indices(const Mesh& input) {
  const Index nv = input.num_vertices();
  const Index nf = input.num_faces();
  const std::span<const Index> in_faces(input.faces);
  for (Index f = 0; f < nf; ++f) {
    for (Index k = 0; k < 3; ++k) {
      const Index v = in_faces[3 * f + k];
      if (v < 0 || v >= nv)
        return fail(Status::IndexOutOfRange, Element::Face, f,
                    "face " + str(f) + " refers to vertex " + str(v) + ", but the mesh has " + str(nv) + " vertices");
    }
  }
  {
    std::vector<std::uint8_t> used(static_cast<std::size_t>(nv), 0);
    for (Index v : in_faces) used[v] = 1;
    for (Index v = 0; v < nv; ++v) {
      const double* p = position(input, v);
      if (used[v] && !(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])))
        return fail(Status::NonFiniteCoordinate, Element::Vertex, v,
                    "vertex " + str(v) + " has a non-finite coordinate (" + std::to_string(p[0]) + ", " +
                        std::to_string(p[1]) + ", " + std::to_string(p[2]) + ")");
    }
  }
  for (Index f = 0; f < nf; ++f)
    if (!detail::face_is_proper(in_faces, f, nv))
      return fail(Status::DegenerateFace, Element::Face, f,
                  "face " + str(f) + " repeats a vertex (" + str(in_faces[3 * f]) + ", " + str(in_faces[3 * f + 1]) +
                      ", " + str(in_faces[3 * f + 2]) + ")");

  return std::nullopt;
}

// 5: components (through shared vertices): one, or the largest kept on request (a repair).
// kept_faces: the input faces kept, ascending.
std::optional<ValidateResult> keep_component(const Mesh& input, const ValidateOptions& options, ValidateResult& r,
                                             std::vector<Index>& kept_faces) {
  const Index nv = input.num_vertices();
  const Index nf = input.num_faces();
  const std::span<const Index> in_faces(input.faces);
  std::vector<Index> component;
  const Index num_components = detail::face_components_by_vertex(in_faces, nv, &component);
  kept_faces.reserve(static_cast<std::size_t>(nf));
  if (num_components > 1) {
    std::vector<Index> size(static_cast<std::size_t>(num_components), 0);
    for (Index f = 0; f < nf; ++f) ++size[component[f]];
    // Labels are numbered by smallest face, so the first maximum is the one with the smallest face.
    const Index largest = static_cast<Index>(std::max_element(size.begin(), size.end()) - size.begin());
    if (!options.keep_largest_component) {
      return fail(Status::MultipleComponents, Element::Face, 0,
                  "the mesh has " + str(num_components) + " connected components (the largest has " + str(size[largest]) +
                      " of " + str(nf) + " faces); keep only the largest component or split the file");
    }
    for (Index f = 0; f < nf; ++f)
      if (component[f] == largest) kept_faces.push_back(f);
    r.repairs.push_back({RepairKind::ComponentsDropped, num_components - 1,
                         "kept the largest of " + str(num_components) + " components (" + str(size[largest]) + " of " +
                             str(nf) + " faces); dropped " + str(nf - size[largest]) + " faces"});
  } else {
    for (Index f = 0; f < nf; ++f) kept_faces.push_back(f);
  }

  return std::nullopt;
}

// 6–7: no face of zero area (naming why), no two faces on the same vertices. faces: the kept
// faces in input vertex numbering.
std::optional<ValidateResult> check_faces(const Mesh& input, const ValidateOptions& options,
                                          std::span<const Index> faces, std::span<const Index> kept_faces) {
  const Index nv = input.num_vertices();
  const Index kf = static_cast<Index>(kept_faces.size());
  // 6: zero area (the first such face, found in parallel).
  Index first = kf;
#pragma omp parallel for schedule(static) reduction(min : first)
  for (Index i = 0; i < kf; ++i)
    if (detail::is_degenerate(shape_of(input, faces, i), options.degenerate_tolerance)) first = std::min(first, i);
  if (first < kf) {
    const Index i = first;
    const Index f = kept_faces[i];
    // Name why: two vertices at one position, or three on a line. (Faces of small but
    // non-zero area pass: the metric mollifies them, mollify_lengths().)
    std::string why = "its vertices are collinear";
    for (int k = 0; k < 3; ++k) {
      const Index a = faces[3 * i + k], b = faces[3 * i + (k + 1) % 3];
      const double* p = &input.positions[3 * static_cast<std::size_t>(a)];
      const double* q = &input.positions[3 * static_cast<std::size_t>(b)];
      if (p[0] == q[0] && p[1] == q[1] && p[2] == q[2]) {
        why = "vertices " + str(std::min(a, b)) + " and " + str(std::max(a, b)) + " are at the same position";
        break;
      }
    }
    return fail(Status::DegenerateFace, Element::Face, f,
                "face " + str(f) + " (vertices " + str(faces[3 * i]) + ", " + str(faces[3 * i + 1]) + ", " +
                    str(faces[3 * i + 2]) + ") has zero area: " + why);
  }
  // 7: duplicates.
  {
    const auto dup = detail::find_duplicate_faces(faces, nv);
    for (Index i = 0; i < kf; ++i)
      if (dup[i] != kInvalid)
        return fail(Status::DuplicateFace, Element::Face, kept_faces[i],
                    "faces " + str(kept_faces[dup[i]]) + " and " + str(kept_faces[i]) + " use the same vertices (" +
                        str(faces[3 * i]) + ", " + str(faces[3 * i + 1]) + ", " + str(faces[3 * i + 2]) + ")");
  }
  return std::nullopt;
}

// 8: no edge with more than two faces.
std::optional<ValidateResult> check_edges(std::span<const Index> faces, std::span<const Index> kept_faces,
                                          const detail::EdgeTable& table) {
  for (Index g = 0; g < table.num_groups(); ++g) {
    if (table.group_size(g) <= 2) continue;
    const Index c = table.group_corners[table.group_offsets[g]];
    std::string list;
    for (Index j = table.group_offsets[g]; j < table.group_offsets[g + 1] && j < table.group_offsets[g] + 6; ++j)
      list += (list.empty() ? "" : ", ") + str(kept_faces[table.group_corners[j] / 3]);
    return fail(Status::NonManifoldEdge, Element::Face, kept_faces[c / 3],
                "edge (" + str(edge_from(faces, c)) + ", " + str(edge_to(faces, c)) + ") is shared by " +
                    str(table.group_size(g)) + " faces (" + list + (table.group_size(g) > 6 ? ", …" : "") + ")");
  }
  return std::nullopt;
}

// 9: an orientable surface, its faces flipped to one orientation when they disagree (a repair);
// orient.flip then says which kept faces were flipped.
std::optional<ValidateResult> orient_surface(const Mesh& input, const ValidateOptions& options,
                                             const detail::EdgeTable& table, std::span<const Index> kept_faces,
                                             std::vector<Index>& faces, detail::Orientation& orient, ValidateResult& r) {
  const std::span<const Index> in_faces(input.faces);
  const Index kf = static_cast<Index>(kept_faces.size());
  if (!orient.orientable)
    return fail(Status::NonOrientable, Element::Face, kept_faces[orient.conflict_face],
                "the surface is not orientable: no choice of face orientations is consistent (conflict at face " +
                    str(kept_faces[orient.conflict_face]) + ")");
  if (orient.inconsistent_edges > 0) {
    if (!options.repair_orientation)
      return fail(Status::InconsistentOrientation, Element::None, -1,
                  str(orient.inconsistent_edges) + " edges are traversed in the same direction by both their faces");
    // Per edge-connected patch, choose between the breadth-first orientation and its reverse:
    // the one enclosing positive volume (holes capped) when that is meaningful, else the one
    // that keeps the larger area of faces as they were.
    std::vector<std::uint8_t> patch_flip(static_cast<std::size_t>(orient.num_patches), 0);
    const VolumeArea va = capped_volume(input, faces, table, orient.flip);
    std::vector<double> kept_area(static_cast<std::size_t>(orient.num_patches), 0.0),
        flipped_area(static_cast<std::size_t>(orient.num_patches), 0.0);
    for (Index i = 0; i < kf; ++i) {
      const double* p = position(input, faces[3 * i]);
      const double* q = position(input, faces[3 * i + 1]);
      const double* w = position(input, faces[3 * i + 2]);
      const double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, v[3] = {w[0] - p[0], w[1] - p[1], w[2] - p[2]};
      const double a = std::hypot(u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]);
      (orient.flip[i] ? flipped_area : kept_area)[orient.patch[i]] += a;
    }
    const bool volume_decides = orient.num_patches == 1 && std::abs(va.volume) > 1e-4 * std::pow(va.area, 1.5);
    for (Index p = 0; p < orient.num_patches; ++p)
      patch_flip[p] = volume_decides ? va.volume < 0 : flipped_area[p] > kept_area[p];
    std::int64_t flipped = 0;
    for (Index i = 0; i < kf; ++i) {
      if (orient.flip[i] != patch_flip[orient.patch[i]]) {
        std::swap(faces[3 * i + 1], faces[3 * i + 2]);
        ++flipped;
      }
    }
    r.repairs.push_back({RepairKind::FacesFlipped, flipped,
                         "flipped " + str(flipped) + " faces to orient the surface consistently (" +
                             str(orient.inconsistent_edges) + " edges were inconsistent; kept the " +
                             (volume_decides ? "outward" : "majority") + " orientation)"});
    for (Index i = 0; i < kf; ++i) orient.flip[i] = faces[3 * i + 1] != in_faces[3 * kept_faces[i] + 1];
  } else {
    std::fill(orient.flip.begin(), orient.flip.end(), 0);
  }

  return std::nullopt;
}

// The validated mesh: vertices no kept face uses dropped (a repair), the rest renumbered in
// input order, texture coordinates carried along (their corners flipped with their faces).
void compact_mesh(const Mesh& input, std::span<const Index> faces, std::span<const Index> kept_faces,
                  const std::vector<std::uint8_t>& flip, ValidateResult& r) {
  const Index nv = input.num_vertices();
  const Index kf = static_cast<Index>(kept_faces.size());
  const std::span<const Index> in_faces(input.faces);
  std::vector<Index> new_index(static_cast<std::size_t>(nv), kInvalid);
  {
    std::vector<std::uint8_t> used_in_input(static_cast<std::size_t>(nv), 0);
    for (Index v : in_faces) used_in_input[v] = 1;
    std::int64_t unreferenced = 0;
    Index first_unreferenced = kInvalid;
    for (Index v = 0; v < nv; ++v) {
      if (!used_in_input[v]) {
        if (first_unreferenced == kInvalid) first_unreferenced = v;
        ++unreferenced;
      }
    }
    if (unreferenced > 0)
      r.repairs.push_back({RepairKind::UnreferencedVerticesDropped, unreferenced,
                           "dropped " + str(unreferenced) + " vertices used by no face (first: vertex " +
                               str(first_unreferenced) + ")"});
  }
  for (Index v : faces) new_index[v] = 0;
  for (Index v = 0; v < nv; ++v) {
    if (new_index[v] == kInvalid) continue;
    new_index[v] = static_cast<Index>(r.vertex_to_input.size());
    r.vertex_to_input.push_back(v);
  }
  r.face_to_input.assign(kept_faces.begin(), kept_faces.end());
  Mesh& out = r.mesh;
  out.positions.reserve(3 * r.vertex_to_input.size());
  for (Index v : r.vertex_to_input) out.positions.insert(out.positions.end(), position(input, v), position(input, v) + 3);
  out.faces.resize(faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i) out.faces[i] = new_index[faces[i]];
  if (input.has_texcoords()) {
    out.texcoords = input.texcoords;
    out.corner_texcoords.resize(faces.size());
    for (Index i = 0; i < kf; ++i) {
      const Index f = kept_faces[i];
      out.corner_texcoords[3 * i] = input.corner_texcoords[3 * f];
      out.corner_texcoords[3 * i + 1] = input.corner_texcoords[3 * f + (flip[i] ? 2 : 1)];
      out.corner_texcoords[3 * i + 2] = input.corner_texcoords[3 * f + (flip[i] ? 1 : 2)];
    }
  }

}

}  // namespace

ValidateResult validate_mesh(const Mesh& input, const ValidateOptions& options) try {
  if (std::string why; !options.is_valid(&why)) return fail(Status::InvalidArgument, Element::None, -1, why);
  const Index nv = input.num_vertices();
  const Index nf = input.num_faces();
  if (input.faces.size() % 3 != 0 || input.positions.size() % 3 != 0)
    return fail(Status::InvalidArgument, Element::None, -1, "position or face buffer size is not a multiple of 3");
  if (input.has_texcoords() && input.corner_texcoords.size() != input.faces.size())
    return fail(Status::InvalidArgument, Element::None, -1, "corner_texcoords must be empty or as long as faces");
  if (nf == 0) return fail(Status::NoFaces, Element::None, -1, "the mesh has no faces");
  const std::span<const Index> in_faces(input.faces);
  if (auto e = check_indices(input)) return *e;

  ValidateResult r;
  std::vector<Index> kept_faces;
  if (auto e = keep_component(input, options, r, kept_faces)) return *e;
  // Work on the kept faces (still in input vertex numbering).
  const Index kf = static_cast<Index>(kept_faces.size());
  std::vector<Index> faces(3 * static_cast<std::size_t>(kf));
  for (Index i = 0; i < kf; ++i)
    for (Index k = 0; k < 3; ++k) faces[3 * i + k] = in_faces[3 * kept_faces[i] + k];
  if (auto e = check_faces(input, options, faces, kept_faces)) return *e;
  const detail::EdgeTable table = detail::build_edge_table(faces, nv);
  if (auto e = check_edges(faces, kept_faces, table)) return *e;
  // Where every edge's two faces already agree, the orientation is the input's own (no search).
  detail::Orientation orient;
  if (detail::count_inconsistent_edges(faces, table) > 0) {
    orient = detail::orient_faces(faces, table);
  } else {
    orient.flip.assign(static_cast<std::size_t>(kf), 0);
  }
  if (auto e = orient_surface(input, options, table, kept_faces, faces, orient, r)) return *e;
  compact_mesh(input, faces, kept_faces, orient.flip, r);
  const Mesh& out = r.mesh;

  // 10: pinched vertices (and every other connectivity invariant) via the topology. With no face
  // flipped the edge table is out.faces' own (compact_mesh() keeps the corners and renumbers the
  // vertices in their order), so it is not built again.
  TopologyResult topo = orient.inconsistent_edges == 0
                            ? detail::topology_from_edge_table(out.faces, out.num_vertices(), table)
                            : build_topology(out.faces, out.num_vertices());
  if (topo.status != Status::Ok) {
    ValidateResult e = fail(topo.status, topo.element, topo.element_index, topo.message);
    if (topo.element == Element::Vertex) {
      e.element_index = r.vertex_to_input[topo.element_index];
      e.message = "the faces around vertex " + str(e.element_index) + " form more than one fan (pinched vertex)";
    } else if (topo.element == Element::Face) {
      e.element_index = kept_faces[topo.element_index];
    }
    return e;
  }
  r.topology = std::move(topo.topology);

  // Option: split ears (new vertices and faces are appended; see repair_ears.cpp).
  if (options.split_ears) {
    const std::vector<Index> ears = find_ears(r.topology);
    std::string why;
    if (const Status s = split_ears(r, ears, &why); s != Status::Ok) return fail(s, Element::None, -1, why);
  }
  r.status = Status::Ok;
  r.message = "ok";
  return r;
} catch (const std::bad_alloc&) {
  return fail(Status::OutOfMemory, Element::None, -1, "out of memory while validating the mesh");
}

LoadResult load_mesh(const std::string& path, const LoadOptions& options) {
  return validate_read(read_mesh(path, options.read), path, options.validate);
}

LoadResult validate_read(ReadResult read, const std::string& name, const ValidateOptions& options) {
  LoadResult r;
  r.read = std::move(read);
  if (r.read.status != Status::Ok) {
    r.status = r.read.status;
    r.message = r.read.message;
    r.line = r.read.line;
    r.element = r.read.element;
    r.element_index = r.read.element_index;
    return r;
  }
  if (r.read.polygons_triangulated > 0)
    r.repairs.push_back({RepairKind::PolygonsTriangulated, r.read.polygons_triangulated,
                         "fan-triangulated " + str(r.read.polygons_triangulated) + " polygons with more than 3 sides"});
  r.validated = validate_mesh(r.read.mesh, options);
  r.status = r.validated.status;
  r.message = r.validated.status == Status::Ok ? "ok" : name + ": " + r.validated.message;
  r.element = r.validated.element;
  r.element_index = r.validated.element_index;
  const auto& polygon_of = r.read.triangle_polygon;
  if (r.element == Element::Face && r.element_index >= 0 &&
      r.element_index < static_cast<std::int64_t>(polygon_of.size())) {
    // Faces of a triangulated file are triangles; name the polygon the user can find in the file.
    r.message += " (triangle " + str(r.element_index) + " is part of polygon " + str(polygon_of[r.element_index]) +
                 " of the file)";
    r.element_index = polygon_of[r.element_index];
  }
  r.repairs.insert(r.repairs.end(), r.validated.repairs.begin(), r.validated.repairs.end());
  return r;
}

}  // namespace ricci
