// ricci — command-line tool. Everything but the last-resort error handler is in commands.cpp.
#include <exception>
#include <iostream>

#include "commands.h"
#include "huge_pages.h"

int main(int argc, char** argv) {
  ricci_cli::prepare_malloc(argv);
  try {
    return ricci_cli::run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "ricci: internal error: " << e.what() << '\n';
  } catch (...) {
    std::cerr << "ricci: internal error: unknown exception\n";
  }
  return ricci_cli::kExitInternal;
}
