// The doctest runner. Floating-point traps are enabled in debug builds so that an invalid
// operation, a division by zero or an overflow stops the test that caused it.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include <cfenv>

int main(int argc, char** argv) {
#if !defined(NDEBUG) && defined(__GLIBC__)
  feenableexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW);
#endif
  doctest::Context context(argc, argv);
  return context.run();
}
