// ricci executables — large allocations on transparent huge pages, and a fixed mmap threshold.
//
// Takes: the program's argv, first thing in main() (prepare_malloc()). Gives: the same program,
// re-executed once with glibc's tunable glibc.malloc.hugetlb=1 added to GLIBC_TUNABLES, when that
// applies (below); else nothing happens and the program goes on as it is. Then, in the process
// that runs, malloc's mmap threshold fixed at 4 MB (fixed_mmap_threshold()).
//
// Why: the pipeline allocates and first touches hundreds of MB per million faces (factorizations,
// edge tables, the cut's copies, the output files). With 4 kB pages each first touch is a page
// fault; where faults are expensive (virtual machines) they were a quarter of a 425k-face run
// (236k faults, 3.5 s of system time in a 12 s run). With the tunable, glibc's malloc asks the
// kernel (madvise MADV_HUGEPAGE) to back its large mappings and heap growth with 2 MB pages: 18k
// faults for the same run. glibc reads GLIBC_TUNABLES only when a process starts, hence the
// re-execution; the process id, arguments and the rest of the environment are unchanged.
//
// Applies when: glibc ≥ 2.35 (the tunable's first release), not a sanitizer build (their
// allocators replace glibc's), not under valgrind (LD_PRELOAD names its preload), the kernel's
// transparent huge pages are in "madvise" mode (in "always" mode the kernel already uses them; in
// "never" it cannot), GLIBC_TUNABLES does not already set glibc.malloc.hugetlb, and the
// environment variable RICCI_HUGE_PAGES is not "0". If the re-execution fails, the program runs on.
#pragma once

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#if defined(__linux__)
#include <unistd.h>
#endif
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__) || defined(__SANITIZE_MEMORY__)
#define RICCI_SANITIZED_ALLOCATOR 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define RICCI_SANITIZED_ALLOCATOR 1
#endif
#endif

namespace ricci_cli {

/// True when this process's malloc was started with glibc.malloc.hugetlb set (by the user or by
/// prefer_huge_pages()): report.json says so.
inline bool malloc_huge_pages() {
  const char* t = std::getenv("GLIBC_TUNABLES");
  return t != nullptr && std::strstr(t, "glibc.malloc.hugetlb=1") != nullptr;
}

/// The kernel's transparent huge page mode: "always", "madvise", "never" or "" when unknown.
inline std::string transparent_huge_page_mode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  if (!std::getline(in, line)) return {};
  const std::size_t open = line.find('['), close = line.find(']');
  if (open == std::string::npos || close == std::string::npos || close < open) return {};
  return line.substr(open + 1, close - open - 1);
}

/// See the header comment. Call before any thread starts; returns only when no re-execution
/// happened.
inline void prefer_huge_pages(char** argv) {
#if defined(__linux__) && defined(__GLIBC__) && !defined(RICCI_SANITIZED_ALLOCATOR) && \
    (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 35))
  const char* off = std::getenv("RICCI_HUGE_PAGES");
  if (off != nullptr && std::strcmp(off, "0") == 0) return;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (tunables != nullptr && std::strstr(tunables, "glibc.malloc.hugetlb") != nullptr) return;
  const char* preload = std::getenv("LD_PRELOAD");
  if (preload != nullptr && std::strstr(preload, "vgpreload") != nullptr) return;
  if (transparent_huge_page_mode() != "madvise") return;
  const std::string before = tunables != nullptr ? tunables : "";
  const std::string after = before.empty() ? "glibc.malloc.hugetlb=1" : before + ":glibc.malloc.hugetlb=1";
  if (::setenv("GLIBC_TUNABLES", after.c_str(), 1) != 0) return;
  ::execv("/proc/self/exe", argv);
  // Not re-executed: run on with the environment as it was.
  if (tunables != nullptr) {
    ::setenv("GLIBC_TUNABLES", before.c_str(), 1);
  } else {
    ::unsetenv("GLIBC_TUNABLES");
  }
#else
  (void)argv;
#endif
}

/// Blocks of 4 MB and more are mapped on their own and given back when freed; smaller ones come
/// from malloc's heap. By default glibc raises that threshold, up to 32 MB, each time a mapped
/// block is freed, so that the pipeline's freed arrays of a few MB to 32 MB stay in the heap,
/// where the next stage's arrays rarely fit, and the peak grows: kitten-425k's run peaked at
/// 574-603 MB with it and 469-482 MB with the threshold fixed, in the same time (6.2-6.7 s); a
/// 1M-face torus at 1147-1173 and 1081 MB. No-op where glibc's allocator is not in use.
inline void fixed_mmap_threshold() {
#if defined(__GLIBC__) && !defined(RICCI_SANITIZED_ALLOCATOR)
  ::mallopt(M_MMAP_THRESHOLD, 4 << 20);
#endif
}

/// prefer_huge_pages(), then fixed_mmap_threshold(): the allocator the ricci executables run on.
inline void prepare_malloc(char** argv) {
  prefer_huge_pages(argv);
  fixed_mmap_threshold();
}

}  // namespace ricci_cli
