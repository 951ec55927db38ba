// fixtures/: the generator reproduces the committed files, the loader reports the numbers of
// fixtures/README.md, and every malformed file in fixtures/bad/ gives its documented status.
#include <doctest/doctest.h>

#include <fstream>
#include <map>
#include <sstream>

#include "ricci/validate.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;
namespace fs = std::filesystem;

namespace {

// Rows of a Markdown table whose first cell is a `file` name: name → the remaining cells.
std::map<std::string, std::vector<std::string>> markdown_table(const fs::path& path) {
  std::map<std::string, std::vector<std::string>> rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("| `", 0) != 0) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(1));
    std::string cell;
    while (std::getline(ss, cell, '|')) {
      const auto b = cell.find_first_not_of(' '), e = cell.find_last_not_of(' ');
      cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
    }
    const std::string name = cells[0].substr(1, cells[0].size() - 2);
    cells.erase(cells.begin());
    rows[name] = cells;
  }
  return rows;
}

}  // namespace

TEST_CASE("fixtures: the generator reproduces the committed files byte for byte") {
  ricci_test::TempDir tmp;
  const auto r = ricci_test::run_program(RICCI_MAKE_FIXTURES_PATH, {tmp.path().string()});
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  const auto made = ricci_test::mesh_files(tmp.path());
  CHECK(made.size() == 8);
  for (const auto& file : made) {
    INFO(file.filename().string());
    CHECK(ricci_test::read_bytes(file) == ricci_test::read_bytes(ricci_test::fixtures_dir() / file.filename()));
  }
}

TEST_CASE("fixtures: the README table matches the loader") {
  const auto table = markdown_table(ricci_test::fixtures_dir() / "README.md");
  int checked = 0;
  for (const auto& [name, cells] : table) {
    REQUIRE(cells.size() == 7);
    INFO(name);
    const LoadResult r = load_mesh((ricci_test::fixtures_dir() / name).string());
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.repairs.empty());
    const Topology& t = r.validated.topology;
    CHECK(std::to_string(t.num_vertices) == cells[0]);
    CHECK(std::to_string(t.num_edges) == cells[1]);
    CHECK(std::to_string(t.num_faces) == cells[2]);
    CHECK(std::to_string(t.num_boundary_loops()) == cells[3]);
    CHECK(std::to_string(t.euler_characteristic()) == cells[4]);
    CHECK(std::to_string(t.genus()) == cells[5]);
    CHECK(std::to_string(t.num_components) == cells[6]);
    CHECK(t.euler_characteristic() == 2 - 2 * t.genus() - t.num_boundary_loops());
    CHECK(ricci_test::check_topology(t, r.validated.mesh.faces) == "");
    ++checked;
  }
  CHECK(checked == 8);
}

TEST_CASE("fixtures: every bad file gives its documented status") {
  const fs::path dir = ricci_test::fixtures_dir() / "bad";
  const auto table = markdown_table(dir / "README.md");
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.path().filename() != "README.md";
  CHECK(files == table.size());  // every file is documented
  for (const auto& [name, cells] : table) {
    INFO(name);
    REQUIRE(fs::exists(dir / name));
    const LoadResult r = load_mesh((dir / name).string());
    CHECK(status_name(r.status) == cells[0]);
    if (r.status != Status::Ok) CHECK(r.message.find(name) != std::string::npos);
  }
}

TEST_CASE("fixtures: closed generated shapes face outward and every shape is well shaped") {
  using namespace ricci_shapes;
  for (const Mesh& m : {icosphere(2), torus(16, 8, 1.0, 0.4), pretzel(2, 3), pretzel(3, 2)}) {
    CHECK(signed_volume(m) > 0);
    CHECK(min_angle_degrees(m) > 20);
  }
  for (const Mesh& m : {disk(6), annulus(4, 24), remove_vertex_stars(icosphere(2), {0, 5, 9})}) {
    const auto r = validate_mesh(m);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.repairs.empty());  // consistently oriented as generated
    CHECK(min_angle_degrees(m) > 20);
  }
}
