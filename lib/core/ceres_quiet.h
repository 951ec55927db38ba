// One Ceres solve that leaves the caller's process as it was (internal).
//
// Takes: Ceres options, a problem and a summary to fill. Gives: the solve, with the floating-point
// environment held (Ceres may evaluate trial points that raise flags; the caller's trap settings
// stay out of it and are restored) and Ceres' own logging silenced: logging_type = SILENT stops its
// progress lines, but a minimizer that stops on consecutive invalid steps still logs an ERROR line
// through glog, and the library prints nothing. glog's threshold is process-wide, so it is raised
// while any solve runs (counted across threads) and put back when the last one ends.
#pragma once

#include <ceres/ceres.h>

#include <cfenv>
#include <mutex>

namespace ricci::detail {

inline void quiet_solve(const ceres::Solver::Options& options, ceres::Problem* problem,
                        ceres::Solver::Summary* summary) {
  static std::mutex mutex;
  static int running = 0;
  static int saved_level = 0;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (running++ == 0) {
      saved_level = FLAGS_minloglevel;
      FLAGS_minloglevel = google::GLOG_FATAL;
    }
  }
  std::fenv_t env;
  std::feholdexcept(&env);
  ceres::Solve(options, problem, summary);
  std::fesetenv(&env);
  const std::lock_guard<std::mutex> lock(mutex);
  if (--running == 0) FLAGS_minloglevel = saved_level;
}

}  // namespace ricci::detail
