// Tests of `ricci uniformize`, `ricci layout` and `ricci cover`, run as separate processes: the
// embedded default end to end (the report keys scripts rely on, every output file and what it
// holds), the output directory's all-or-nothing replacement rules, a stored metric laid out
// again, the cover tiling, and exit codes for bad input.
#include <doctest/doctest.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include <cmath>
#include <numbers>
#include <complex>
#include <optional>
#include <random>
#include <sstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "huge_pages.h"
#include "ricci/deck.h"
#include "pictures.h"
#include "ricci/io.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

namespace {

using ricci_test::run_cli;
using ricci_test::TempDir;
using Json = nlohmann::json;
namespace fs = std::filesystem;

Json parse(const std::string& text) { return Json::parse(text, nullptr, /*allow_exceptions=*/false); }

/// Names in a directory (hidden staging directories included).
std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

namespace {

/// report.json's malloc_huge_pages after `ricci uniformize` on the torus fixture with GLIBC_TUNABLES
/// and RICCI_HUGE_PAGES set to the given values (null: unset) in its environment.
Json huge_pages_reported(const char* tunables, const char* ricci_huge_pages) {
  struct Env {
    const char* name;
    std::optional<std::string> saved;
    Env(const char* n, const char* value) : name(n) {
      if (const char* v = std::getenv(n)) saved = v;
      if (value != nullptr) {
        ::setenv(n, value, 1);
      } else {
        ::unsetenv(n);
      }
    }
    ~Env() {
      if (saved) {
        ::setenv(name, saved->c_str(), 1);
      } else {
        ::unsetenv(name);
      }
    }
  } a("GLIBC_TUNABLES", tunables), b("RICCI_HUGE_PAGES", ricci_huge_pages);
  TempDir tmp;
  const auto r = run_cli({"uniformize", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o",
                          (tmp / "out").string(), "--no-pictures", "--json", "-q"});
  REQUIRE(r.exit_code == 0);
  const Json j = parse(r.out);
  REQUIRE(j.contains("malloc_huge_pages"));
  return j["malloc_huge_pages"];
}

}  // namespace

TEST_CASE("cli uniformize: malloc backs large blocks with huge pages where the kernel takes advice") {
  // The CLI re-executes itself once with glibc.malloc.hugetlb=1 (cli/huge_pages.h) when glibc
  // has the tunable, the build has glibc's allocator and the kernel's THP mode is "madvise".
  bool expected = ricci_cli::transparent_huge_page_mode() == "madvise";
#if !defined(__GLIBC__) || defined(RICCI_SANITIZED_ALLOCATOR) || (__GLIBC__ == 2 && __GLIBC_MINOR__ < 35)
  expected = false;
#endif
  INFO("THP mode: " << ricci_cli::transparent_huge_page_mode());
  CHECK(huge_pages_reported(nullptr, nullptr) == expected);
  CHECK(huge_pages_reported(nullptr, "0") == false);  // turned off
  CHECK(huge_pages_reported("glibc.malloc.hugetlb=0", nullptr) == false);  // the user's own setting wins
  CHECK(huge_pages_reported("glibc.malloc.hugetlb=1", "0") == true);       // set by the user
  // Other tunables are kept beside it.
  CHECK(huge_pages_reported("glibc.malloc.check=0", nullptr) == expected);
}

TEST_CASE("cli uniformize: the embedded default runs the whole pipeline and writes every output") {
  TempDir tmp;
  const fs::path out = tmp / "out";
  const auto r = run_cli({"uniformize", "-o", out.string(), "--json"});
  REQUIRE(r.exit_code == 0);
  const Json j = parse(r.out);
  REQUIRE(j.is_object());
  for (const char* key : {"status", "message", "input", "mesh", "geometry", "scheme", "boundary", "iterations",
                          "chord_steps", "max_curvature_error", "layout", "seed_independence_error", "cut", "generators",
                          "relation_error", "angle_distortion", "timings", "total_seconds", "outputs", "history",
                          "notes", "repairs"})
    CHECK_MESSAGE(j.contains(key), key);
  CHECK(j["status"] == "ok");
  CHECK(j["geometry"] == "hyperbolic");
  CHECK(j["scheme"] == "yamabe");
  CHECK(j["flips"] == true);
  REQUIRE(j["intrinsic"].is_object());
  CHECK(j["intrinsic"]["refined"].is_boolean());
  CHECK(j["fallback"].is_null());
  CHECK(j["mesh"]["genus"] == 2);
  CHECK(j["iterations"].get<int>() >= 1);
  CHECK(j["chord_steps"].get<int>() >= 0);
  CHECK(j["chord_steps"].get<int>() < j["iterations"].get<int>());  // the first step factorizes
  CHECK(j["max_curvature_error"].get<double>() < 1e-12);
  CHECK(j["layout"]["max_edge_length_error"].get<double>() < 1e-9);
  CHECK(j["layout"]["flipped_faces"] == 0);
  CHECK(j["seed_independence_error"].get<double>() < 1e-9);
  // One chart resolving every vertex: the check compared all of them.
  CHECK(j["seed_check_vertices"].get<long long>() == j["cut"]["cut_vertices"].get<long long>());
  CHECK(j["relation_error"].get<double>() < 1e-9);
  REQUIRE(j["generators"].size() == 4);
  for (const Json& g : j["generators"]) {
    CHECK(g["residual_max"].get<double>() < 1e-9);
    CHECK(g["translation_length"].get<double>() > 0);
  }
  // The layout is the compact domain; the canonical polygon is the geodesic octagon of the
  // canonical generators, each a word in the domain's side pairings.
  CHECK(j["cut"]["kind"] == "compact");
  CHECK(j["cut"]["canonical"] == false);
  CHECK(j["polygon"]["kind"] == "geodesic");
  CHECK(j["polygon"]["word"] == "a1 b1 a1^-1 b1^-1 a2 b2 a2^-1 b2^-1");
  CHECK(j["polygon"]["vertices"].size() == 8);
  CHECK(j["polygon"]["simple"] == true);
  CHECK(j["polygon"]["angle_sum"].get<double>() == doctest::Approx(2 * std::numbers::pi).epsilon(1e-12));
  CHECK(j["polygon"]["area"].get<double>() == doctest::Approx(4 * std::numbers::pi).epsilon(1e-12));
  CHECK(j["polygon"]["closure_error"].get<double>() < 1e-12);
  CHECK(j["polygon"]["arithmetic_bits"] == 113);  // quad verifies the genus-2 octagon
  CHECK(j["polygon"]["relation_floor"].get<double>() < 1e-25);
  CHECK(j["polygon"]["generator_words"].size() == 4);
  CHECK(j["domain_cycle_error"].get<double>() < 1e-12);
  CHECK(j["domain_adjusted_cycle_error"].get<double>() < 1e-25);
  CHECK(j["domain_pairing_adjustment"].get<double>() < 1e-10);
  CHECK(j["fitted_relation_error"].get<double>() < 1e-9);
  CHECK(j["angle_distortion"]["mean"].get<double>() <= j["angle_distortion"]["max"].get<double>());
  for (const char* stage : {"load", "initial_metric", "target", "flow", "cut", "layout", "seed_check", "deck", "outputs", "pictures"})
    CHECK_MESSAGE(j["timings"].contains(stage), stage);
  // Progress on stderr for every stage, and a final summary line on stdout without --json.
  for (const char* stage : {"initial_metric", "flow iteration 1", "cut:", "layout:", "seed_check", "deck:", "wrote"})
    CHECK_MESSAGE(r.err.find(stage) != std::string::npos, stage);

  // The files.
  const std::vector<std::string> files = listing(out);
  CHECK(files == std::vector<std::string>{
                     "angles.png",      "angles.svg",      "checker-1.png",   "checker-2.png",
                     "checker-3.png",   "convergence-time.png", "convergence-time.svg", "convergence.png",
                     "convergence.svg", "cover.obj",       "cover.png",       "cover.svg",
                     "domain.obj",      "domain.png",      "domain.svg",      "generators.json",
                     "mesh.glb",        "mesh.obj",        "metric.csv",      "polygon.png",
                     "polygon.svg",     "report.html",     "report.json",     "signature.json"});
  // The checkerboard's texture map is close to conformal (square checks): sigma_max/sigma_min.
  CHECK(j["conformal_distortion"]["faces"].get<int>() > 1000);
  CHECK(j["conformal_distortion"]["median"].get<double>() < 1.5);
  // Every PNG decodes to a non-empty picture.
  for (const std::string& name : files)
    if (name.size() > 4 && name.substr(name.size() - 4) == ".png") {
      const ricci_cli::Image img = ricci_cli::decode_png(ricci_test::read_bytes(out / name));
      CHECK_MESSAGE(img.width > 100, name);
    }
  const Json report = parse(ricci_test::read_bytes(out / "report.json"));
  REQUIRE(report.is_object());
  CHECK(report["status"] == "ok");
  CHECK(report["relation_error"] == j["relation_error"]);
  CHECK(report["layout"] == j["layout"]);
  // mesh.obj: the surface with per-corner texture coordinates inside the Poincare disk, seams
  // along the cut (more texture coordinates than vertices).
  const ricci::ReadResult mesh = ricci::read_mesh((out / "mesh.obj").string());
  REQUIRE(mesh.status == ricci::Status::Ok);
  CHECK(mesh.mesh.has_texcoords());
  CHECK(mesh.mesh.num_texcoords() > mesh.mesh.num_vertices());
  CHECK(mesh.mesh.num_faces() >= j["mesh"]["faces"].get<int>());
  for (std::size_t k = 0; k + 1 < mesh.mesh.texcoords.size(); k += 2)
    CHECK(std::hypot(mesh.mesh.texcoords[k], mesh.mesh.texcoords[k + 1]) < 1);
  // generators.json: the maps themselves; each matrix is in SU(1,1).
  const Json gens = parse(ricci_test::read_bytes(out / "generators.json"));
  REQUIRE(gens.is_object());
  CHECK(gens["word"] == j["polygon"]["word"]);
  CHECK(gens["generator_words"] == j["polygon"]["generator_words"]);
  CHECK(gens["domain_side_pairings"].size() >= 4);
  REQUIRE(gens["generators"].size() == 4);
  for (const Json& g : gens["generators"]) {
    const std::complex<double> a(g["matrix"]["a"][0].get<double>(), g["matrix"]["a"][1].get<double>());
    const std::complex<double> b(g["matrix"]["b"][0].get<double>(), g["matrix"]["b"][1].get<double>());
    CHECK(std::norm(a) - std::norm(b) == doctest::Approx(1).epsilon(1e-12));
    const ricci::Moebius m{a, b};
    CHECK(m.theta() == doctest::Approx(g["theta"].get<double>()).epsilon(1e-12));
  }
  CHECK(ricci_test::read_bytes(out / "cover.svg").find("<svg") != std::string::npos);
  CHECK(ricci_test::read_bytes(out / "metric.csv").find("# edge,v0,v1,length") != std::string::npos);

  // Text mode: one summary line on stdout.
  const fs::path out2 = tmp / "out2";
  const auto t = run_cli({"uniformize", "-o", out2.string(), "-q"});
  CHECK(t.exit_code == 0);
  CHECK(t.err.empty());
  CHECK(t.out.rfind("ok hyperbolic", 0) == 0);
}

TEST_CASE("cli uniformize: --cut-after-flow gives the same mesh.obj as the cut beside the flow") {
  TempDir tmp;
  const std::string torus = (ricci_test::fixtures_dir() / "torus.obj").string();
  const auto beside = run_cli({"uniformize", torus, "-o", (tmp / "a").string(), "--no-pictures", "--threads", "2"});
  const auto after =
      run_cli({"uniformize", torus, "-o", (tmp / "b").string(), "--no-pictures", "--threads", "2", "--cut-after-flow"});
  REQUIRE(beside.exit_code == 0);
  REQUIRE(after.exit_code == 0);
  CHECK(beside.err.find("(beside the flow)") != std::string::npos);
  CHECK(after.err.find("(beside the flow)") == std::string::npos);
  CHECK(ricci_test::read_bytes(tmp / "a" / "mesh.obj") == ricci_test::read_bytes(tmp / "b" / "mesh.obj"));
}

TEST_CASE("cli uniformize: --mesh-polygon lays a canonical cut of the mesh out as the polygon (polygon.obj)") {
  TempDir tmp;
  const fs::path out = tmp / "out";
  const auto r = run_cli({"uniformize", "-o", out.string(), "--json", "--no-pictures", "--mesh-polygon"});
  REQUIRE(r.exit_code == 0);
  const Json j = parse(r.out);
  CHECK(j["polygon"]["kind"] == "mesh");
  CHECK(j["polygon"]["word"] == "a1 b1 a1^-1 b1^-1 a2 b2 a2^-1 b2^-1");
  CHECK(j["polygon"]["canonical"] == true);
  CHECK(j["polygon"]["max_edge_length_error"].get<double>() < 1e-9);
  CHECK(j["polygon"]["flipped_faces"] == 0);
  CHECK(j["polygon"]["base_candidates"].size() >= 1);
  bool a_view = false;  // the polygon shown came from a base whose note is empty
  for (const auto& b : j["polygon"]["base_candidates"]) a_view |= b["note"] == "";
  CHECK(a_view);
  // The geodesic polygon of the same generators, in their frame.
  CHECK(j["polygon"]["geodesic"]["simple"] == true);
  CHECK(j["polygon"]["geodesic"]["angle_sum"].get<double>() == doctest::Approx(2 * std::numbers::pi).epsilon(1e-12));
  CHECK(j["relation_error"].get<double>() < 1e-9);
  CHECK(j["fitted_relation_error"].get<double>() < 1e-9);
  CHECK(fs::exists(out / "polygon.obj"));
  const Json gens = parse(ricci_test::read_bytes(out / "generators.json"));
  CHECK(gens["word"] == j["polygon"]["word"]);
  CHECK(!gens.contains("generator_words"));
}

TEST_CASE("cli uniformize: cover.obj only up to --cover-faces faces, with a note naming its size otherwise") {
  TempDir tmp;
  // The default writes the embedded genus-2 surface's tiling: one copy of the domain per tile.
  const fs::path all = tmp / "all";
  const auto r = run_cli({"uniformize", "-o", all.string(), "--json", "--no-pictures", "-q"});
  REQUIRE(r.exit_code == 0);
  const ricci::ReadResult tiling = ricci::read_mesh((all / "cover.obj").string());
  REQUIRE(tiling.status == ricci::Status::Ok);
  const ricci::ReadResult domain = ricci::read_mesh((all / "domain.obj").string());
  REQUIRE(domain.status == ricci::Status::Ok);
  const long long faces = static_cast<long long>(tiling.mesh.num_faces());
  REQUIRE(faces > domain.mesh.num_faces());
  CHECK(faces % domain.mesh.num_faces() == 0);
  // Exactly at the limit it is written; one face below, not, and the note says why.
  const fs::path at = tmp / "at", below = tmp / "below";
  REQUIRE(run_cli({"uniformize", "-o", at.string(), "--no-pictures", "-q", "--cover-faces", std::to_string(faces)})
              .exit_code == 0);
  CHECK(fs::exists(at / "cover.obj"));
  const auto b = run_cli({"uniformize", "-o", below.string(), "--json", "--no-pictures", "-q", "--cover-faces",
                          std::to_string(faces - 1)});
  REQUIRE(b.exit_code == 0);
  CHECK_FALSE(fs::exists(below / "cover.obj"));
  CHECK(fs::exists(below / "cover.svg"));
  const Json j = parse(b.out);
  bool noted = false;
  for (const Json& n : j["notes"])
    noted |= n.get<std::string>().find("cover.obj not written") != std::string::npos &&
             n.get<std::string>().find(std::to_string(faces) + " faces") != std::string::npos;
  CHECK(noted);
  bool listed = false;
  for (const Json& f : j["outputs"]) listed |= f == "cover.obj";
  CHECK_FALSE(listed);
  CHECK(run_cli({"uniformize", "-o", (tmp / "bad").string(), "--cover-faces", "-1"}).exit_code == 2);
}

TEST_CASE("cli uniformize: the output directory is all or nothing") {
  TempDir tmp;
  const std::string torus = (ricci_test::fixtures_dir() / "torus.obj").string();
  const fs::path out = tmp / "out";
  REQUIRE(run_cli({"uniformize", torus, "-o", out.string(), "-q"}).exit_code == 0);
  const std::string first = ricci_test::read_bytes(out / "report.json");
  // A previous ricci output directory is replaced as a whole.
  ricci_test::write_bytes(out / "stale.txt", "old");
  REQUIRE(run_cli({"uniformize", torus, "-o", out.string(), "-q"}).exit_code == 0);
  CHECK(!fs::exists(out / "stale.txt"));
  CHECK(fs::exists(out / "generators.json"));
  // A directory that is not ricci's is refused and left alone.
  const fs::path mine = tmp / "mine";
  fs::create_directory(mine);
  ricci_test::write_bytes(mine / "notes.txt", "keep");
  const auto refused = run_cli({"uniformize", torus, "-o", mine.string(), "-q"});
  CHECK(refused.exit_code == 6);
  CHECK(refused.err.find("refusing") != std::string::npos);
  CHECK(listing(mine) == std::vector<std::string>{"notes.txt"});
  // An output directory that holds the input is refused.
  const fs::path holder = tmp / "holder";
  fs::create_directory(holder);
  fs::copy_file(torus, holder / "torus.obj");
  ricci_test::write_bytes(holder / "report.json", "{}");
  const auto self = run_cli({"uniformize", (holder / "torus.obj").string(), "-o", holder.string(), "-q"});
  CHECK(self.exit_code == 6);
  CHECK(fs::exists(holder / "torus.obj"));
  // A failing run writes nothing and leaves no staging directory: an infeasible cone file.
  const fs::path cones = tmp / "cones.txt";
  ricci_test::write_bytes(cones, "0 6.283185307179586\n");
  const fs::path failed = tmp / "failed";
  const auto bad = run_cli({"uniformize", torus, "-o", failed.string(), "--target", "cones=" + cones.string(), "-q"});
  CHECK(bad.exit_code == 8);
  CHECK(bad.err.find("no output written") != std::string::npos);
  CHECK(!fs::exists(failed));
  for (const std::string& name : listing(tmp.path())) CHECK_MESSAGE(name.find("ricci-tmp") == std::string::npos, name);
  // Usage errors.
  CHECK(run_cli({"uniformize", torus, "-q"}).exit_code == 2);
  CHECK(run_cli({"uniformize", torus, "-o", out.string(), "--base-candidates", "0"}).exit_code == 2);
  CHECK(run_cli({"uniformize", (tmp / "missing.obj").string(), "-o", (tmp / "x").string()}).exit_code == 3);
  CHECK(!fs::exists(tmp / "x"));
}

TEST_CASE("cli uniformize: torus, sphere and disk outputs") {
  TempDir tmp;
  const auto torus = run_cli({"uniformize", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o",
                              (tmp / "t").string(), "--json", "-q", "--no-pictures"});
  REQUIRE(torus.exit_code == 0);
  const Json t = parse(torus.out);
  CHECK(t["geometry"] == "euclidean");
  CHECK(t["generators"].size() == 2);
  CHECK(t["relation_error"].get<double>() < 1e-12);
  CHECK(t["layout"]["domain"] == "plane");
  CHECK(t["cut"]["kind"] == "canonical");
  CHECK(t["polygon"]["word"] == "a1 b1 a1^-1 b1^-1");
  CHECK(t["layout"]["patches"] == 0);  // 512 faces: below the automatic threshold
  CHECK(t["layout"]["patch_seam_error"].is_null());
  // Forced divide and conquer: 8 patches, or 0 when the glued layout was not more accurate.
  const auto split = run_cli({"uniformize", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o",
                              (tmp / "t8").string(), "--json", "-q", "--no-pictures", "--patches", "8"});
  REQUIRE(split.exit_code == 0);
  const Json t8 = parse(split.out);
  const int used = t8["layout"]["patches"].get<int>();
  CHECK((used == 8 || used == 0));
  if (used == 8) CHECK(t8["layout"]["patch_seam_error"].get<double>() < 1e-9);
  CHECK(t8["layout"]["max_edge_length_error"].get<double>() < 1e-12);
  CHECK(run_cli({"uniformize", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o", (tmp / "t9").string(), "-q",
                 "--patches", "257"})
            .exit_code == 2);
  // --layout-refine-above 0: the sweeps run down to the rounding floor (not at the default, where
  // one propagation is within 1e-10 of it on this torus); a negative threshold is a usage error.
  CHECK(t["layout"]["polish_sweeps"] == 0);
  const auto strict = run_cli({"uniformize", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o",
                               (tmp / "t0").string(), "--json", "-q", "--no-pictures", "--layout-refine-above", "0"});
  REQUIRE(strict.exit_code == 0);
  const Json t0 = parse(strict.out);
  CHECK(t0["layout"]["max_edge_length_error"].get<double>() <= t["layout"]["max_edge_length_error"].get<double>());
  CHECK((t0["layout"]["polish_sweeps"].get<int>() > 0 || t0["layout"]["max_error_above_rounding"].get<double>() == 0));
  CHECK(run_cli({"uniformize", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o", (tmp / "t10").string(), "-q",
                 "--layout-refine-above", "-1"})
            .exit_code == 2);

  const auto sphere = run_cli({"uniformize", (ricci_test::fixtures_dir() / "icosphere.obj").string(), "-o",
                               (tmp / "s").string(), "--json", "-q"});
  REQUIRE(sphere.exit_code == 0);
  const Json s = parse(sphere.out);
  CHECK(s["geometry"] == "spherical");
  CHECK(s["layout"]["domain"] == "sphere");
  CHECK(s["generators"].empty());
  CHECK(s["relation_error"].is_null());
  // With pictures (the checkerboard from the Mercator projection of the sphere layout).
  for (const char* name : {"mesh.obj", "metric.csv", "report.json", "report.html", "sphere.obj", "domain.png", "checker-1.png",
                           "angles.png", "convergence.png"})
    CHECK_MESSAGE(fs::exists(tmp / "s" / name), name);
  CHECK(!fs::exists(tmp / "s" / "cover.png"));
  const ricci::ReadResult sph = ricci::read_mesh((tmp / "s" / "sphere.obj").string());
  REQUIRE(sph.status == ricci::Status::Ok);
  for (std::size_t k = 0; k + 2 < sph.mesh.positions.size(); k += 3)
    CHECK(std::hypot(sph.mesh.positions[k], sph.mesh.positions[k + 1], sph.mesh.positions[k + 2]) ==
          doctest::Approx(1).epsilon(1e-12));

  const auto disk = run_cli({"uniformize", (ricci_test::fixtures_dir() / "sphere-3holes.obj").string(), "-o",
                             (tmp / "d").string(), "--json", "-q", "--no-pictures"});
  REQUIRE(disk.exit_code == 0);
  const Json d = parse(disk.out);
  CHECK(d["geometry"] == "euclidean");
  CHECK(d["boundary"] == "circle");
  CHECK(d["layout"]["flipped_faces"] == 0);
  CHECK(listing(tmp / "d") ==
        std::vector<std::string>{"domain.obj", "mesh.glb", "mesh.obj", "metric.csv", "report.json", "signature.json"});
  CHECK(d["signature"]["circle_domain"]["circles"].size() == 3);
}

TEST_CASE("cli layout: a stored metric laid out again, a metric of another mesh is refused") {
  TempDir tmp;
  const std::string g2 = (ricci_test::fixtures_dir() / "genus2.obj").string();
  const fs::path metric = tmp / "metric.csv";
  REQUIRE(run_cli({"flow", g2, "--tol", "1e-12", "-o", metric.string(), "-q"}).exit_code == 0);
  const auto r = run_cli({"layout", g2, "--metric", metric.string(), "-o", (tmp / "lay").string(), "--json", "-q"});
  REQUIRE(r.exit_code == 0);
  const Json j = parse(r.out);
  CHECK(j["status"] == "ok");
  CHECK(j["geometry"] == "hyperbolic");
  CHECK(j["iterations"].is_null());
  CHECK(j["layout"]["max_edge_length_error"].get<double>() < 1e-9);
  CHECK(j["relation_error"].get<double>() < 1e-9);
  CHECK(!fs::exists(tmp / "lay" / "metric.csv"));
  // JSON metrics too.
  const fs::path mj = tmp / "metric.json";
  REQUIRE(run_cli({"flow", g2, "--tol", "1e-12", "-o", mj.string(), "-q"}).exit_code == 0);
  const auto rj = run_cli({"layout", g2, "--metric", mj.string(), "-o", (tmp / "layj").string(), "--json", "-q"});
  REQUIRE(rj.exit_code == 0);
  CHECK(parse(rj.out)["relation_error"] == j["relation_error"]);
  // The torus's metric does not fit the genus-2 mesh.
  const fs::path tm = tmp / "torus.csv";
  REQUIRE(run_cli({"flow", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o", tm.string(), "-q"}).exit_code == 0);
  const auto bad = run_cli({"layout", g2, "--metric", tm.string(), "-o", (tmp / "bad").string(), "-q"});
  CHECK(bad.exit_code == 4);
  CHECK(bad.err.find(tm.string()) != std::string::npos);
  CHECK(bad.err.find("another mesh") != std::string::npos);
  CHECK(!fs::exists(tmp / "bad"));
  // A malformed row names its line.
  const fs::path broken = tmp / "broken.csv";
  ricci_test::write_bytes(broken, "# edge,v0,v1,length\n0,1,x,0.5\n");
  const auto br = run_cli({"layout", g2, "--metric", broken.string(), "-o", (tmp / "br").string(), "-q"});
  CHECK(br.exit_code == 4);
  CHECK(br.err.find("line 2") != std::string::npos);
}

TEST_CASE("cli cover: the tiling as SVG or mesh, surfaces without a cover are refused") {
  TempDir tmp;
  const fs::path svg = tmp / "cover.svg";
  const auto r = run_cli({"cover", "--depth", "2", "-o", svg.string(), "--json", "-q"});
  REQUIRE(r.exit_code == 0);
  const Json j = parse(r.out);
  CHECK(j["copies"].get<int>() > 8);
  CHECK(ricci_test::read_bytes(svg).find("<svg") != std::string::npos);
  const fs::path obj = tmp / "cover.obj";
  REQUIRE(run_cli({"cover", (ricci_test::fixtures_dir() / "torus.obj").string(), "--depth", "3", "-o", obj.string(), "-q"})
              .exit_code == 0);
  const ricci::ReadResult m = ricci::read_mesh(obj.string());
  REQUIRE(m.status == ricci::Status::Ok);
  CHECK(m.mesh.num_faces() % 9 == 0);  // a 3x3 block of copies of the (refined) disk
  CHECK(m.mesh.num_faces() >= 9 * 1024);
  const auto disk = run_cli({"cover", (ricci_test::fixtures_dir() / "disk.obj").string(), "-o", svg.string(), "-q"});
  CHECK(disk.exit_code == 2);
  CHECK(disk.err.find("genus >= 1") != std::string::npos);
  CHECK(run_cli({"cover", "-o", (tmp / "c.txt").string()}).exit_code == 2);
}

namespace {

extern "C" char** environ;

/// Starts `ricci uniformize ... -o out` with RICCI_WRITE_PAUSE_MS=150, waits until its staging
/// directory appears beside `out`, lets it write a few files, sends `sig`, and returns the wait
/// status (or -1 when the staging directory never appeared).
int interrupt_while_writing(const fs::path& out, int sig) {
  const std::string cli = RICCI_CLI_PATH;
  std::vector<std::string> args = {cli, "uniformize", "-o", out.string(), "-q"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_store;
  for (char** e = environ; *e != nullptr; ++e) env_store.emplace_back(*e);
  env_store.emplace_back("RICCI_WRITE_PAUSE_MS=150");
  std::vector<char*> envp;
  for (auto& e : env_store) envp.push_back(e.data());
  envp.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, cli.c_str(), &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return -1;
  std::string staging_name = ".";
  staging_name += out.filename().string();
  staging_name += ".ricci-tmp-";
  staging_name += std::to_string(pid);
  const fs::path staging = out.parent_path() / staging_name;
  bool seen = false;
  for (int i = 0; i < 600 && !seen; ++i) {  // up to 60 s
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    seen = fs::exists(staging);
  }
  if (seen) std::this_thread::sleep_for(std::chrono::milliseconds(400));  // a few files written
  kill(pid, sig);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
  }
  return seen ? status : -1;
}

}  // namespace

TEST_CASE("cli uniformize and flow: a failed write prints no ok summary, exits 6 and leaves nothing") {
  // A name past the file system's 255 bytes fails to be created: a write failure any user can
  // meet (a full disk fails the same way, later), reproducible without one.
  TempDir tmp;
  const fs::path out = tmp / std::string(250, 'a');
  const auto u = run_cli({"uniformize", "-o", out.string(), "--no-pictures", "-q"});
  INFO(u.err);
  CHECK(u.exit_code == 6);
  CHECK(u.out.find("ok") != 0);
  CHECK(u.out.rfind("write_failed: ", 0) == 0);
  CHECK(u.err.find("nothing was written") != std::string::npos);
  CHECK(fs::is_empty(tmp.path()));
  const auto j = run_cli({"uniformize", "-o", out.string(), "--no-pictures", "-q", "--json"});
  CHECK(j.exit_code == 6);
  const Json report = parse(j.out);
  REQUIRE(report.is_object());
  CHECK(report["status"] == "write_failed");
  const auto f = run_cli({"flow", "-q", "-o", (tmp / (std::string(300, 'a') + ".json")).string()});
  INFO(f.err);
  CHECK(f.exit_code == 6);
  CHECK(f.out.rfind("write_failed: ", 0) == 0);
  CHECK(fs::is_empty(tmp.path()));
}

TEST_CASE("cli uniformize, flow and convert: a write cut off midway (file-size limit) exits 6 and leaves nothing") {
  // The write fails after part of a file landed, as on a disk that fills up: the process runs with
  // a file-size limit of 16 blocks (ulimit -f), below every output of the embedded default. Before
  // the CLI ignored SIGXFSZ it died by that signal and left its staging directory behind.
  TempDir tmp;
  const std::string cli = RICCI_CLI_PATH;
  const std::vector<std::vector<std::string>> runs = {
      {"uniformize", "-o", (tmp / "out").string(), "--no-pictures", "-q"},
      {"flow", "-o", (tmp / "metric.csv").string(), "-q"},
      {"convert", (ricci_test::fixtures_dir() / "genus2.obj").string(), "-o", (tmp / "mesh.ply").string()}};
  for (const std::vector<std::string>& args : runs) {
    std::string line = "ulimit -f 16; exec '" + cli + "'";
    for (const std::string& a : args) line += " '" + a + "'";
    CAPTURE(line);
    const auto r = ricci_test::run_program("/bin/sh", {"-c", line});
    INFO(r.err);
    CHECK(r.exit_code == 6);
    CHECK(r.out.find("ok") != 0);
    CHECK(fs::is_empty(tmp.path()));
  }
}

TEST_CASE("cli uniformize: an interrupted run leaves no partial output and keeps the previous OUTDIR") {
  TempDir tmp;
  for (int sig : {SIGINT, SIGTERM}) {
    CAPTURE(sig);
    // No previous OUTDIR: nothing at all is left.
    const fs::path out = tmp / ("fresh-" + std::to_string(sig));
    const int status = interrupt_while_writing(out, sig);
    REQUIRE(status != -1);
    CHECK(WIFSIGNALED(status));
    CHECK(WTERMSIG(status) == sig);
    CHECK(!fs::exists(out));
    // A previous OUTDIR: still there, unchanged.
    const fs::path prev = tmp / ("previous-" + std::to_string(sig));
    REQUIRE(run_cli({"uniformize", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o", prev.string(), "-q",
                     "--no-pictures"})
                .exit_code == 0);
    const std::string before = ricci_test::read_bytes(prev / "report.json");
    const int status2 = interrupt_while_writing(prev, sig);
    REQUIRE(status2 != -1);
    CHECK(WIFSIGNALED(status2));
    CHECK(ricci_test::read_bytes(prev / "report.json") == before);
    CHECK(!fs::exists(prev / "polygon.obj"));  // the genus-2 run's files never arrived
  }
  // No staging or set-aside directories are left behind.
  for (const std::string& name : listing(tmp.path())) CHECK_MESSAGE(name.rfind(".", 0) != 0, name);
}

namespace {

// A torus with needles and caps, written to dir/needles.obj: its straight input triangles fold at
// a few vertices, and its conformal factor jumps by more than 0.05 across the median edge.
ricci::Mesh needle_torus(const TempDir& dir, fs::path& file) {
  std::mt19937_64 rng(3);
  const ricci::Mesh m = ricci_shapes::insert_needles_and_caps(ricci_shapes::torus(16, 8, 2.0, 0.7), rng, 0.3, 0.02);
  file = dir / "needles.obj";
  REQUIRE(ricci::write_mesh(file.string(), m).status == ricci::Status::Ok);
  return m;
}

}  // namespace

TEST_CASE("cli uniformize: where straight input faces would fold, refinement.obj holds the common subdivision") {
  TempDir dir;
  fs::path mesh;
  const ricci::Mesh m = needle_torus(dir, mesh);
  const fs::path out = dir / "out";
  const auto r = run_cli({"uniformize", mesh.string(), "-o", out.string(), "--no-pictures", "--json", "-q"});
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  const Json j = parse(r.out);
  REQUIRE(j.is_object());
  CHECK(j["flips"] == true);
  REQUIRE(j["intrinsic"]["refined"] == true);
  CHECK(j["intrinsic"]["inconsistent_vertices"].get<int>() > 0);
  // refinement.obj: one face line per face of the subdivision, each under a group naming its
  // input face; mesh.obj keeps the input's faces.
  const std::string text = ricci_test::read_bytes(out / "refinement.obj");
  ricci::Index faces = 0, groups = 0, bad_group = 0;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("f ", 0) == 0) ++faces;
    if (line.rfind("g input_face_", 0) == 0) {
      ++groups;
      const long f = std::stol(line.substr(13));
      if (f < 0 || f >= static_cast<long>(m.num_faces())) ++bad_group;
    }
  }
  CHECK(faces == j["intrinsic"]["refinement_faces"].get<ricci::Index>());
  CHECK(groups >= static_cast<ricci::Index>(m.num_faces()));
  CHECK(bad_group == 0);
  const ricci::ReadResult back = ricci::read_mesh((out / "mesh.obj").string());
  REQUIRE(back.status == ricci::Status::Ok);
  CHECK(back.mesh.faces == m.faces);
  CHECK(back.mesh.has_texcoords());
  for (const char* name : {"report.json", "domain.obj", "metric.csv"}) CHECK_MESSAGE(fs::exists(out / name), name);
}

TEST_CASE("cli uniformize: Steiner points where the input's faces cannot carry the map, none with --steiner-levels 0") {
  // The needle torus: the default subdivides it on its own faces.
  TempDir dir;
  fs::path mesh;
  const ricci::Mesh m = needle_torus(dir, mesh);
  // Rows of metric.csv's vertex section: (input_vertex) per vertex.
  auto metric_rows = [](const fs::path& file) {
    std::vector<long> input;
    std::istringstream lines(ricci_test::read_bytes(file));
    bool vertices = false;
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("# vertex,", 0) == 0) vertices = true;
      else if (line.rfind("#", 0) == 0) vertices = false;  // the edge section's comments
      else if (vertices) input.push_back(std::stol(line.substr(line.find(',') + 1)));
    }
    return input;
  };
  double distortion[2] = {0, 0};
  for (const bool steiner : {true, false}) {
    CAPTURE(steiner);
    const fs::path out = dir / (steiner ? "on" : "off");
    std::vector<std::string> args = {"uniformize", mesh.string(), "-o", out.string(), "--no-pictures", "--json", "-q"};
    if (!steiner) args.insert(args.end(), {"--steiner-levels", "0"});
    const auto r = run_cli(args);
    REQUIRE_MESSAGE(r.exit_code == 0, r.err);
    const Json j = parse(r.out);
    REQUIRE(j.is_object());
    distortion[steiner ? 0 : 1] = j["angle_distortion"]["mean"].get<double>();
    const std::vector<long> rows = metric_rows(out / "metric.csv");
    const ricci::ReadResult back = ricci::read_mesh((out / "mesh.obj").string());
    REQUIRE(back.status == ricci::Status::Ok);
    CHECK(back.mesh.faces == m.faces);  // the user's faces either way
    if (steiner) {
      REQUIRE(j["steiner"].is_object());
      CHECK(j["steiner"]["used"] == true);
      const int levels = j["steiner"]["levels"].get<int>();
      CHECK(levels >= 1);
      CHECK(j["steiner"]["faces"].get<long>() == (static_cast<long>(m.num_faces()) << (2 * levels)));
      CHECK(j["steiner"]["median_jump"].get<double>() > 0.05);
      CHECK(j["steiner"]["refined_median_jump"].get<double>() < j["steiner"]["median_jump"].get<double>());
      // metric.csv: the input's vertices in order, then the Steiner vertices (input_vertex -1).
      const long added = j["steiner"]["vertices_added"].get<long>();
      REQUIRE(rows.size() == static_cast<std::size_t>(m.num_vertices() + added));
      for (std::size_t w = 0; w < rows.size(); ++w) CHECK(rows[w] == (w < static_cast<std::size_t>(m.num_vertices()) ? static_cast<long>(w) : -1));
      CHECK(j["timings"].contains("probe_flow"));
    } else {
      CHECK(j["steiner"].is_null());
      CHECK(rows.size() == static_cast<std::size_t>(m.num_vertices()));
    }
  }
  CHECK(distortion[0] < distortion[1]);
}

