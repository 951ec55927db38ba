// The doctest runner. Floating-point traps are enabled (glibc) so that an invalid operation, a
// division by zero or an overflow stops the test that caused it — in the Release build too, whose
// vectorised loops compute what the debug build computes one lane at a time.
//
// A run asked for named test cases (-tc / --test-case, as CTest runs each registered case) fails
// when no test case matches: a name that the registration mangles (CMake splits names at ';')
// would otherwise run nothing and pass.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include <cfenv>
#include <cstdio>
#include <string_view>

namespace {

unsigned matched_test_cases = 0;

/// Records how many test cases passed the filters.
struct MatchCounter : doctest::IReporter {
  explicit MatchCounter(const doctest::ContextOptions&) {}
  void report_query(const doctest::QueryData&) override {}
  void test_run_start() override {}
  void test_run_end(const doctest::TestRunStats& stats) override {
    matched_test_cases = stats.numTestCasesPassingFilters;
  }
  void test_case_start(const doctest::TestCaseData&) override {}
  void test_case_reenter(const doctest::TestCaseData&) override {}
  void test_case_end(const doctest::CurrentTestCaseStats&) override {}
  void test_case_exception(const doctest::TestCaseException&) override {}
  void subcase_start(const doctest::SubcaseSignature&) override {}
  void subcase_end() override {}
  void log_assert(const doctest::AssertData&) override {}
  void log_message(const doctest::MessageData&) override {}
  void test_case_skipped(const doctest::TestCaseData&) override {}
};

REGISTER_LISTENER("match_counter", 1, MatchCounter);

bool names_test_cases(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    for (std::string_view flag : {"-tc=", "--test-case=", "--dt-test-case=", "-dt-tc="})
      if (a.substr(0, flag.size()) == flag) return true;
  }
  return false;
}

bool only_queries(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a.substr(0, 2) == "-l" || a.substr(0, 6) == "--list" || a == "-h" || a == "--help" || a == "-v" ||
        a == "--version" || a == "-?")
      return true;
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
#if defined(__GLIBC__)
  feenableexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW);
#endif
  doctest::Context context(argc, argv);
  const int rc = context.run();
  if (rc == 0 && names_test_cases(argc, argv) && !only_queries(argc, argv) && matched_test_cases == 0) {
    std::fprintf(stderr, "ricci_tests: no test case matches the requested name(s)\n");
    return 1;
  }
  return rc;
}
