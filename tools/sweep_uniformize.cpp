// sweep_uniformize — the main job (uniformize(): flow, cut, layout, seed check, canonical polygon,
// deck transformations) on every mesh of ../shared/meshes/{genus0,genus1,genus2,genus3plus,boundary},
// (and derived/), one Markdown table row each. A driver, not a test: a mesh that fails is a row with its status.
// Like the CLI, a mesh whose boundary target an ear makes infeasible is run again with its ears split.
//
//   cmake --build build --target sweep_uniformize && build/tools/sweep_uniformize [MESHES_DIR] [--out FILE.md]
//   --polish-sweeps N   LayoutOptions::polish_sweeps for euclidean layouts (default: the library's)
//   --patches N         LayoutOptions::patches: divide-and-conquer layouts with N patches (default: off)
//   --only TEXT         only the meshes whose path (e.g. "genus1/kitten") contains TEXT
//
// Columns: geometry; #F; Newton iterations (with the polishing steps; chord steps, which reuse the
// last factor, counted in them and apart) and max |K̄ − K|; the
// layout's max relative edge-length error and flipped faces; the largest deviation between
// layouts from four seed faces after the fitted isometry; closed genus ≥ 2: the compact domain's
// vertex-cycle error, the canonical polygon's relation error Π[A_i^-1, B_i] − 1 and the polygon's
// own edge error (or why there is none); seconds in all.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"

namespace fs = std::filesystem;

