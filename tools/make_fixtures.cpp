// make_fixtures OUTDIR — writes the small test meshes of fixtures/ (OBJ, deterministic: the same
// bytes on every run; tests/whole/test_fixtures.cpp checks that the committed files are reproduced).
//
//   build/tools/make_fixtures fixtures
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "shapes.h"

namespace {

struct Fixture {
  const char* file;
  ricci::Mesh mesh;
};

std::vector<Fixture> fixtures() {
  using namespace ricci_shapes;
  const ricci::Mesh sphere = icosphere(3);
  const ricci::Mesh genus2 = pretzel(2, 4);
  return {
      {"icosphere.obj", sphere},
      {"torus.obj", torus(32, 16, 1.0, 0.4)},
      {"genus2.obj", genus2},
      {"genus3.obj", pretzel(3, 4)},
      {"disk.obj", disk(12)},
      {"annulus.obj", annulus(8, 48)},
      {"sphere-3holes.obj", remove_vertex_stars(sphere, {0, 5, 9})},
      {"genus2-1hole.obj", remove_vertex_stars(genus2, {0})},
      {"genus2-finger.obj", tube_pretzel(2, 4, 20, 3)},
  };
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_fixtures OUTDIR\n");
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  for (const Fixture& f : fixtures()) {
    const std::string path = (dir / f.file).string();
    const ricci::WriteResult w = ricci::write_mesh(path, f.mesh);
    if (w.status != ricci::Status::Ok) {
      std::fprintf(stderr, "make_fixtures: %s\n", w.message.c_str());
      return 1;
    }
    std::printf("%-20s %6d vertices %6d faces  min angle %.1f deg\n", f.file, f.mesh.num_vertices(),
                f.mesh.num_faces(), ricci_shapes::min_angle_degrees(f.mesh));
  }
  return 0;
}
