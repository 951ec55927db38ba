// ricci command-line driver — outputs for other tools (see uniformize_outputs.h).
#include "uniformize_outputs.h"

#include "ricci/metric.h"

#include <algorithm>
#include <cmath>

namespace ricci_cli {

namespace {

using ricci::Index;

/// Area of a flat triangle from its 3D corners (the layout's triangles as drawn).
double triangle_area(const double* a, const double* b, const double* c) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double w[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  return 0.5 * std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
}

/// Values per validated vertex → per file vertex (0 where the file's vertex was dropped).
std::vector<double> to_file(const std::vector<double>& per_vertex, std::span<const Index> vertex_to_input,
                            Index file_vertices) {
  if (vertex_to_input.empty()) {
    std::vector<double> out = per_vertex;
    out.resize(static_cast<std::size_t>(file_vertices), 0.0);
    return out;
  }
  std::vector<double> out(static_cast<std::size_t>(file_vertices), 0.0);
  for (std::size_t v = 0; v < per_vertex.size() && v < vertex_to_input.size(); ++v) {
    const Index w = vertex_to_input[v];
    if (w >= 0 && w < file_vertices) out[static_cast<std::size_t>(w)] = per_vertex[v];
  }
  return out;
}

/// "lh" of ".../lh.white"; the whole file name when it has no dot.
std::string freesurfer_prefix(const std::string& path) {
  std::string name = path.substr(path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1);
  const std::size_t dot = name.find('.');
  if (dot != std::string::npos && dot > 0) name = name.substr(0, dot);
  return name.empty() ? std::string("surface") : name;
}

}  // namespace

VertexOverlays vertex_overlays(const ricci::Mesh& mesh, const ricci::Topology& topology,
                               std::span<const Index> vertex_to_input, Index file_vertices, const ricci::UniformizeResult& r, const ricci::Mesh& surface, std::span<const double> uv,
                               std::span<const double> sphere) {
  const std::size_t nv = static_cast<std::size_t>(mesh.num_vertices());
  const std::size_t nc = mesh.faces.size();
  // The input's own metric: K from its corner angles, its face areas.
  const std::vector<double> l = ricci::mesh_edge_lengths(mesh, topology);
  std::vector<double> theta(nc), K(nv), area_of_face(nc / 3);
  ricci::corner_angles(topology, ricci::Geometry::Euclidean, l, theta);
  ricci::vertex_curvature(topology, theta, K);
  ricci::face_areas(topology, ricci::Geometry::Euclidean, l, theta, area_of_face);
  std::vector<double> area_in(nv, 0.0), area_out(nv, 0.0), log_sum(nv, 0.0), log_count(nv, 0.0);
  const bool sphere_layout = !sphere.empty();
  const bool same_faces = surface.faces == mesh.faces;
  double total_in = 0, total_out = 0;
  for (std::size_t f = 0; f < nc / 3; ++f) {
    const Index a = mesh.faces[3 * f], b = mesh.faces[3 * f + 1], c = mesh.faces[3 * f + 2];
    double aout = 0;
    if (sphere_layout) {
      aout = triangle_area(&sphere[3 * static_cast<std::size_t>(a)], &sphere[3 * static_cast<std::size_t>(b)],
                           &sphere[3 * static_cast<std::size_t>(c)]);
    } else if (same_faces && uv.size() == 2 * nc) {
      const double q[3][3] = {{uv[6 * f], uv[6 * f + 1], 0}, {uv[6 * f + 2], uv[6 * f + 3], 0}, {uv[6 * f + 4], uv[6 * f + 5], 0}};
      aout = triangle_area(q[0], q[1], q[2]);
    }
    total_in += area_of_face[f];
    total_out += aout;
    for (const Index v : {a, b, c}) {
      area_in[static_cast<std::size_t>(v)] += area_of_face[f] / 3;
      area_out[static_cast<std::size_t>(v)] += aout / 3;
    }
  }
  VertexOverlays o;
  std::vector<double> u(nv, 0.0), area(nv, 0.0), angle(nv, 0.0);
  if (r.flow.u.size() == nv) u = r.flow.u;
  if (total_in > 0 && total_out > 0) {
    for (std::size_t v = 0; v < nv; ++v) {
      if (area_in[v] > 0 && area_out[v] > 0) area[v] = std::log((area_out[v] / total_out) / (area_in[v] / total_in));
    }
  }
  if (r.angles.ratio.size() == nc) {
    for (std::size_t c = 0; c < nc; ++c) {
      const double ratio = r.angles.ratio[c];
      if (!(ratio > 0) || !std::isfinite(ratio)) continue;
      const auto v = static_cast<std::size_t>(mesh.faces[c]);
      log_sum[v] += std::abs(std::log(ratio));
      log_count[v] += 1;
    }
    for (std::size_t v = 0; v < nv; ++v) angle[v] = log_count[v] > 0 ? log_sum[v] / log_count[v] : 0.0;
  }
  o.K = to_file(K, vertex_to_input, file_vertices);
  o.u = to_file(u, vertex_to_input, file_vertices);
  o.area_distortion = to_file(area, vertex_to_input, file_vertices);
  o.angle_distortion = to_file(angle, vertex_to_input, file_vertices);
  return o;
}

std::vector<std::pair<std::string, std::string>> family_files(ricci::FileFormat input_format, const std::string& input_path,
                                                              const VertexOverlays& overlays, Index file_faces,
                                                              const ricci::Mesh& layout, bool sphere) {
  std::vector<std::pair<std::string, std::string>> out;
  const std::pair<const char*, const std::vector<double>*> arrays[4] = {{"K", &overlays.K},
                                                                        {"u", &overlays.u},
                                                                        {"area_distortion", &overlays.area_distortion},
                                                                        {"angle_distortion", &overlays.angle_distortion}};
  if (input_format == ricci::FileFormat::Gifti) {
    out.emplace_back(sphere ? "sphere.surf.gii" : "layout.surf.gii", ricci::serialize_mesh(layout, ricci::FileFormat::Gifti));
    for (const auto& [name, values] : arrays)
      out.emplace_back(std::string(name) + ".func.gii",
                       ricci::serialize_overlay(*values, ricci::OverlayFormat::GiftiFunc, name, file_faces));
  } else if (input_format == ricci::FileFormat::FreeSurfer) {
    const std::string prefix = freesurfer_prefix(input_path);
    out.emplace_back(prefix + (sphere ? ".sphere" : ".layout"), ricci::serialize_mesh(layout, ricci::FileFormat::FreeSurfer));
    for (const auto& [name, values] : arrays)
      out.emplace_back(prefix + "." + name,
                       ricci::serialize_overlay(*values, ricci::OverlayFormat::FreeSurferCurv, name, file_faces));
  }
  return out;
}

}  // namespace ricci_cli
