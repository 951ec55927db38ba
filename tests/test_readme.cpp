// README.md promises: its library example is this repository's tests/readme_example.cpp, it
// builds and runs; its two commands are the ones the scripts and CI run; its repository map and
// header table name every stage folder and public header.
#include <doctest/doctest.h>

#include <sstream>
#include <string>

#include "support.h"

namespace {

std::string readme() { return ricci_test::read_bytes(ricci_test::fs::path(RICCI_SOURCE_DIR) / "README.md"); }

std::string trim_comment_header(const std::string& source) {
  // The file starts with one comment line that the README leaves out.
  return source.substr(source.find('\n') + 1);
}

}  // namespace

TEST_CASE("readme: the library example is the compiled tests/readme_example.cpp") {
  const std::string text = readme();
  const std::string code =
      trim_comment_header(ricci_test::read_bytes(ricci_test::fs::path(RICCI_SOURCE_DIR) / "tests/readme_example.cpp"));
  REQUIRE(!code.empty());
  CHECK(text.find("```cpp\n" + code + "```") != std::string::npos);
}

TEST_CASE("readme: the library example runs and uniformizes a torus") {
  const auto r = ricci_test::run_program(RICCI_README_EXAMPLE_PATH, {(ricci_test::fixtures_dir() / "torus.obj").string()});
  CHECK(r.exit_code == 0);
  CHECK(r.out.rfind("ok euclidean", 0) == 0);
  CHECK(r.out.find("2 deck generators") != std::string::npos);
  const auto bad = ricci_test::run_program(RICCI_README_EXAMPLE_PATH, {"/nonexistent/mesh.obj"});
  CHECK(bad.exit_code == 1);
  CHECK(bad.err.find("/nonexistent/mesh.obj") != std::string::npos);
}

TEST_CASE("readme: it opens with the two commands, and CI runs the second") {
  const std::string text = readme();
  const auto demo = text.find("bash tools/demo.sh");
  const auto check = text.find("bash tools/check.sh");
  REQUIRE(demo != std::string::npos);
  REQUIRE(check != std::string::npos);
  CHECK(demo < text.find("\n## ", text.find("\n## ") + 1));  // both in the first section
  CHECK(check < text.find("\n## ", text.find("\n## ") + 1));
  const std::string ci = ricci_test::read_bytes(ricci_test::fs::path(RICCI_SOURCE_DIR) / ".ci/run");
  CHECK(ci.find("bash tools/check.sh") != std::string::npos);
}

TEST_CASE("readme: the repository map names every stage folder and every public header with its stage") {
  const std::string text = readme();
  const ricci_test::fs::path lib = ricci_test::fs::path(RICCI_SOURCE_DIR) / "lib";
  std::istringstream stages(ricci_test::read_bytes(lib / "stages.txt"));
  int count = 0, headers = 0;
  for (std::string stage; std::getline(stages, stage);) {
    if (stage.empty() || stage[0] < 'a' || stage[0] > 'z') continue;
    ++count;
    INFO("stage " << stage);
    CHECK(text.find("| `lib/" + stage + "/` |") != std::string::npos);
    CHECK(ricci_test::fs::is_regular_file(lib / stage / "README.md"));
    for (const auto& h : ricci_test::fs::directory_iterator(lib / stage / "include" / "ricci")) {
      ++headers;
      INFO("header " << h.path().filename().string());
      CHECK(text.find("| `" + h.path().filename().string() + "` | " + stage + " |") != std::string::npos);
    }
  }
  CHECK(count >= 10);
  CHECK(headers >= 15);
}
