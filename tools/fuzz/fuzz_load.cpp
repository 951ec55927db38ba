// libFuzzer target: the whole load → validate path, then the connectivity and the first metric
// kernels on what validation accepts.
//
// Input: byte 0 selects
//   bits 0–1  the input: 0 OBJ, 1 OFF, 2 PLY (read_mesh_from_memory + validate_read), 3 a raw
//             triangle soup given straight to validate_mesh() (indices may be out of range or
//             negative, coordinates NaN or infinite: what no reader produces), see soup_from()
//   bit 2     ValidateOptions::keep_largest_component
//   bit 3     ValidateOptions::repair_orientation = false
//   bits 4–5  geometry of initial_metric(): E, H, S (3: E)
//   bit 6     ReadOptions::read_texcoords = false
// and the rest is the file (or the soup).
//
// Checked: the reader's and the validator's contracts (fuzz_common.h), that an error names a face
// or vertex that exists in the input, and that diagnose() agrees with a successful validation;
// on meshes of up to kMaxKernelFaces faces, initial_metric() and the kernels run (sanitizers
// watch them) and their outputs have the documented sizes.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_common.h"
#include "ricci/metric.h"

namespace {

constexpr ricci::Index kMaxKernelFaces = 4096;

/// A soup from raw bytes: #V = byte 0 % 64, then one signed byte per coordinate (value / 4;
/// 127 → NaN, −128 → +∞), then signed bytes as vertex indices, three per face.
ricci::Mesh soup_from(std::string_view bytes) {
  ricci::Mesh m;
  if (bytes.empty()) return m;
  const std::size_t nv = static_cast<unsigned char>(bytes[0]) % 64;
  bytes.remove_prefix(1);
  const std::size_t coords = std::min(3 * nv, bytes.size() / 3 * 3);
  for (std::size_t i = 0; i < coords; ++i) {
    const auto b = static_cast<std::int8_t>(bytes[i]);
    m.positions.push_back(b == 127    ? std::numeric_limits<double>::quiet_NaN()
                          : b == -128 ? std::numeric_limits<double>::infinity()
                                      : b / 4.0);
  }
  bytes.remove_prefix(coords);
  for (std::size_t i = 0; i + 3 <= bytes.size(); ++i) m.faces.push_back(static_cast<std::int8_t>(bytes[i]));
  m.faces.resize(m.faces.size() / 3 * 3);
  return m;
}

/// initial_metric() and the kernels of metric.h on a validated mesh.
void run_kernels(const ricci::Mesh& mesh, const ricci::Topology& t, ricci::Geometry geometry) {
  if (t.num_faces > kMaxKernelFaces) return;
  ricci::InitialMetricOptions options;
  options.geometry = geometry;
  const ricci::InitialMetric metric = ricci::initial_metric(mesh, t, options);
  RICCI_FUZZ_CHECK(metric.status != ricci::Status::NotRun);
  RICCI_FUZZ_CHECK(!metric.message.empty());
  if (metric.status != ricci::Status::Ok) return;
  const auto nv = static_cast<std::size_t>(t.num_vertices), ne = static_cast<std::size_t>(t.num_edges),
             nc = static_cast<std::size_t>(t.num_corners());
  RICCI_FUZZ_CHECK(metric.u.size() == nv);
  RICCI_FUZZ_CHECK(metric.structure.eta.size() == ne);
  RICCI_FUZZ_CHECK(metric.l0.size() == ne);
  RICCI_FUZZ_CHECK(ricci_fuzz::all_finite(metric.u));
  RICCI_FUZZ_CHECK(ricci_fuzz::all_finite(metric.structure.eta));
  std::vector<double> l(ne), theta(nc), K(nv), area(static_cast<std::size_t>(t.num_faces)),
      blocks(9 * area.size());
  if (ricci::edge_lengths(t, metric.structure, metric.u, l) != ricci::kInvalid) return;
  const ricci::AngleReport angles = ricci::corner_angles(t, geometry, l, theta);
  RICCI_FUZZ_CHECK(angles.violations >= 0 && angles.violations <= t.num_faces);
  ricci::vertex_curvature(t, theta, K);
  ricci::face_areas(t, geometry, l, theta, area);
  ricci::angle_derivative_blocks(t, metric.structure, metric.u, l, theta, blocks);
  (void)ricci::gauss_bonnet_defect(t, geometry, K, area);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t selector = data[0];
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  ricci::ValidateOptions validate;
  validate.keep_largest_component = (selector & 4) != 0;
  validate.repair_orientation = (selector & 8) == 0;
  const int g = (selector >> 4) & 3;
  const ricci::Geometry geometry = g == 1   ? ricci::Geometry::Hyperbolic
                                   : g == 2 ? ricci::Geometry::Spherical
                                            : ricci::Geometry::Euclidean;

  if ((selector & 3) == 3) {
    const ricci::Mesh soup = soup_from(bytes);
    (void)ricci::diagnose(soup, validate.degenerate_tolerance);
    const ricci::ValidateResult v = ricci::validate_mesh(soup, validate);
    if (v.status != ricci::Status::Ok) {
      RICCI_FUZZ_CHECK(v.status != ricci::Status::NotRun && !v.message.empty());
      if (v.element == ricci::Element::Face)
        RICCI_FUZZ_CHECK(v.element_index >= 0 && v.element_index < soup.num_faces());
      if (v.element == ricci::Element::Vertex)
        RICCI_FUZZ_CHECK(v.element_index >= 0 && v.element_index < soup.num_vertices());
      return 0;
    }
    ricci_fuzz::check_validated(v, soup, validate);
    run_kernels(v.mesh, v.topology, geometry);
    return 0;
  }

  static const ricci::FileFormat kFormats[3] = {ricci::FileFormat::Obj, ricci::FileFormat::Off,
                                                ricci::FileFormat::PlyBinary};
  static const char* const kNames[3] = {"fuzz.obj", "fuzz.off", "fuzz.ply"};
  const ricci::FileFormat format = kFormats[selector & 3];
  const std::string name = kNames[selector & 3];
  ricci::ReadOptions read_options;
  read_options.format = format;
  read_options.read_texcoords = (selector & 64) == 0;
  ricci::ReadResult read = ricci::read_mesh_from_memory(bytes, name, read_options);
  ricci_fuzz::check_read(read, name, format, /*round_trip=*/false);
  if (read.status == ricci::Status::Ok) (void)ricci::diagnose(read.mesh, validate.degenerate_tolerance);
  const ricci::Mesh input = read.mesh;
  const std::int64_t polygons = read.polygons_read;
  const ricci::LoadResult loaded = ricci::validate_read(std::move(read), name, validate);
  if (loaded.status != ricci::Status::Ok) {
    ricci_fuzz::check_failure(loaded.status, loaded.message, name);
    if (loaded.read.status == ricci::Status::Ok) {
      // Validation errors name an element of the file: a polygon (as the file numbers them) or
      // a vertex.
      if (loaded.element == ricci::Element::Face)
        RICCI_FUZZ_CHECK(loaded.element_index >= 0 && loaded.element_index < polygons);
      if (loaded.element == ricci::Element::Vertex)
        RICCI_FUZZ_CHECK(loaded.element_index >= 0 && loaded.element_index < input.num_vertices());
    }
    return 0;
  }
  RICCI_FUZZ_CHECK(loaded.validated.status == ricci::Status::Ok);
  ricci_fuzz::check_validated(loaded.validated, input, validate);
  run_kernels(loaded.validated.mesh, loaded.validated.topology, geometry);
  return 0;
}
