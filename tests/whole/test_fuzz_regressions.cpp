// Regression tests from fuzzing (tools/fuzz): every input a libFuzzer target found crashing, or
// breaking a documented contract, is embedded here as bytes and must now give a clean status.
// Also: every committed seed of tools/fuzz/corpus is read without incident in the normal test
// builds (Release and ASan/UBSan), and the in-memory target reader used by fuzz_target agrees
// with read_target_file().
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ricci/flow.h"
#include "ricci/io.h"
#include "ricci/metric.h"
#include "ricci/validate.h"
#include "support.h"

namespace {

using ricci::FileFormat;
using ricci::Status;
namespace fs = std::filesystem;

fs::path corpus_dir() {
  return fs::path(RICCI_SOURCE_DIR) / "tools" / "fuzz" / "corpus";
}

/// The seed files of one target, sorted by name.
std::vector<fs::path> seeds(const std::string& target) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(corpus_dir() / target))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

ricci::ReadResult read_as(std::string_view bytes, FileFormat format) {
  ricci::ReadOptions options;
  options.format = format;
  return ricci::read_mesh_from_memory(bytes, "fuzz", options);
}

/// The disk of the fuzz_target harness: vertex 0 inside a hexagon 1..6.
ricci::Topology hexagon_disk() {
  ricci::Mesh m;
  m.positions = {0, 0, 0};
  const double c[6][2] = {{1, 0}, {0.5, 0.866}, {-0.5, 0.866}, {-1, 0}, {-0.5, -0.866}, {0.5, -0.866}};
  for (int i = 0; i < 6; ++i) {
    m.positions.insert(m.positions.end(), {c[i][0], c[i][1], 0});
    m.faces.insert(m.faces.end(), {0, 1 + i, 1 + (i + 1) % 6});
  }
  const ricci::ValidateResult v = ricci::validate_mesh(m);
  REQUIRE(v.status == Status::Ok);
  return v.topology;
}

}  // namespace

TEST_CASE("fuzz: every seed of the mesh corpora reads to a status with a message") {
  const std::pair<const char*, FileFormat> targets[] = {
      {"obj", FileFormat::Obj}, {"off", FileFormat::Off}, {"ply", FileFormat::PlyBinary}};
  for (const auto& [target, format] : targets) {
    const std::vector<fs::path> files = seeds(target);
    REQUIRE(!files.empty());
    for (const fs::path& p : files) {
      INFO(p.string());
      const ricci::ReadResult r = read_as(ricci_test::read_bytes(p), format);
      CHECK(r.status != Status::NotRun);
      CHECK(r.message.rfind("fuzz: ", 0) == 0);
      if (r.status == Status::Ok) {
        const ricci::LoadResult loaded = ricci::validate_read(r, "fuzz");
        CHECK(loaded.status != Status::NotRun);
      }
    }
  }
}

TEST_CASE("fuzz: parse_target_text reads what read_target_file reads") {
  const ricci::Topology t = hexagon_disk();
  ricci_test::TempDir dir;
  const std::string texts[] = {"0 0.5\n", "# c\n\n3 -0.25 # x\r\n1 +1e-3\n", "0 1\n0 2\n", "99 0\n", "0\n",
                               "0 nan\n"};
  for (const std::string& text : texts) {
    INFO(text);
    const fs::path path = dir / "target.txt";
    ricci_test::write_bytes(path, text);
    const ricci::TargetFileResult from_file =
        ricci::read_target_file(path.string(), t, ricci::BoundaryMode::Free);
    const ricci::TargetFileResult from_text =
        ricci::parse_target_text(text, t, ricci::BoundaryMode::Free, path.string());
    CHECK(from_text.status == from_file.status);
    CHECK(from_text.message == from_file.message);
    CHECK(from_text.line == from_file.line);
    CHECK(from_text.target.K == from_file.target.K);
  }
}

// fuzz_load, crash-9731483a (selector 0x15: OFF, keep_largest_component, hyperbolic). A hexagon
// disk with one vertex pulled 10⁴ units away validates fine, but in H (χ = 1, so no rescaling)
// its initial radius γ ≈ 10692 gave tanh(γ/2) = 1, u = 0, and sinh²(l/2) overflowed: 0·∞ made η
// NaN on three edges while initial_metric() reported Ok. Now surfaces with χ ≥ 0 are scaled to
// area 2π in H too, and lengths or radii beyond what double resolves are a NumericalFailure.
TEST_CASE("fuzz: initial_metric in H refuses radii too large instead of returning NaN weights") {
  constexpr std::string_view kInput =
      "OFF\n7 6 double 0\n0 0 0\n1 0 0\n500.000000000000 10680.60254037844386 0\n"
      "-0.4999999999499999 0.8660254037844387 0\n-1 1.2246467991473532e-16 0\n"
      "-0.5000000000000004 -0.8660254037844384 0\n0.5000000000000001 -0.8660254037844386 0\n"
      "3 0 1 2\n3 0 2 3\n3 0 3 4\n3 0 4 5\n3 0 5 6\n3 0 6 1\n";
  ricci::ValidateOptions validate;
  validate.keep_largest_component = true;
  const ricci::LoadResult loaded = ricci::validate_read(read_as(kInput, FileFormat::Off), "fuzz", validate);
  REQUIRE(loaded.status == Status::Ok);
  ricci::InitialMetricOptions options;
  options.geometry = ricci::Geometry::Hyperbolic;
  const ricci::InitialMetric m =
      ricci::initial_metric(loaded.validated.mesh, loaded.validated.topology, options);
  if (m.status == Status::Ok) {
    for (const double eta : m.structure.eta) CHECK(std::isfinite(eta));
    for (const double u : m.u) CHECK(u < 0);  // tanh(γ/2) < 1: a finite hyperbolic radius
  } else {
    CHECK(m.status == Status::NumericalFailure);
    CHECK(!m.message.empty());
  }
  // A length scale chosen by the caller that puts edges beyond the range is refused by name.
  options.length_scale = 1e6;
  const ricci::InitialMetric big = ricci::initial_metric(loaded.validated.mesh, loaded.validated.topology, options);
  CHECK(big.status == Status::NumericalFailure);
  CHECK(big.message.find("too long for the hyperbolic plane") != std::string::npos);
}
