// ricci command-line driver — `batch` and `summarize`, which the Python package implements
// (lib/python/ricci/batch.py): this process becomes `PYTHON -m ricci COMMAND ARGS…`.
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "commands.h"

namespace ricci_cli {

int run_python_command(const std::string& command, const std::vector<std::string>& args) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::string python = "python3";
#ifdef RICCI_PYTHON_EXECUTABLE
  if (fs::exists(RICCI_PYTHON_EXECUTABLE, ec)) python = RICCI_PYTHON_EXECUTABLE;
#endif
  if (const char* p = std::getenv("RICCI_PYTHON"); p != nullptr && *p != '\0') python = p;
  // The package built beside this executable (the build tree's python/ricci) comes first.
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path beside = exe.parent_path() / "python";
    if (fs::exists(beside / "ricci" / "__init__.py", ec)) {
      std::string path = beside.string();
      if (const char* old = std::getenv("PYTHONPATH"); old != nullptr && *old != '\0') path += std::string(":") + old;
      ::setenv("PYTHONPATH", path.c_str(), 1);
    }
  }
  std::vector<std::string> words{python, "-m", "ricci", command};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  ::execvp(argv[0], argv.data());
  print_error("ricci " + command + " runs in Python: cannot start " + python + ": " + std::strerror(errno) +
              " (install the package with `pip install ./lib/python`, or set RICCI_PYTHON to an interpreter that has it)");
  return kExitInternal;
}

}  // namespace ricci_cli
