// random_surface_sweep — the default job (uniformize(), as `ricci uniformize` runs it: the ears
// its default target makes infeasible split)
// on seeded random surfaces (stress_shapes.h random_surface(): genus 0–12, 0–8 boundary loops,
// jittered, stretched up to 100:1), one Markdown table row each, then a summary of how the runs
// ended. A driver, not a test: a surface that fails is a row with its status and message.
//
//   cmake --build build --target random_surface_sweep
//   build/tools/random_surface_sweep [--count N] [--first SEED] [--min-faces F] [--max-faces F] [--out FILE.md]
//                                    [--write DIR]
//
// Floating-point traps are on (glibc: invalid operations, division by zero, overflow), as in the
// test suite: a draw whose run computes a NaN or an infinity stops the sweep there (SIGFPE)
// instead of passing as a row.
//
// --write DIR also writes each draw as DIR/random-SEED.obj (as generated, before validation), so
// a draw can be run through `ricci uniformize` with its progress lines.
// Each draw's face count is log-uniform in [min, max] (defaults 1000 and 50000), drawn from its
// seed. Columns: the surface; how the run ended (ok, or the status and failing stage); Newton
// iterations and max |K̄ − K|; the layout's max relative edge error (over its charts, with their
// number when there is an atlas, and the error over the faces other than the needles of the common
// subdivision within their coarse face's rounding, LayoutAtlas::frame_rounding_faces) and flipped faces; closed genus ≥ 1: the relation error; the
// seconds of uniformize(). "ok (on the double)": vertex scaling with flips solved on the surface's
// double after the solve on the surface stopped ("N chords split": on the double of the surface
// with its chords split, UniformizeOptions::split_chords); "ok (circle packing)": the fallback. Failures
// are listed after the table with their messages.
#include <cfenv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "stress_shapes.h"

namespace {

std::string sci(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1e", x);
  return b;
}

struct Args {
  int count = 60;
  std::uint64_t first = 1;
  ricci::Index min_faces = 1000, max_faces = 50000;
  std::string out;
  std::string write_dir;
};

bool parse(int argc, char** argv, Args& a) {
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (i + 1 >= argc) return false;
    const std::string v = argv[++i];
    if (k == "--count") a.count = std::atoi(v.c_str());
    else if (k == "--first") a.first = std::strtoull(v.c_str(), nullptr, 10);
    else if (k == "--min-faces") a.min_faces = std::atoi(v.c_str());
    else if (k == "--max-faces") a.max_faces = std::atoi(v.c_str());
    else if (k == "--out") a.out = v;
    else if (k == "--write") a.write_dir = v;
    else return false;
  }
  return a.count > 0 && a.min_faces >= 500 && a.max_faces <= 200000 && a.min_faces <= a.max_faces;
}

}  // namespace

int main(int argc, char** argv) {
#if defined(__GLIBC__)
  feenableexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW);
