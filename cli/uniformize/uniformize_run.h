// ricci command-line driver — `ricci uniformize` and `ricci layout` taken apart into the steps a
// driver other than the command line runs (the Python module, lib/python): the options checked,
// the input loaded (from a file, or a mesh already read into memory), the pipeline, and OUTDIR
// written. run_uniformize() (uniformize_command.cpp) is exactly these steps in order, printing as
// it goes; with `console` off nothing is printed and the run's state stays in UniformizeRun.
//
// Each step returns an exit code (commands.h) when the run ends there: `status` and `message`
// then say why. Steps after a failed one must not be called.
#pragma once

#include <chrono>
#include <functional>
#include <future>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "flow_setup.h"
#include "ricci/deck.h"
#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "uniformize_outputs.h"
#include "uniformize_pictures.h"

namespace ricci_cli {

/// One file of OUTDIR: its bytes in memory, or made piece by piece as it is written.
struct OutFile {
  std::string name;
  std::string data;
  /// When set, the file's bytes are what this hands its sink (and `data` is not used): large
  /// meshes are written without ever being one string. False: it could not make them.
  std::function<bool(const ricci::ByteSink&)> stream = {};
  /// When valid, `data` is being made on another thread (text files made beside the mesh.glb and
  /// the signature): write_run() takes it before anything reads `data`.
  std::shared_future<std::string> later = {};
};

/// What the command's options say: the library's options and the target and boundary specs.
struct UniformizeSettings {
  ricci::UniformizeOptions uo;
  TargetSpec target;
  BoundarySpec boundary;
};

/// The state of one run: what report.json says, and what the steps hand each other.
struct UniformizeRun {
  using Clock = std::chrono::steady_clock;
  Clock::time_point start = Clock::now();
  /// Off: nothing on stdout or stderr (errors stay in status/message, notes in `notes`).
  bool console = true;
  /// A mesh read elsewhere (e.g. from arrays): validated under the name `file` instead of reading
  /// options.mesh. Null: read options.mesh (or the embedded default when it is empty).
  const ricci::ReadResult* preread = nullptr;

  ricci::Status status = ricci::Status::NotRun;
  std::string message = "not run";
  std::string file;
  bool embedded = false;
  bool have_mesh = false;
  /// The validated input's counts for report.json (the topology itself stays in `input`).
  struct Counts {
    ricci::Index vertices = 0, edges = 0, faces = 0, boundary_loops = 0;
    std::int64_t euler_characteristic = 0, genus = 0;
    void take(const ricci::Topology& t) {
      vertices = t.num_vertices;
      edges = t.num_edges;
      faces = t.num_faces;
      boundary_loops = t.num_boundary_loops();
      euler_characteristic = t.euler_characteristic();
      genus = t.genus();
    }
  } counts;
  std::string scheme = "circle-packing";
  bool have_result = false;
  ricci::UniformizeResult result;
  std::vector<ricci::Repair> repairs;
  std::vector<std::string> notes;
  std::vector<std::string> outputs;
  std::string output_dir;
  double load_seconds = 0, write_seconds = 0, pictures_seconds = 0, total_seconds = 0;
  std::optional<ConformalDistortion> distortion;
  bool from_metric = false;
  ricci::Index input_flipped_faces = 0;  ///< refined: input faces that come out flipped through the subdivision
  ricci::Index refinement_faces = 0;     ///< refined: faces written to refinement.obj
  ricci::FileFormat input_format = ricci::FileFormat::Obj;  ///< format the input was read in
  ricci::Index file_vertices = 0, file_faces = 0;  ///< counts of the file as read (before validation)
  std::vector<double> sphere_positions;     ///< sphere results: the unit-sphere position per vertex
  nlohmann::ordered_json signature;         ///< signature_json() of the result (null when there is none)

  UniformizeSettings settings;  ///< from uniformize_settings()
  ricci::ValidateResult input;  ///< the validated input (uniformize_load(); ears split by the compute step)
};

/// Starts a run for `o` (file name, embedded default, scheme and layout mode from the options).
void uniformize_begin(const UniformizeCommandOptions& o, UniformizeRun& run);
/// The options checked and turned into run.settings (a usage error, exit 2, otherwise). OUTDIR is
/// not looked at (uniformize_check_outdir()).
std::optional<int> uniformize_settings(const UniformizeCommandOptions& o, UniformizeRun& run);
/// -o OUTDIR required, and refused when it cannot be (re)placed or would hold the input.
std::optional<int> uniformize_check_outdir(const UniformizeCommandOptions& o, UniformizeRun& run);
/// The input (or run.preread, or the embedded default) loaded and validated into run.input.
std::optional<int> uniformize_load(const UniformizeCommandOptions& o, const char* cmd, UniformizeRun& run);
/// The pipeline: the stored metric laid out (`layout`) or target + uniformize(), then the notes on
/// the result; fails when the result did. Progress goes to run.settings.uo's callbacks (set to
/// print on stderr unless o.quiet).
std::optional<int> uniformize_compute(const UniformizeCommandOptions& o, UniformizeRun& run);
/// The surface mesh.obj holds: the input's faces with their per-corner layout (E, H; through the
/// common subdivision when refined), or the input without texture coordinates (closed genus 0;
/// run.sphere_positions then gets the unit-sphere positions). `through` receives the input's
/// layout through the subdivision when the result is refined. Fails only for a refined result
/// whose subdivision does not match.
std::optional<int> uniformize_surface(const UniformizeCommandOptions& o, UniformizeRun& run, ricci::Mesh& surface,
                                      ricci::InputSurfaceLayout& through);
/// Every output, pictures (unless o.no_pictures) and reports included, written to o.output at
/// once; the summary (or --json) on stdout when run.console. Returns the exit code.
int uniformize_write(const UniformizeCommandOptions& o, const char* cmd, UniformizeRun& run);
/// report.json's content for the run as it stands.
nlohmann::ordered_json uniformize_report(const UniformizeRun& run);

}  // namespace ricci_cli
