// bench_flow — timing of the discrete Ricci flow (uniformization with auto settings) on generated
// and real meshes, printed as a Markdown table. A driver, not a test: it never fails on a slow or
// non-converging mesh, it reports it.
//
// How to run (Release build):
//   cmake -S . -B build -DCMAKE_BUILD_TYPE=Release && cmake --build build -j --target bench_flow
//   build/tools/bench_flow                       # everything: ~10k/100k/1M generated + shared meshes
//   build/tools/bench_flow --quick               # a small set (generated ~10k, shared meshes ≤ 12k faces)
//   build/tools/bench_flow /path/to/meshes --out bench.md --threads 8
//
// Options:
//   MESHES_DIR         the shared meshes folder (subfolders genus0, genus1, genus2, genus3plus,
//                      boundary, derived). Default: ../shared/meshes beside the repository.
//   --quick            small set only; gradient descent capped at 10 s.
//   --out FILE.md      also write the table to FILE.md (atomically).
//   --threads N        OpenMP threads for the kernels (0: the OpenMP default). Default: 0.
//   --gd-seconds S     cap of gradient descent's wall time per mesh. Default: 60 (10 with --quick).
//   --gd-iters N       cap of gradient descent's iterations per mesh. Default: 20000.
//   --no-gradient      skip the gradient-descent column.
//
// Columns, per input: background geometry chosen by the topology; #F; Newton iterations to
// 1e-10; final max |K̄ − K|; prep = load/generate + initial metric seconds; total flow seconds
// and seconds per Newton iteration; then the time to reach max error < 1e-6 by Newton (read off
// its history) and by gradient descent with step 0.05 (the comparison of the paper's Fig. 6).
// Gradient descent is capped at --gd-iters iterations and --gd-seconds (it runs in chunks sized
// to the time left); a capped run shows "capped" with its iterations, time and error.
// Timings are wall-clock and sensitive to other load on the machine: OpenMP threads that wait
// actively slow down badly when the cores are shared (try --threads 1 or OMP_WAIT_POLICY=passive).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "bench_common.h"
#include "ricci/flow.h"
#include "ricci/io.h"
#include "ricci/metric.h"
#include "ricci/validate.h"
#include "shapes.h"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr double kNewtonTolerance = 1e-10;
constexpr double kCompareTolerance = 1e-6;

struct Settings {
  fs::path meshes;
  bool quick = false;
  std::string out;
  int threads = 0;
  double gd_seconds = 60;
  int gd_iters = 20000;
  bool gradient = true;
};

using bench_common::compiler_name;
using bench_common::cpu_model;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

using bench_common::fmt;

/// An input: a name and a way to produce a validated mesh.
struct Input {
  std::string name;
  std::function<ricci::ValidateResult()> make;
};

ricci::ValidateResult validated(const ricci::Mesh& mesh) { return ricci::validate_mesh(mesh); }

std::vector<Input> generated_inputs(bool quick) {
  using namespace ricci_shapes;
  std::vector<Input> in;
  // Sizes of about 10k, 100k and 1M faces: torus 2·n·m faces; icosphere 20·4^s; pretzel (genus
  // 2) 100·c² faces for c cells per unit, midpoint-subdivided (×4 each) beyond c = 32.
  struct Size {
    const char* label;
    int torus_minor, ico, pretzel_cells, pretzel_subdiv;
  };
  const Size sizes[] = {{"10k", 50, 5, 10, 0}, {"100k", 158, 6, 32, 0}, {"1M", 500, 8, 25, 2}};
  for (const Size& s : sizes) {
    const int m = s.torus_minor;
    in.push_back({std::string("generated/torus-") + s.label,
                  [m] { return validated(torus(2 * m, m, 1.0, 0.5)); }});
    const int ico = s.ico;
    in.push_back({std::string("generated/icosphere-") + s.label, [ico] { return validated(icosphere(ico)); }});
    const int c = s.pretzel_cells, k = s.pretzel_subdiv;
    in.push_back({std::string("generated/pretzel2-") + s.label, [c, k] {
                    Mesh mesh = pretzel(2, c);
                    for (int i = 0; i < k; ++i) mesh = subdivide_midpoint(mesh);
                    return validated(mesh);
                  }});
    if (quick) break;
  }
  return in;
}

