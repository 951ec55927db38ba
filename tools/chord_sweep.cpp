// chord_sweep — the chord splits (UniformizeOptions::split_chords) measured: seeded random
// bordered surfaces (stress_shapes.h random_surface(seed, faces), validated with ears split, as the
// CLI loads them) that have chords — interior edges joining two boundary vertices — each run
// through uniformize() with and without the splits. Prints a Markdown table: per draw its faces
// and chords, and per run the status, the scheme that solved it (vertex scaling on the double,
// or circle packing), the chords split, the mean angle distortion, the layout edge error (its
// charts) and the seconds. A benchmark, not a test.
//
//   build/tools/chord_sweep [--first N] [--last N] [--faces N] [--all-geometries]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "stress_shapes.h"

using namespace ricci;

namespace {

Index count_chords(const Topology& t) { return static_cast<Index>(find_chords(t).size()); }

std::string cell(const UniformizeResult& r, double seconds) {
  char buf[256];
  if (r.status != Status::Ok) {
    std::snprintf(buf, sizeof buf, "%s (%s) | – | – | – | %.2f", std::string(status_name(r.status)).c_str(),
                  r.failed_stage.c_str(), seconds);
    return buf;
  }
  const std::string how = r.intrinsic.doubled ? "double" : (r.intrinsic.fallback.empty() ? "flips" : "circle packing");
  const double error = r.has_atlas ? r.atlas.max_edge_length_error : r.layout.max_edge_length_error;
  const Index charts = r.has_atlas ? r.atlas.num_charts() : 1;
  std::snprintf(buf, sizeof buf, "%s, %d split | %.4f | %.2g | %d | %.2f", how.c_str(), static_cast<int>(r.steiner.chord_splits),
                r.angles.mean_abs_log, error, static_cast<int>(charts), seconds);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  int first = 1, last = 80;
  Index faces = 1500;
  bool all = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--first" && i + 1 < argc) first = std::atoi(argv[++i]);
    else if (a == "--last" && i + 1 < argc) last = std::atoi(argv[++i]);
    else if (a == "--faces" && i + 1 < argc) faces = std::atoi(argv[++i]);
    else if (a == "--all-geometries") all = true;
    else {
      std::fprintf(stderr, "usage: chord_sweep [--first N] [--last N] [--faces N] [--all-geometries]\n");
      return 2;
    }
  }
  std::printf("| draw | faces | chords | with splits: how | angle distortion | layout error | charts | s "
              "| without: how | angle distortion | layout error | charts | s |\n");
  std::printf("|---:|---:|---:|---|---:|---:|---:|---:|---|---:|---:|---:|---:|\n");
  for (int seed = first; seed <= last; ++seed) {
    const ricci_shapes::RandomSurface s = ricci_shapes::random_surface(static_cast<std::uint64_t>(seed), faces);
    ValidateOptions vo;
    vo.split_ears = true;
    const ValidateResult v = validate_mesh(s.mesh, vo);
    if (v.status != Status::Ok || v.topology.is_closed()) continue;
    const Index chords = count_chords(v.topology);
    if (chords == 0 || (!all && natural_geometry(v.topology) != Geometry::Hyperbolic)) continue;
    std::string row = "| " + std::to_string(seed) + " | " + std::to_string(v.topology.num_faces) + " | " +
                      std::to_string(chords);
    for (const bool on : {true, false}) {
      UniformizeOptions o;
      o.seed_checks = 0;
      o.split_chords = on;
      const auto t0 = std::chrono::steady_clock::now();
      const UniformizeResult r = uniformize(v.mesh, v.topology, o);
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      row += " | " + cell(r, sec);
    }
    std::printf("%s |\n", row.c_str());
    std::fflush(stdout);
  }
  return 0;
}
