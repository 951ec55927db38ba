// Ears: boundary vertices in a single triangle, and the repair that splits the edge opposite them.
//
//       b                 b
//      / \ ear           /|\ .
//     a---c      →      a-m-c      m: midpoint of (a, c), appended
//      \ /               \|/ .
//       d                 d
//
// Face (b, a, c) becomes (b, a, m) in place plus (b, m, c) appended; face (d, c, a) becomes
// (d, c, m) in place plus (d, m, a) appended. Each new face is a copy of the face it comes from
// with one vertex replaced, so corner slots, orientation and texture indices carry over.
#include <algorithm>
#include <new>
#include <string>

#include "ricci/validate.h"

namespace ricci {

std::vector<Index> find_ears(const Topology& topology) {
  std::vector<Index> ears;
  for (Index j = 0; j < static_cast<Index>(topology.boundary_vertices.size()); ++j) {
    const Index v = topology.boundary_vertices[j];
    if (topology.valence(v) == 1) ears.push_back(v);
  }
  std::sort(ears.begin(), ears.end());
  ears.erase(std::unique(ears.begin(), ears.end()), ears.end());
  return ears;
}

namespace {

SplitEarsResult split_fail(Status status, std::string message) {
  SplitEarsResult r;
  r.status = status;
  r.message = std::move(message);
  return r;
}

std::string vertex_list(const std::vector<Index>& v) {
  constexpr std::size_t kShown = 10;
  std::string s;
  for (std::size_t i = 0; i < v.size() && i < kShown; ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  if (v.size() > kShown) s += ", …";
  return s;
}

// Splits the edge opposite corner c (at the ear) of `faces`, whose opposite corner is o.
void split_at(Mesh& m, std::vector<Index>& face_to_input, Index c, Index o) {
  auto& F = m.faces;
  const Index ca = next_corner(c), cc = prev_corner(c);
  const Index a = F[ca], cv = F[cc];
  const Index mid = m.num_vertices();
  double p[3];
  for (int d = 0; d < 3; ++d)
    p[d] = 0.5 * (m.positions[3 * std::size_t(a) + d] + m.positions[3 * std::size_t(cv) + d]);
  m.positions.insert(m.positions.end(), p, p + 3);
  const Index f = corner_face(c), g = corner_face(o);
  const Index ga = prev_corner(o), gc = next_corner(o);  // corners of a and c in face g
  // Appended copies: (b, m, c) from f, (d, m, a) from g.
  const Index f2 = m.num_faces(), g2 = f2 + 1;
  const Index fv[3] = {F[3 * f], F[3 * f + 1], F[3 * f + 2]}, gv[3] = {F[3 * g], F[3 * g + 1], F[3 * g + 2]};
  F.insert(F.end(), fv, fv + 3);
  F.insert(F.end(), gv, gv + 3);
  F[3 * f2 + corner_slot(ca)] = mid;
  F[3 * g2 + corner_slot(gc)] = mid;
  F[cc] = mid;  // f = (b, a, m)
  F[ga] = mid;  // g = (d, c, m)
  const Index fi = face_to_input[f], gi = face_to_input[g];
  face_to_input.push_back(fi);
  face_to_input.push_back(gi);
  if (!m.has_texcoords()) return;
  auto& T = m.corner_texcoords;
  auto midpoint = [&](Index t0, Index t1) {
    const Index t = m.num_texcoords();
    const double uv[2] = {
        0.5 * (m.texcoords[2 * std::size_t(t0)] + m.texcoords[2 * std::size_t(t1)]),
        0.5 * (m.texcoords[2 * std::size_t(t0) + 1] + m.texcoords[2 * std::size_t(t1) + 1])};
    m.texcoords.insert(m.texcoords.end(), uv, uv + 2);
    return t;
  };
  const Index ta = T[ca], tc = T[cc], tga = T[ga], tgc = T[gc];
  const Index tf = midpoint(ta, tc);
  const Index tg = (tga == ta && tgc == tc) ? tf : midpoint(tga, tgc);  // a seam keeps two coordinates
  const Index ft[3] = {T[3 * f], T[3 * f + 1], T[3 * f + 2]}, gt[3] = {T[3 * g], T[3 * g + 1], T[3 * g + 2]};
  T.insert(T.end(), ft, ft + 3);
  T.insert(T.end(), gt, gt + 3);
  T[3 * f2 + corner_slot(ca)] = tf;
  T[3 * g2 + corner_slot(gc)] = tg;
  T[cc] = tf;
  T[ga] = tg;
}

// `to_input` (may be empty): a vertex's index in the input file, named in the message when it differs.
SplitEarsResult split_selected(const Mesh& mesh, const Topology& topology, std::span<const Index> ears,
                               std::span<const Index> to_input = {}) try {
  const Index nv = mesh.num_vertices();
  if (mesh.positions.size() != 3 * std::size_t(nv) ||
      mesh.faces.size() != 3 * std::size_t(mesh.num_faces()) || topology.num_vertices != nv ||
      topology.num_faces != mesh.num_faces() ||
      topology.vertex_corner_offsets.size() != std::size_t(nv) + 1 ||
      topology.opposite.size() != mesh.faces.size() ||
      (mesh.has_texcoords() && mesh.corner_texcoords.size() != mesh.faces.size()))
    return split_fail(Status::InvalidArgument, "the mesh and its topology differ in size");
  for (Index v : ears)
    if (v < 0 || v >= nv)
      return split_fail(
          Status::InvalidArgument,
          "ear " + std::to_string(v) + " is not a vertex (the mesh has " + std::to_string(nv) + ")");

  SplitEarsResult r;
  r.mesh = mesh;
  r.face_to_input.resize(std::size_t(mesh.num_faces()));
  for (Index f = 0; f < mesh.num_faces(); ++f) r.face_to_input[f] = f;
  std::vector<Index> pending(ears.begin(), ears.end());
  std::sort(pending.begin(), pending.end());
  pending.erase(std::unique(pending.begin(), pending.end()), pending.end());

  const Topology* t = &topology;
  Topology rebuilt;
  bool changed = false;
  // Rounds: in each, the ears whose two faces no earlier ear of the round touched are split; the
  // rest wait for the rebuilt topology (where they may no longer be ears).
  while (!pending.empty()) {
    std::vector<std::uint8_t> touched(std::size_t(r.mesh.num_faces()), 0);
    std::vector<Index> later;
    bool split_any = false;
    for (Index b : pending) {
      if (t->valence(b) != 1 || !t->is_boundary_vertex(b)) continue;  // not (or no longer) an ear
      const Index c = t->vertex_corners[t->vertex_corner_offsets[b]];
      const Index o = t->opposite[c];
      if (o == kInvalid) {
        r.unsplittable.push_back(b);
        continue;
      }
      const Index f = corner_face(c), g = corner_face(o);
      if (touched[f] || touched[g]) {
        later.push_back(b);
        continue;
      }
      touched[f] = touched[g] = 1;
      split_at(r.mesh, r.face_to_input, c, o);
      r.split.push_back(b);
      split_any = true;
    }
    if (!split_any) break;
    changed = true;
    TopologyResult tr = build_topology(r.mesh.faces, r.mesh.num_vertices());
    if (tr.status != Status::Ok)  // an internal invariant: the split keeps a valid surface
      return split_fail(Status::NumericalFailure,
                        "internal error: splitting ears broke the surface: " + tr.message);
    rebuilt = std::move(tr.topology);
    t = &rebuilt;
    pending = std::move(later);
  }
  r.topology = changed ? std::move(rebuilt) : topology;
  std::sort(r.unsplittable.begin(), r.unsplittable.end());
  const auto n = static_cast<std::int64_t>(r.split.size());
  if (n > 0) {
    std::vector<Index> named = r.split;
    std::sort(named.begin(), named.end());
    std::string input;
    if (to_input.size() == std::size_t(nv)) {
      std::vector<Index> mapped;
      for (Index v : named) mapped.push_back(to_input[v]);
      if (mapped != named) input = "; " + vertex_list(mapped) + " in the input file";
    }
    r.repair = {RepairKind::EarsSplit, n,
                "split " + std::to_string(n) + (n == 1 ? " ear" : " ears") + " (boundary " +
                    (n == 1 ? "vertex " : "vertices ") + vertex_list(named) +
                    (n == 1 ? " in a single triangle" : ", each in a single triangle") + input +
                    ") at the midpoint of the opposite edge: added " +
                    (n == 1 ? "vertex " + std::to_string(nv)
                            : "vertices " + std::to_string(nv) + "–" + std::to_string(nv + n - 1)) +
                    " and " + std::to_string(2 * n) + " faces"};
  }
  if (!r.unsplittable.empty())
    r.repair.message += "; left " + std::to_string(r.unsplittable.size()) +
                        " ears in isolated triangles alone (" + vertex_list(r.unsplittable) + ")";
  r.status = Status::Ok;
  r.message = "ok";
  return r;
} catch (const std::bad_alloc&) {
  return split_fail(Status::OutOfMemory, "out of memory while splitting ears");
}

}  // namespace

SplitEarsResult split_ears(const Mesh& mesh, const Topology& topology) {
  if (topology.boundary_vertices.size() > std::size_t(topology.num_vertices) ||
      topology.vertex_corner_offsets.size() != std::size_t(topology.num_vertices) + 1)
    return split_fail(Status::InvalidArgument, "the topology is not built");
  const std::vector<Index> ears = find_ears(topology);
  return split_selected(mesh, topology, ears);
}

SplitEarsResult split_ears(const Mesh& mesh, const Topology& topology, std::span<const Index> ears) {
  return split_selected(mesh, topology, ears);
}

Status split_ears(ValidateResult& v, std::span<const Index> ears, std::string* why) try {
  if (ears.empty()) return Status::Ok;
  SplitEarsResult split = split_selected(v.mesh, v.topology, ears, v.vertex_to_input);
  if (split.status == Status::Ok && v.face_to_input.size() != std::size_t(v.mesh.num_faces())) {
    split.status = Status::InvalidArgument;
    split.message = "face_to_input does not match the mesh";
  }
  if (split.status != Status::Ok) {
    if (why) *why = split.message;
    return split.status;
  }
  if (split.split.empty()) return Status::Ok;
  std::vector<Index> face_to_input(split.face_to_input.size());
  for (std::size_t f = 0; f < face_to_input.size(); ++f)
    face_to_input[f] = v.face_to_input[split.face_to_input[f]];
  v.vertex_to_input.resize(std::size_t(split.mesh.num_vertices()), kInvalid);
  v.face_to_input = std::move(face_to_input);
  v.mesh = std::move(split.mesh);
  v.topology = std::move(split.topology);
  v.repairs.push_back(std::move(split.repair));
  return Status::Ok;
} catch (const std::bad_alloc&) {
  if (why) *why = "out of memory while splitting ears";
  return Status::OutOfMemory;
}

}  // namespace ricci
