// bench_polygon — the canonical-polygon stage against the flow on closed surfaces of genus ≥ 2:
// the shared meshes (when ../shared/meshes is there), the fixtures and generated pretzels of
// genus 8, 12 and 20 (holes in a row, and in a grid: tools/shapes.h).
//
//   bench_polygon [--mesh-path] [--out FILE]
//
// Runs uniformize() with the defaults (seed_checks 0, base_candidates 1 for the mesh path, so a
// fallback costs one cut) and prints a Markdown table: faces, genus, flow and polygon seconds,
// their ratio, which polygon was made (geodesic, mesh, or none) and its figures. --mesh-path
// adds a column with the polygon stage of mesh_polygon (8 base candidates) on inputs up to genus 5.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"

namespace {

struct Input {
  std::string name;
  ricci::Mesh mesh;
};

double stage_seconds(const ricci::UniformizeResult& r, const std::string& stage) {
  double s = 0;
  for (const auto& [name, t] : r.timings)
    if (name == stage) s += t;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  bool mesh_path = false;
  std::string out_file;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--mesh-path") mesh_path = true;
    else if (a == "--out" && i + 1 < argc) out_file = argv[++i];
    else {
      std::fprintf(stderr, "usage: bench_polygon [--mesh-path] [--out FILE]\n");
      return 2;
    }
  }
  namespace fs = std::filesystem;
  const fs::path source = RICCI_SOURCE_DIR;
  std::vector<Input> inputs;
  auto add_file = [&](const fs::path& p) {
    const ricci::ReadResult rr = ricci::read_mesh(p.string());
    if (rr.status == ricci::Status::Ok) inputs.push_back({p.parent_path().filename().string() + "/" + p.filename().string(), rr.mesh});
  };
  add_file(source / "fixtures" / "genus2.obj");
  add_file(source / "fixtures" / "genus3.obj");
  const fs::path shared = source / ".." / "shared" / "meshes";
  for (const char* m : {"genus2/eight.off", "genus2/cup_input_simple_10000.off", "genus2/skull_low_resolution.obj",
                        "genus3plus/3holes.off", "genus3plus/fertility.off", "genus3plus/botijo.obj"})
    if (fs::exists(shared / m)) add_file(shared / m);
  for (int g : {8, 12, 20}) inputs.push_back({"pretzel(" + std::to_string(g) + ", 4)", ricci_shapes::pretzel(g, 4)});
  for (const auto& [c, r] : {std::pair{4, 2}, std::pair{4, 3}, std::pair{5, 4}})
    inputs.push_back({"pretzel_grid(" + std::to_string(c) + ", " + std::to_string(r) + ", 4)",
                      ricci_shapes::pretzel_grid(c, r, 4)});

  std::ostringstream table;
  table << "| input | faces | genus | flow s | polygon s | polygon/flow | polygon | perimeter | reach | "
           "relation error | status |"
        << (mesh_path ? " mesh path s |" : "") << "\n";
  table << "|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---|" << (mesh_path ? "---:|" : "") << "\n";
  for (const Input& in : inputs) {
    const ricci::ValidateResult v = ricci::validate_mesh(in.mesh);
    if (v.status != ricci::Status::Ok) continue;
    ricci::UniformizeOptions o;
    o.seed_checks = 0;
    o.base_candidates = 1;
    const ricci::UniformizeResult r = ricci::uniformize(v.mesh, v.topology, o);
    const double flow = stage_seconds(r, "flow"), polygon = stage_seconds(r, "polygon");
    const bool wide = r.has_geodesic_polygon && r.geodesic_polygon.arithmetic_bits > 113;
    const char* kind = r.has_polygon ? "mesh" : (r.has_geodesic_polygon ? (wide ? "geodesic, quad-double" : "geodesic") : "none");
    char row[512];
    std::snprintf(row, sizeof row, "| %s | %lld | %lld | %.3f | %.3f | %.2f | %s | %.1f | %.1f | %.1e | %s |", in.name.c_str(),
                  static_cast<long long>(v.topology.num_faces), static_cast<long long>(v.topology.genus()), flow, polygon,
                  flow > 0 ? polygon / flow : 0.0, kind, r.has_geodesic_polygon ? r.geodesic_polygon.perimeter : 0.0,
                  r.has_geodesic_polygon ? r.geodesic_polygon.reach : 0.0, r.has_deck ? r.deck.relation_error : 0.0,
                  std::string(ricci::status_name(r.status)).c_str());
    table << row;
    if (mesh_path) {
      if (v.topology.genus() <= 5) {
        ricci::UniformizeOptions m = o;
        m.mesh_polygon = true;
        m.base_candidates = 8;
        const ricci::UniformizeResult rm = ricci::uniformize(v.mesh, v.topology, m);
        std::snprintf(row, sizeof row, " %.3f |", stage_seconds(rm, "polygon"));
        table << row;
      } else {
        table << " – |";
      }
    }
    table << "\n";
    std::fprintf(stderr, "%s\n", row);
  }
  std::printf("%s", table.str().c_str());
  if (!out_file.empty()) {
    std::ofstream f(out_file);
    f << "# The canonical-polygon stage against the flow\n\n"
      << "`build/tools/bench_polygon" << (mesh_path ? " --mesh-path" : "") << " --out " << out_file
      << "` (Release, 2 cores). Default options with `seed_checks = 0` and `base_candidates = 1` (a fallback to the "
         "mesh path costs one cut). polygon: `geodesic` (the default: canonical generators from the compact "
         "domain's word, their geodesic 4g-gon), `mesh` (the mesh path, as fallback), `none` (the deck group is "
         "given by the domain's pairings only); `quad-double`: quad could not resolve the polygon's relation at its reach, so the pairings "
         "were closed again and the same words evaluated in quad-double (about 212 bits). perimeter and reach (largest distance of a corner from the "
         "centre) are the geodesic polygon's. Timings vary by about ±15 % run to run on this machine.\n\n"
      << table.str();
  }
  return 0;
}
