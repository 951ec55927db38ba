// ricci command-line driver: the `cut` subcommand (see commands.h and lib/cut/include/ricci/cut.h).
//
//   load → cut_surface → write CUT (the disk) and CUT.loops.obj (sides and loops) → summary
//
// Outputs (-o CUT; both written atomically, neither may be the input):
//   CUT             the disk as a mesh of its own (format from the extension): one vertex per cut
//                   vertex (a surface vertex on the cut appears once per side it lies on), the
//                   faces of the (refined) surface in order.
//   CUT.loops.obj   next to CUT (its extension replaced by .loops.obj): the vertices of the
//                   refined surface (the input's vertices first, in order, then added ones), then
//                   one polyline (`o` name, `l` indices) per side of the disk boundary, named
//                   side<k>_<label> (e.g. side2_a1^-1, side9_∂1), and one per generator, named
//                   loop_<name> (a1, b1, …; t1 … for arcs to boundary loops).
#include <CLI/CLI.hpp>
#include <charconv>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.h"
#include "ricci/cut.h"
#include "ricci/io.h"
#include "ricci/validate.h"

namespace ricci_cli {

namespace {

using Json = nlohmann::ordered_json;
using ricci::Index;
using ricci::Status;
namespace fs = std::filesystem;

/// The companion file with the sides and generators as OBJ polylines.
std::string loops_file(const ricci::CutResult& r, const std::string& source) {
  std::string s;
  s += "# ricci cut of " + source + ": sides of the disk boundary and generator loops as polylines\n";
  s += "# word: " + r.word + "\n";
  s += "# genus " + std::to_string(r.genus) + ", boundary loops " + std::to_string(r.boundary_loops) +
       ", sides " + std::to_string(r.num_sides()) + ", canonical " + (r.canonical ? "yes" : "no") + "\n";
  s += "# vertices: the refined surface (input vertices first, in input order, then " +
       std::to_string(r.num_refined_vertices()) + " added ones)\n";
  const Index nv = r.num_input_vertices + r.num_refined_vertices();
  for (Index v = 0; v < nv; ++v) {
    s += "v ";
    for (int d = 0; d < 3; ++d) {
      if (d) s += ' ';
      append_number(
          s, r.surface_positions.empty() ? 0.0 : r.surface_positions[3 * static_cast<std::size_t>(v) + d]);
    }
    s += '\n';
  }
  for (Index k = 0; k < r.num_sides(); ++k) {
    s += "o side";
    s += std::to_string(k);
    s += '_';
    s += r.side_label[k];
    s += "\nl";
    for (Index i = r.side_offsets[k]; i < r.side_offsets[k + 1]; ++i) {
      s += ' ';
      s += std::to_string(r.cut_to_surface[r.side_vertices[i]] + 1);
    }
    s += '\n';
  }
  for (Index g = 0; g < r.num_generators(); ++g) {
    s += "o loop_";
    s += r.generator_name[g];
    s += "\nl";
    for (Index i = r.generator_offsets[g]; i < r.generator_offsets[g + 1]; ++i) {
      s += ' ';
      s += std::to_string(r.generator_vertices[i] + 1);
    }
    s += '\n';
  }
  return s;
}

/// The companion file of `-o OUT`: OUT with its extension replaced by ".loops.obj".
std::string cut_loops_path(const std::string& output) {
  fs::path p(output);
  p.replace_extension(".loops.obj");
  return p.string();
}

}  // namespace

int run_cut(const CutCommandOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const bool embedded = options.mesh.empty();
  const std::string file = embedded ? std::string(embedded_default_name()) : options.mesh;
  Json j;
  j["status"] = "not_run";
  j["message"] = "not run";
  j["file"] = file;
  auto finish = [&](int code) {
    j["total_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (options.json) std::cout << j.dump(2) << '\n';
    return finish_stdout(code);
  };
  auto fail = [&](Status status, const std::string& message, int code) {
    j["status"] = std::string(ricci::status_name(status));
    j["message"] = message;
    print_error(message);
    return finish(code);
  };

  std::vector<std::string> protected_paths;
  if (!embedded) protected_paths.push_back(options.mesh);
  const std::string loops = options.output.empty() ? std::string() : cut_loops_path(options.output);
  if (!options.output.empty()) {
    if (ricci::format_from_path(options.output) == ricci::FileFormat::Auto)
      return fail(Status::InvalidArgument,
                  "-o " + options.output + ": use a mesh extension (.obj, .off or .ply) for the cut mesh",
                  kExitUsage);
    // Both files are refused up front when one of them is a directory, so that neither is written.
    for (const std::string& p : {options.output, loops}) {
      std::error_code ec;
      if (std::filesystem::is_directory(p, ec))
        return fail(Status::WriteFailed, p + ": the output path is a directory; nothing was written",
                    kExitOutputFailure);
    }
    for (const std::string& p : protected_paths)
      if (same_file(options.output, p) || same_file(loops, p))
        return fail(Status::OutputIsInput,
                    "refusing to write " + (same_file(options.output, p) ? options.output : loops) +
                        ": it is the input file " + p + "; nothing was written",
                    kExitOutputFailure);
  }

  if (embedded)
    print_note(options.quiet,
               std::string("no MESH given; using the embedded default mesh ") + embedded_default_name());
  ricci::ValidateOptions vo;
  vo.keep_largest_component = options.largest_component;
  const ricci::LoadResult loaded = load_input(embedded ? std::string() : options.mesh, vo);
  if (loaded.status != Status::Ok) return fail(loaded.status, loaded.message, exit_code(loaded.status));
  for (const ricci::Repair& rep : loaded.repairs) print_note(options.quiet, rep.message);
  j["repairs"] = repairs_json(loaded.repairs);
  const ricci::Mesh& mesh = loaded.validated.mesh;
  const ricci::Topology& topo = loaded.validated.topology;
  j["vertices"] = topo.num_vertices;
  j["faces"] = topo.num_faces;

  ricci::CutOptions co;
  co.seed = options.seed;
  if (options.base_vertex >= 0) {
    if (options.base_vertex >= topo.num_vertices)
      return fail(Status::InvalidArgument,
                  "--base-vertex " + std::to_string(options.base_vertex) + ": " + file + " has " +
                      std::to_string(topo.num_vertices) + " vertices (numbered 0-based after validation)",
                  kExitUsage);
    co.base_vertex = static_cast<Index>(options.base_vertex);
  }
  const ricci::CutResult r = ricci::cut_surface(mesh, topo, co);
  if (r.status != Status::Ok)
    return fail(r.status, file + ": " + r.message,
                r.status == Status::NumericalFailure ? kExitInternal : exit_code(r.status));

  j["status"] = "ok";
  j["message"] = r.message;
  j["genus"] = r.genus;
  j["boundary_loops"] = r.boundary_loops;
  j["sides"] = r.num_sides();
  j["canonical"] = r.canonical;
  j["reason"] = r.reason;
  j["word"] = r.word;
  j["base_vertex"] = r.base_vertex;
  Json names = Json::array();
  for (const std::string& n : r.generator_name) names.push_back(n);
  j["generators"] = std::move(names);
  j["refined_vertices"] = r.num_refined_vertices();
  j["moves"] = r.moves;
  j["cut_vertices"] = r.num_cut_vertices();
  j["cut_faces"] = static_cast<std::int64_t>(r.cut_faces.size() / 3);
  j["seconds"] = r.seconds;
  j["output"] = nullptr;
  j["loops_output"] = nullptr;
  if (!r.canonical && !r.reason.empty()) print_note(options.quiet, "not canonical: " + r.reason);

  if (!options.output.empty()) {
    ricci::WriteOptions wo;
    wo.protected_paths = protected_paths;
    std::error_code ec_ignored;
    const ricci::Mesh disk = ricci::cut_disk_mesh(r);
    const std::string loops_text = loops_file(r, file);
    ricci::WriteResult w, wl;
    {
      const InterruptsDeferred deferred;  // both files or neither, also when interrupted
      w = ricci::write_mesh(options.output, disk, wo);
      if (w.status == Status::Ok) {
        wl = ricci::write_file_atomic(loops, loops_text, protected_paths);
        if (wl.status != Status::Ok) std::filesystem::remove(options.output, ec_ignored);
      }
    }
    if (w.status != Status::Ok) return fail(w.status, w.message, exit_code(w.status));
    if (wl.status != Status::Ok)
      return fail(wl.status, wl.message + "; " + options.output + " was removed again", exit_code(wl.status));
    j["output"] = options.output;
    j["loops_output"] = loops;
    print_note(options.quiet, "wrote " + options.output + " (" + std::to_string(r.num_cut_vertices()) +
                                  " vertices, " + std::to_string(r.cut_faces.size() / 3) + " faces) and " +
                                  loops + " (" + std::to_string(r.num_sides()) + " sides, " +
                                  std::to_string(r.num_generators()) + " generators)");
  }
  if (!options.json) std::cout << r.brief_report() << "\nword: " << r.word << '\n';
  return finish(kExitOk);
}

CLI::App* add_cut_command(CLI::App& app, CutCommandOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "cut",
      "Cut the surface open into one topological disk whose boundary reads the canonical word "
      "a1 b1 a1^-1 b1^-1 ... (plus t_i d_i t_i^-1 for boundary loops): tree-cotree loops, "
      "cut-and-paste canonicalisation, exact local refinement where needed. A summary (or --json) "
      "goes to stdout; -o writes the disk and, next to it, CUT.loops.obj with the sides and loops.");
  cmd->add_option("MESH", o.mesh,
                  "Mesh file (.obj, .off, .ply). Default: the embedded genus-2 mesh (" +
                      std::string(embedded_default_name()) + ").");
  cmd->add_option("-o,--output", o.output,
                  "Write the cut mesh (the disk; .obj, .off or .ply) here and the sides and generator "
                  "loops as OBJ polylines to the same name with the extension .loops.obj. Default: "
                  "write nothing.");
  cmd->add_option("--base-vertex", o.base_vertex,
                  "Base vertex of the loops (0-based, after validation): the root of their tree; at genus "
                  ">= 1 they are based at the cut graph's branch point nearest it (base_vertex in --json). "
                  "Default: chosen by --seed.")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--seed", o.seed,
                  "Seed for the base vertex when --base-vertex is not given: 0 takes vertex 0, any "
                  "other value a vertex drawn from it. Default: 0.");
  cmd->add_flag("--json", o.json, "Print the summary as one JSON object on stdout. Default: off (text).");
  cmd->add_flag("--largest-component", o.largest_component,
                "Keep the largest connected component instead of failing on several. Default: off.");
  cmd->add_flag("-q,--quiet", o.quiet, "No notes on stderr (errors are still printed). Default: off.");
  return cmd;
}

}  // namespace ricci_cli