#endif
  Args a;
  if (!parse(argc, argv, a)) {
    std::fprintf(stderr, "usage: random_surface_sweep [--count N] [--first SEED] [--min-faces F] [--max-faces F] [--out FILE.md] [--write DIR]\n");
    return 2;
  }
  std::ostringstream table, failures, fallbacks;
  table << "| seed | genus | loops | faces | aspect | result | Newton | max \\|K̄ − K\\| | layout error | flipped | relation | s |\n"
        << "|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|\n";
  std::map<std::string, int> ended;
  double total = 0;
  for (int i = 0; i < a.count; ++i) {
    const std::uint64_t seed = a.first + static_cast<std::uint64_t>(i);
    const ricci::Index target = ricci_shapes::random_surface_faces(seed, a.min_faces, a.max_faces);
    const ricci_shapes::RandomSurface s = ricci_shapes::random_surface(seed, target);
    if (!a.write_dir.empty()) {
      const std::string path = a.write_dir + "/random-" + std::to_string(seed) + ".obj";
      const ricci::WriteResult w = ricci::write_mesh(path, s.mesh);
      if (w.status != ricci::Status::Ok) {
        std::fprintf(stderr, "random_surface_sweep: cannot write %s: %s\n", path.c_str(), w.message.c_str());
        return 1;
      }
    }
    const ricci::ValidateResult v = ricci_shapes::validate_as_cli(s.mesh);
    std::string result, iters = "–", curv = "–", lay = "–", flipped = "–", rel = "–", secs = "–";
    if (v.status != ricci::Status::Ok) {
      result = std::string(ricci::status_name(v.status)) + " (validate)";
      failures << "- seed " << seed << ": " << v.message << "\n";
    } else {
      const auto t0 = std::chrono::steady_clock::now();
      const ricci::UniformizeResult r = ricci::uniformize(v.mesh, v.topology);
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      total += sec;
      char b[32];
      std::snprintf(b, sizeof b, "%.2f", sec);
      secs = b;
      if (r.flow.status == ricci::Status::Ok) {
        iters = std::to_string(r.flow.iterations);
        curv = sci(r.flow.max_curvature_error);
      }
      if (r.status == ricci::Status::Ok) {
        result = !r.intrinsic.fallback.empty() ? "ok (circle packing)" : r.intrinsic.doubled ? "ok (on the double)" : "ok";
        if (r.steiner.chord_splits > 0)
          result.insert(result.size() - (result == "ok" ? 0 : 1),
                        std::string(result == "ok" ? " (" : ", ") + std::to_string(r.steiner.chord_splits) + " chords split" +
                            (result == "ok" ? ")" : ""));
        if (!r.intrinsic.fallback.empty()) fallbacks << "- seed " << seed << ": " << r.intrinsic.fallback << "\n";
        if (r.has_atlas) {
          lay = sci(r.atlas.max_edge_length_error) + " (" + std::to_string(r.atlas.num_charts()) + " charts" +
                (r.atlas.frame_rounding_faces.empty()
                     ? std::string()
                     : "; " + sci(r.atlas.max_resolved_error) + " but for " +
                           std::to_string(r.atlas.frame_rounding_faces.size()) + " needles") +
                ")";
          flipped = std::to_string(r.atlas.flipped_faces);
        } else if (r.has_cut) {
          lay = sci(r.layout.max_edge_length_error);
          flipped = std::to_string(r.layout.flipped_faces);
        }
        if (r.has_deck && r.deck.status == ricci::Status::Ok) rel = sci(r.deck.relation_error);
      } else {
        result = std::string(ricci::status_name(r.status)) + " (" + r.failed_stage + ")";
        failures << "- seed " << seed << " (" << s.description << "): " << r.message << "\n";
      }
    }
    ++ended[result];
    char aspect[32];
    std::snprintf(aspect, sizeof aspect, "%.1f", s.aspect);
    table << "| " << seed << " | " << s.genus << " | " << s.loops << " | " << s.mesh.num_faces() << " | " << aspect
          << " | " << result << " | " << iters << " | " << curv
          << " | " << lay << " | " << flipped << " | " << rel << " | " << secs << " |\n";
    std::fprintf(stderr, "%s: %s\n", s.description.c_str(), result.c_str());
  }
  std::ostringstream doc;
  doc << "# The default job on seeded random surfaces\n\n"
      << "`build/tools/random_surface_sweep --count " << a.count << " --first " << a.first << " --min-faces " << a.min_faces
      << " --max-faces " << a.max_faces << "` (Release, 2 cores, floating-point traps on): `random_surface()` of tools/stress_shapes.h — "
      << "genus 0–12, 0–8 boundary loops, random flips and splits, jitter, stretched up to 100:1 along x — then "
      << "`uniformize()` with its defaults (the ears its default target makes infeasible split, as the CLI does). " << sci(total) << " s of uniformize() in all.\n\n"
      << "How the runs ended:\n\n";
  for (const auto& [k, n] : ended) doc << "- " << k << ": " << n << "\n";
  doc << "\n" << table.str();
  if (!failures.str().empty()) doc << "\nFailures:\n\n" << failures.str();
  if (!fallbacks.str().empty())
    doc << "\nWhy vertex scaling with flips gave way to circle packing (`intrinsic.fallback`):\n\n" << fallbacks.str();
  if (a.out.empty()) {
    std::cout << doc.str();
  } else {
    std::ofstream f(a.out);
    f << doc.str();
    if (!f) {
      std::fprintf(stderr, "random_surface_sweep: cannot write %s\n", a.out.c_str());
      return 1;
    }
  }
  return 0;
}
