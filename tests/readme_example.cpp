// The README's library example (tests/test_readme.cpp checks that the README shows this file).
#include <cstdio>
#include <ricci/uniformize.h>
#include <ricci/validate.h>

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  const ricci::LoadResult in = ricci::load_mesh(argv[1]);  // read + validate (+ repairs)
  if (in.status != ricci::Status::Ok) {
    std::fprintf(stderr, "%s\n", in.message.c_str());
    return 1;
  }
  // Flow to the uniformization metric, cut, lay out, fit the deck transformations.
  const ricci::UniformizeResult r = ricci::uniformize(in.validated.mesh, in.validated.topology);
  std::printf("%s\n", r.brief_report().c_str());
  if (r.status != ricci::Status::Ok) return 1;
  // Per-corner texture coordinates from the layout (plane or Poincare disk), seams on the cut.
  const ricci::Mesh textured = ricci::surface_with_cut_uvs(r.cut, r.layout.positions);
  std::printf("%d textured faces, %zu deck generators\n", textured.num_faces(), r.deck.generators.size());
}