namespace {

std::string sci(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1e", x);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  fs::path dir = fs::path(RICCI_SOURCE_DIR).parent_path() / "shared" / "meshes";
  std::string out_path;
  int polish = -1, patches = -1;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) {
      out_path = argv[++i];
    } else if (a == "--polish-sweeps" && i + 1 < argc) {
      polish = std::atoi(argv[++i]);
    } else if (a == "--patches" && i + 1 < argc) {
      patches = std::atoi(argv[++i]);
    } else if (a == "--only" && i + 1 < argc) {
      only = argv[++i];
    } else if (a == "--help" || a == "-h") {
      std::cout << "usage: sweep_uniformize [MESHES_DIR] [--out FILE.md] [--polish-sweeps N] [--patches N] [--only TEXT]\n";
      return 0;
    } else {
      dir = a;
    }
  }
  if (!fs::is_directory(dir)) {
    std::cerr << "sweep_uniformize: " << dir << " is not a directory\n";
    return 2;
  }
  std::string table;
  table += "| mesh | geometry | #F | Newton it. | max \\|K̄ − K\\| | layout edge error | rounding floor | flips | seed independence | "
           "domain cycles | pairings moved | relation error | as fitted | polygon | s |\n";
  table += "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  std::cout << table << std::flush;
  ricci::UniformizeOptions options;
  if (polish >= 0) options.layout.polish_sweeps = polish;
  if (patches >= 0) options.layout.patches = patches;
  for (const char* sub : {"genus0", "genus1", "genus2", "genus3plus", "boundary", "derived"}) {
    std::vector<fs::path> files;
    if (!fs::is_directory(dir / sub)) continue;
    for (const auto& e : fs::directory_iterator(dir / sub)) {
      const std::string ext = e.path().extension().string();
      if (ext == ".obj" || ext == ".off" || ext == ".ply") files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    for (const fs::path& p : files) {
      if (!only.empty() && (std::string(sub) + "/" + p.filename().string()).find(only) == std::string::npos) continue;
      const auto t0 = std::chrono::steady_clock::now();
      const std::string name = std::string(sub) + "/" + p.filename().string();
      std::string row = "| " + name + " | ";
      const ricci::LoadResult lr = ricci::load_mesh(p.string());
      if (lr.status != ricci::Status::Ok) {
        row += std::string(ricci::status_name(lr.status)) + " | | | | | | | | | | | | | |\n";
      } else {
        ricci::UniformizeResult r = ricci::uniformize(lr.validated.mesh, lr.validated.topology, options);
        // As `ricci uniformize` does: a boundary target that an ear makes infeasible gets the ears split.
        bool split = false;
        if (r.status == ricci::Status::InfeasibleTarget && !ricci::find_ears(lr.validated.topology).empty()) {
          ricci::LoadOptions lo;
          lo.validate.split_ears = true;
          const ricci::LoadResult ls = ricci::load_mesh(p.string(), lo);
          if (ls.status == ricci::Status::Ok) {
            r = ricci::uniformize(ls.validated.mesh, ls.validated.topology, options);
            split = true;
          }
        }
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const bool ok = r.status == ricci::Status::Ok;
        row += std::string(ricci::geometry_name(r.geometry)) + " | " + std::to_string(lr.validated.topology.num_faces) +
               (split ? " (ears split)" : "") + " | ";
        if (!ok && r.flow.iterations == 0) {
          char secs[32];
          std::snprintf(secs, sizeof secs, "%.1f", s);
          row += std::string(ricci::status_name(r.status)) + " (" + r.failed_stage + ") | | | | | | | | | | | " + secs + " |\n";
        } else {
          row += std::to_string(r.flow.iterations) +
                 (r.flow.chord_steps > 0 ? " (" + std::to_string(r.flow.chord_steps) + " chord)" : std::string()) + " | " +
                 sci(r.flow.max_curvature_error) + " | ";
          if (r.layout.status == ricci::Status::Ok)
            row += sci(r.layout.max_edge_length_error) + " | " + sci(r.layout.rounding_floor) + " | " +
                   std::to_string(r.layout.flipped_faces) + " | " +
                   sci(r.seed_independence_error) + " | ";
          else
            row += "| | | | ";
          const bool domain = !r.domain_maps.empty();
          const bool deck = r.has_deck && r.deck.status == ricci::Status::Ok;
          row += (domain ? sci(r.domain_cycle_error) : std::string("–")) + " | ";
          row += (domain ? sci(r.domain_pairing_adjustment) : std::string("–")) + " | ";
          row += (deck ? sci(r.deck.relation_error) : std::string("–")) + " | ";
          row += (deck ? sci(domain ? r.fitted_relation_error : r.deck.relation_error) : std::string("–")) + " | ";
          if (r.has_polygon)
            row += "edge error " + sci(r.polygon.max_edge_length_error);
          else if (r.has_geodesic_polygon)
            row += "geodesic, reach " + sci(r.geodesic_polygon.reach);
          else if (deck)
            row += "not drawn (beyond double range)";
          else if (!r.polygon_note.empty())
            row += "none";
          else
            row += "–";
          char secs[32];
          std::snprintf(secs, sizeof secs, "%.1f", s);
          row += std::string(" | ") + secs + " |";
          if (!ok) row += " " + std::string(ricci::status_name(r.status)) + " at " + r.failed_stage;
          row += "\n";
        }
      }
      std::cout << row << std::flush;
      table += row;
    }
  }
  if (!out_path.empty()) {
    std::string doc = "# ricci uniformize on the shared meshes\n\n"
                      "`build/tools/sweep_uniformize --out tools/SWEEP-uniformize.md` (Release build), library defaults "
                      "(Newton to 1e-12 plus polishing, " + std::to_string(options.seed_checks) + " extra seed" +
                      (options.seed_checks == 1 ? "" : "s") + ", " + std::to_string(options.base_candidates) +
                      " base vertices for a canonical polygon of the mesh where the geodesic one is not made; the layout refined only where it misses its "
                      "metric by more than 1e-10 above its rounding floor). Hardware threads: " +
                      std::to_string(std::thread::hardware_concurrency()) +
                      ".\n\nColumns: *Newton it.* — steps with the polishing ones, in parentheses those that reused the last factor (chord steps); *layout edge error* — max relative edge-length error of the layout (the compact "
                      "domain for closed and bordered H surfaces); *rounding floor* — the largest relative change of an "
                      "edge's length that rounding its ends' coordinates can make (Layout::rounding_floor); *seed independence* — largest deviation of the "
                      "extra seeds' layouts from the layout after the fitted isometry; *domain cycles* — the compact domain's fitted side "
                      "pairings around its vertex cycles (distance to the identity); *pairings moved* — how far (largest "
                      "hyperbolic displacement of a side vertex) the pairings moved onto exact cycles; *relation error* "
                      "— Π[A_i⁻¹, B_i] of the canonical generators (H: products of the moved pairings, 113-bit); *as "
                      "fitted* — the same words in the pairings as fitted (torus: the fitted translations); *polygon* "
                      "— H: the geodesic canonical 4g-gon and its reach (largest distance of a corner from its centre; "
                      "double coordinates resolve about 2^-52 e^reach there), or the mesh-path polygon's edge error; "
                      "torus: the canonical cut's layout edge error.\n\n" +
                      table;
    const ricci::WriteResult w = ricci::write_file_atomic(out_path, doc);
    if (w.status != ricci::Status::Ok) {
      std::cerr << "sweep_uniformize: " << w.message << '\n';
      return 1;
    }
  }
  return 0;
}