std::vector<Input> shared_inputs(const fs::path& root, bool quick) {
  std::vector<Input> in;
  if (root.empty() || !fs::is_directory(root)) return in;
  for (const char* folder : {"genus0", "genus1", "genus2", "genus3plus", "boundary", "derived"}) {
    std::vector<fs::path> files;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(root / folder, ec)) {
      const std::string ext = e.path().extension().string();
      if (e.is_regular_file() && (ext == ".obj" || ext == ".off" || ext == ".ply")) files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) {
      // --quick: only files small enough to be ≤ ~12k faces (about 40 bytes per face in text).
      if (quick && fs::file_size(f, ec) > 700'000) continue;
      const std::string path = f.string();
      in.push_back({std::string(folder) + "/" + f.filename().string(), [path] {
                      ricci::LoadResult r = ricci::load_mesh(path);
                      if (r.status != ricci::Status::Ok) {
                        ricci::ValidateResult v;
                        v.status = r.status;
                        v.message = r.message;
                        return v;
                      }
                      return std::move(r.validated);
                    }});
    }
  }
  return in;
}

struct Row {
  std::string name, geometry, faces = "—", newton_iters = "—", max_error = "—", prep = "—", flow = "—",
                                  per_iter = "—", newton_1e6 = "—", gradient_1e6 = "—";
};

/// Seconds at which a history first reports max error < tol, or a negative value.
double time_to(const ricci::FlowResult& r, double tol) {
  for (const ricci::IterationRecord& h : r.history)
    if (h.max_error < tol) return h.seconds;
  return -1;
}

struct GradientRun {
  ricci::Status status = ricci::Status::NotRun;
  int iterations = 0;
  double seconds = 0;
  double error = 0;
};

/// Gradient descent (step 0.05) to 1e-6 under both caps. Runs in chunks, each continuing from the
/// last u (the flow has no memory beyond u), so the wall-time cap holds even when the time per
/// iteration varies: each chunk is sized from the measured time per iteration to a quarter of
/// what is left, growing at most twofold.
GradientRun gradient_descent(const ricci::Topology& topo, const ricci::ConformalStructure& structure,
                             std::span<const double> u0, const ricci::Target& target, const Settings& s) {
  GradientRun out;
  std::vector<double> u(u0.begin(), u0.end());
  ricci::FlowOptions gd;
  gd.method = ricci::Method::GradientDescent;
  gd.tolerance = kCompareTolerance;
  gd.gradient_step = 0.05;
  gd.threads = s.threads;
  int chunk = 16;
  while (true) {
    gd.max_iterations = std::max(1, std::min(chunk, s.gd_iters - out.iterations));
    const ricci::FlowResult g = ricci::solve_flow(topo, structure, u, target, gd);
    out.iterations += g.iterations;
    out.seconds += g.seconds;
    out.error = g.max_curvature_error;
    out.status = g.status;
    if (g.status != ricci::Status::NotConverged || out.iterations >= s.gd_iters || out.seconds >= s.gd_seconds)
      return out;
    u = g.u;
    const double per = g.seconds / std::max(1, g.iterations);
    // A quarter of what is left, so that even a fourfold slowdown (a busy machine) stays in the cap.
    const double fits = per > 0 ? 0.25 * (s.gd_seconds - out.seconds) / per : 2.0 * chunk;
    chunk = static_cast<int>(std::max(1.0, std::min(2.0 * chunk, fits)));
  }
}

Row bench(const Input& input, const Settings& s) {
  Row row;
  row.name = input.name;
  const Clock::time_point t0 = Clock::now();
  const ricci::ValidateResult mesh = input.make();
  if (mesh.status != ricci::Status::Ok) {
    row.geometry = "error: " + std::string(ricci::status_name(mesh.status));
    return row;
  }
  const ricci::Topology& topo = mesh.topology;
  row.faces = std::to_string(topo.num_faces);
  const ricci::Geometry geometry = ricci::natural_geometry(topo);
  row.geometry = std::string(ricci::geometry_name(geometry));
  ricci::InitialMetricOptions mo;
  mo.geometry = geometry;
  const ricci::InitialMetric metric = ricci::initial_metric(mesh.mesh, topo, mo);
  if (metric.status != ricci::Status::Ok) {
    row.newton_iters = std::string(ricci::status_name(metric.status));
    return row;
  }
  const ricci::Target target = ricci::uniform_target(topo, ricci::natural_boundary_mode(topo, geometry));
  const ricci::TargetCheck check = ricci::check_target(topo, metric.structure, target);
  if (check.status != ricci::Status::Ok) {
    row.newton_iters = std::string(ricci::status_name(check.status));
    return row;
  }
  row.prep = fmt("%.2f", seconds_since(t0));

  ricci::FlowOptions newton;
  newton.tolerance = kNewtonTolerance;
  newton.threads = s.threads;
  const ricci::FlowResult n = ricci::solve_flow(topo, metric.structure, metric.u, target, newton);
  row.newton_iters = std::to_string(n.iterations);
  if (n.status != ricci::Status::Ok) row.newton_iters += " (" + std::string(ricci::status_name(n.status)) + ")";
  row.max_error = fmt("%.1e", n.max_curvature_error);
  row.flow = fmt("%.3f", n.seconds);
  if (n.iterations > 0) row.per_iter = fmt("%.4f", n.seconds / n.iterations);
  const double n6 = time_to(n, kCompareTolerance);
  row.newton_1e6 = n6 >= 0 ? fmt("%.3f", n6) : std::string("not reached");

  if (s.gradient) {
    const GradientRun g = gradient_descent(topo, metric.structure, metric.u, target, s);
    if (g.status == ricci::Status::Ok)
      row.gradient_1e6 = fmt("%.3f", g.seconds) + " (" + std::to_string(g.iterations) + " it)";
    else if (g.status == ricci::Status::NotConverged)
      row.gradient_1e6 = "capped: " + std::to_string(g.iterations) + " it, " + fmt("%.1f", g.seconds) + " s, err " +
                         fmt("%.1e", g.error);
    else
      row.gradient_1e6 = std::string(ricci::status_name(g.status)) + " after " + std::to_string(g.iterations) + " it";
  }
  return row;
}