TEST_CASE("cli uniformize: boundary splits where triangles lean over a circle domain's boundary, none with --boundary-split-rounds 0") {
  // tools/random_surface_sweep's seed 44: an annulus stretched 11:1 whose circle domain needs
  // triangles to fold over boundary edges.
  TempDir dir;
  const fs::path mesh = dir / "seed44.obj";
  const ricci::Mesh m = ricci_shapes::random_surface(44, 1292).mesh;
  REQUIRE(ricci::write_mesh(mesh.string(), m).status == ricci::Status::Ok);
  const fs::path out = dir / "on";
  const auto r = run_cli({"uniformize", mesh.string(), "-o", out.string(), "--no-pictures", "--json", "-q",
                          "--seed-checks", "0"});
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  const Json j = parse(r.out);
  REQUIRE(j.is_object());
  REQUIRE(j["steiner"].is_object());
  CHECK(j["steiner"]["used"] == true);
  CHECK(j["steiner"]["levels"] == 0);
  const long splits = j["steiner"]["boundary_splits"].get<long>();
  CHECK(splits > 0);
  CHECK(j["steiner"]["boundary_split_rounds"].get<int>() >= 1);
  CHECK(j["steiner"]["vertices_added"].get<long>() == splits);
  CHECK(j["fallback"].is_null());
  CHECK(j["max_curvature_error"].get<double>() < 1e-12);
  CHECK(fs::exists(out / "refinement.obj"));
  // metric.csv: the validated input's vertices (an ear split among them), then the split ones.
  long appended = 0, rows = 0;
  std::istringstream lines(ricci_test::read_bytes(out / "metric.csv"));
  bool vertices = false;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("# vertex,", 0) == 0) vertices = true;
    else if (line.rfind("#", 0) == 0) vertices = false;
    else if (vertices) {
      ++rows;
      if (std::stol(line.substr(line.find(',') + 1)) == -1) ++appended;
    }
  }
  CHECK(rows >= m.num_vertices() + splits);
  CHECK(appended >= splits);
  const auto off = run_cli({"uniformize", mesh.string(), "-o", (dir / "off").string(), "--no-pictures", "-q",
                            "--seed-checks", "0", "--boundary-split-rounds", "0"});
  CHECK(off.exit_code == 7);
  CHECK(!fs::exists(dir / "off"));
}

