// scheme_sweep — `ricci uniformize` on mesh files, scheme by scheme, as a user runs it: the default
// (vertex scaling with intrinsic Delaunay flips), vertex scaling without flips, the paper's circle
// packing and inversive distance. Runs the CLI (`ricci uniformize MESH -o TMP --no-pictures --json
// --seed-checks 0 -q [--scheme S] [--no-flips]`) and prints a Markdown table: per mesh and scheme
// the Newton iterations, the flips, the Steiner subdivision levels (where used), max |K̄ − K|,
// the mean angle distortion (mean |log θ_input / θ_output| over the input's corners) and the
// seconds of the whole run, or the status it ended with. A benchmark, not a test.
//
//   build/tools/scheme_sweep [--ricci build/ricci] [--out FILE] MESH...
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace {

using Json = nlohmann::json;

std::string shell_quoted(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs a shell command, returning its standard output.
std::string capture(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return out;
  std::array<char, 4096> buffer{};
  std::size_t n = 0;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), p)) > 0) out.append(buffer.data(), n);
  pclose(p);
  return out;
}

std::string sci(const Json& x) {
  if (!x.is_number()) return "–";
  char b[32];
  std::snprintf(b, sizeof b, "%.1e", x.get<double>());
  return b;
}

std::string fixed(const Json& x, const char* format) {
  if (!x.is_number()) return "–";
  char b[32];
  std::snprintf(b, sizeof b, format, x.get<double>());
  return b;
}

// One cell: "it., flips, max error, angle distortion, s" or the status.
std::string cell(const Json& j, double seconds) {
  if (!j.is_object()) return "no report";
  const std::string status = j.value("status", std::string("?"));
  if (status != "ok") {
    std::string stage = j.contains("failed_stage") && j["failed_stage"].is_string() ? j["failed_stage"].get<std::string>() : "";
    return status + (stage.empty() ? "" : " (" + stage + ")");
  }
  std::string s = fixed(j["iterations"], "%.0f") + " it.";
  if (j.value("flips", false) && j["intrinsic"].is_object()) {
    const Json& in = j["intrinsic"];
    const long long flips = in.value("delaunay_flips", 0LL) + in.value("flow_flips", 0LL);
    s += ", " + std::to_string(flips) + " flips";
    if (in.value("refined", false)) s += " (refined)";
  }
  if (j["steiner"].is_object() && j["steiner"].value("used", false))
    s += ", Steiner " + fixed(j["steiner"]["levels"], "%.0f") + " (" + fixed(j["steiner"]["faces"], "%.0f") + " faces)";
  if (j["fallback"].is_string()) s += ", circle packing after flips stopped";
  s += ", " + sci(j["max_curvature_error"]) + ", " + fixed(j["angle_distortion"]["mean"], "%.4f");
  char b[32];
  std::snprintf(b, sizeof b, ", %.2f s", seconds);
  return s + b;
}

}  // namespace

int main(int argc, char** argv) {
  std::string ricci = "build/ricci", out_path;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--ricci" && i + 1 < argc) ricci = argv[++i];
    else if (a == "--out" && i + 1 < argc) out_path = argv[++i];
    else meshes.push_back(a);
  }
  if (meshes.empty()) {
    std::fprintf(stderr, "usage: scheme_sweep [--ricci build/ricci] [--out FILE] MESH...\n");
    return 2;
  }
  const std::filesystem::path tmp = std::filesystem::temp_directory_path() / "ricci-scheme-sweep";
  const std::array<std::pair<const char*, const char*>, 4> schemes = {{{"default (yamabe with flips)", ""},
                                                                       {"yamabe, no flips", "--scheme yamabe --no-flips"},
                                                                       {"circle packing", "--scheme circle-packing"},
                                                                       {"inversive distance", "--scheme inversive-distance"}}};
  std::ostringstream table;
  table << "| mesh | faces | geometry |";
  for (const auto& s : schemes) table << ' ' << s.first << " |";
  table << "\n|---|---:|---|---|---|---|---|\n";
  std::cout << table.str() << std::flush;
  for (const std::string& mesh : meshes) {
    std::ostringstream row;
    std::string faces = "–", geometry = "–";
    std::vector<std::string> cells;
    for (const auto& s : schemes) {
      std::filesystem::remove_all(tmp);
      const auto t0 = std::chrono::steady_clock::now();
      const std::string text = capture(shell_quoted(ricci) + " uniformize " + shell_quoted(mesh) + " -o " + shell_quoted(tmp.string()) +
                                       " --no-pictures --json --seed-checks 0 -q " + s.second + " 2>/dev/null");
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const Json j = Json::parse(text, nullptr, false);
      if (j.is_object() && j["mesh"].is_object()) faces = std::to_string(j["mesh"].value("faces", 0));
      if (j.is_object() && j["geometry"].is_string()) geometry = j["geometry"].get<std::string>();
      cells.push_back(cell(j, seconds));
    }
    std::filesystem::remove_all(tmp);
    row << "| " << std::filesystem::path(mesh).filename().string() << " | " << faces << " | " << geometry << " |";
    for (const std::string& c : cells) row << ' ' << c << " |";
    row << '\n';
    std::cout << row.str() << std::flush;
    table << row.str();
  }
  if (!out_path.empty()) std::ofstream(out_path) << table.str();
  return 0;
}