std::string table_header() {
  return "| input | geometry | #F | Newton it. | max error | prep s | flow s | s/it | Newton → 1e-6 s | "
         "gradient → 1e-6 s |\n"
         "|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
}

std::string table_row(const Row& r) {
  return "| " + r.name + " | " + r.geometry + " | " + r.faces + " | " + r.newton_iters + " | " + r.max_error + " | " +
         r.prep + " | " + r.flow + " | " + r.per_iter + " | " + r.newton_1e6 + " | " + r.gradient_1e6 + " |\n";
}

int usage(const char* argv0) {
  std::cerr << "usage: " << argv0
            << " [MESHES_DIR] [--quick] [--out FILE.md] [--threads N] [--gd-seconds S] [--gd-iters N] "
               "[--no-gradient]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  bool gd_seconds_given = false;
  s.meshes = fs::path(RICCI_SOURCE_DIR).parent_path() / "shared" / "meshes";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    if (a == "--quick") {
      s.quick = true;
    } else if (a == "--no-gradient") {
      s.gradient = false;
    } else if (a == "--out") {
      const char* v = value();
      if (!v) return usage(argv[0]);
      s.out = v;
    } else if (a == "--threads" || a == "--gd-seconds" || a == "--gd-iters") {
      const char* v = value();
      if (!v) return usage(argv[0]);
      char* end = nullptr;
      const double x = std::strtod(v, &end);
      if (*end != '\0' || !(x >= 0)) return usage(argv[0]);
      if (a == "--threads") s.threads = static_cast<int>(x);
      if (a == "--gd-seconds") {
        s.gd_seconds = x;
        gd_seconds_given = true;
      }
      if (a == "--gd-iters") s.gd_iters = static_cast<int>(x);
    } else if (a == "-h" || a == "--help") {
      usage(argv[0]);
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      return usage(argv[0]);
    } else {
      s.meshes = a;
    }
  }
  if (s.quick && !gd_seconds_given) s.gd_seconds = 10;

  std::vector<Input> inputs = generated_inputs(s.quick);
  const std::vector<Input> shared = shared_inputs(s.meshes, s.quick);
  if (shared.empty()) std::cerr << "bench_flow: no meshes under " << s.meshes.string() << "; generated meshes only\n";
  inputs.insert(inputs.end(), shared.begin(), shared.end());

  std::string doc = "# ricci flow benchmark\n\n";
  doc += "Uniformization with auto settings (circle packing; geometry by topology; circle boundary in E, "
         "geodesic in H), Newton to max error < 1e-10; gradient descent (step 0.05) to 1e-6, capped at " +
         std::to_string(s.gd_iters) + " iterations / " + fmt("%g", s.gd_seconds) + " s. Hardware threads: " +
         std::to_string(std::thread::hardware_concurrency()) + "; --threads " + std::to_string(s.threads) +
         (s.quick ? "; --quick" : "") + ".\n\n" + "Machine: " + cpu_model() + "; compiler: " + compiler_name() +
         ".\n\n";
  doc += table_header();
  std::cout << doc << std::flush;
  for (const Input& in : inputs) {
    std::cerr << "bench_flow: " << in.name << " …\n";
    const std::string line = table_row(bench(in, s));
    std::cout << line << std::flush;
    doc += line;
  }
  if (!s.out.empty()) {
    const ricci::WriteResult w = ricci::write_file_atomic(s.out, doc);
    if (w.status != ricci::Status::Ok) {
      std::cerr << "bench_flow: " << w.message << '\n';
      return 1;
    }
  }
  return 0;
}