TEST_CASE("cli uniformize: --no-flips and the paper's scheme run without flips") {
  TempDir dir;
  for (const std::vector<std::string>& extra : {std::vector<std::string>{"--no-flips"},
                                                std::vector<std::string>{"--scheme", "circle-packing"}}) {
    CAPTURE(extra[0]);
    const fs::path out = dir / ("out" + extra[0]);
    std::vector<std::string> args = {"uniformize", "-o", out.string(), "--no-pictures", "--json", "-q", "--seed-checks", "0"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = run_cli(args);
    REQUIRE_MESSAGE(r.exit_code == 0, r.err);
    const Json j = parse(r.out);
    REQUIRE(j.is_object());
    CHECK(j["flips"] == false);
    CHECK(j["intrinsic"].is_null());
    CHECK(j["scheme"] == (extra[0] == "--no-flips" ? "yamabe" : "circle-packing"));
    CHECK(!fs::exists(out / "refinement.obj"));
  }
}

TEST_CASE("cli uniformize: a surface one chart cannot hold is written as an atlas (groups in mesh.obj, maps in report.json)") {
  TempDir tmp;
  // A genus-2 surface with a finger of aspect 20 : 1 (tools/shapes): its finger's faces shrink
  // below what one Poincaré chart resolves.
  const fs::path in = tmp / "finger.obj";
  REQUIRE(ricci::write_mesh(in.string(), ricci_shapes::tube_pretzel(2, 4, 20, 3)).status == ricci::Status::Ok);
  const auto run = run_cli({"uniformize", in.string(), "-o", (tmp / "o").string(), "--json", "-q"});
  INFO(run.err);
  REQUIRE(run.exit_code == 0);
  const Json j = parse(run.out);
  const Json& L = j["layout"];
  const int charts = L["charts"].get<int>();
  CHECK(charts >= 2);
  CHECK(L["max_edge_length_error"].get<double>() <= 1e-9);
  CHECK(L["flipped_faces"] == 0);
  const Json& atlas = L["atlas"];
  REQUIRE(atlas.is_object());
  CHECK(atlas["root_max_edge_length_error"].get<double>() > 1e-6);
  REQUIRE(atlas["charts"].size() == static_cast<std::size_t>(charts));
  CHECK(j["relation_error"].get<double>() <= 1e-12);
  for (const char* name : {"mesh.obj", "domain.obj", "report.json", "report.html", "domain.png", "checker-1.png", "polygon.png"})
    CHECK_MESSAGE(fs::exists(tmp / "o" / name), name);

  // mesh.obj: a group per run of faces of one chart; each corner's vt, carried by its chart's map
  // into the root chart, lands on that corner's position in domain.obj (the root chart).
  const std::string text = ricci_test::read_bytes(tmp / "o" / "mesh.obj");
  std::vector<int> group_of_face;
  {
    std::istringstream lines(text);
    std::string line;
    int group = -1;
    while (std::getline(lines, line)) {
      if (line.rfind("g chart_", 0) == 0) group = std::stoi(line.substr(8));
      if (line.rfind("f ", 0) == 0) group_of_face.push_back(group);
    }
  }
  const ricci::ReadResult mesh = ricci::read_mesh((tmp / "o" / "mesh.obj").string());
  const ricci::ReadResult domain = ricci::read_mesh((tmp / "o" / "domain.obj").string());
  REQUIRE(mesh.status == ricci::Status::Ok);
  REQUIRE(domain.status == ricci::Status::Ok);
  const std::size_t nf = mesh.mesh.faces.size() / 3;
  REQUIRE(group_of_face.size() == nf);
  REQUIRE(atlas["face_chart"].size() == nf);
  REQUIRE(domain.mesh.faces.size() == 3 * nf);
  std::vector<int> faces_per_chart(static_cast<std::size_t>(charts), 0);
  double carried = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const int k = atlas["face_chart"][f].get<int>();
    REQUIRE(k >= 0);
    REQUIRE(k < charts);
    CHECK(group_of_face[f] == k);
    ++faces_per_chart[static_cast<std::size_t>(k)];
    const Json& m = atlas["charts"][k]["to_root"];
    const ricci::Moebius to_root{{m["a"][0].get<double>(), m["a"][1].get<double>()},
                                 {m["b"][0].get<double>(), m["b"][1].get<double>()}};
    for (int c = 0; c < 3; ++c) {
      const ricci::Index t = mesh.mesh.corner_texcoords[3 * f + c], d = domain.mesh.faces[3 * f + c];
      const std::complex<double> vt{mesh.mesh.texcoords[2 * t], mesh.mesh.texcoords[2 * t + 1]};
      const std::complex<double> root{domain.mesh.positions[3 * d], domain.mesh.positions[3 * d + 1]};
      carried = std::max(carried, ricci::hyperbolic_distance(to_root.apply(vt), root));
    }
  }
  CHECK(carried <= 1e-9);
  for (int k = 0; k < charts; ++k) CHECK(atlas["charts"][k]["faces"] == faces_per_chart[static_cast<std::size_t>(k)]);
}
