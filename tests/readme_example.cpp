// The library example shown in README.md (a test checks that the two stay identical).
#include <cstdio>
#include <ricci/validate.h>

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  ricci::LoadOptions options;
  options.validate.keep_largest_component = true;
  const ricci::LoadResult r = ricci::load_mesh(argv[1], options);
  if (r.status != ricci::Status::Ok) {
    std::fprintf(stderr, "%s\n", r.message.c_str());
    return 1;
  }
  const ricci::Topology& t = r.validated.topology;
  std::printf("V=%d E=%d F=%d chi=%lld b=%d genus=%lld\n", t.num_vertices, t.num_edges, t.num_faces,
              static_cast<long long>(t.euler_characteristic()), t.num_boundary_loops(),
              static_cast<long long>(t.genus()));
  for (const ricci::Repair& repair : r.repairs) std::printf("repaired: %s\n", repair.message.c_str());
}
