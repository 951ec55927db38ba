// ricci — helpers shared by the benchmark drivers (tools/bench_flow.cpp, tools/bench_pipeline.cpp):
// the machine and compiler a table was measured with, and number formatting for its cells.
#pragma once

#include <cstdio>
#include <fstream>
#include <string>

namespace bench_common {

/// The processor's model name (Linux /proc/cpuinfo), or "unknown".
inline std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const std::size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  return "unknown";
}

/// The compiler that built the driver, with its version.
inline std::string compiler_name() {
#if defined(__clang__)
  return std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
  return std::string("g++ ") + __VERSION__;
#else
  return "unknown";
#endif
}

/// x formatted by the printf format f (one double conversion).
inline std::string fmt(const char* f, double x) {
  char buf[96];
  std::snprintf(buf, sizeof buf, f, x);
  return buf;
}

}  // namespace bench_common
