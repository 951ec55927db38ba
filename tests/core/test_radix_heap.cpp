// The radix heap pops (key, item) in the order a binary heap of the pairs gives, under the
// monotone use Dijkstra's algorithm makes of it (keys never below the last popped), ties included.
#include <doctest/doctest.h>

#include <cstdint>
#include <functional>
#include <queue>
#include <random>
#include <utility>
#include <vector>

#include "radix_heap.h"
#include "support.h"

TEST_CASE("radix heap: pops in (key, item) order like a binary heap, with ties and equal keys pushed after a pop") {
  ricci_test::for_each_seed(1, 20, [](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    // Small key steps and few items per step make many equal keys; seed 1..20 spread the scale.
    const std::uint64_t spread = std::uint64_t{1} << (seed % 3 == 0 ? 2 : seed % 3 == 1 ? 20 : 50);
    std::uniform_int_distribution<std::uint64_t> step(0, spread);
    std::uniform_int_distribution<int> item(0, 999), pushes(0, 4);
    ricci::detail::RadixHeap<int> radix;
    std::priority_queue<std::pair<std::uint64_t, int>, std::vector<std::pair<std::uint64_t, int>>, std::greater<>> binary;
    std::uint64_t last = 0;
    int popped = 0, tied = 0;
    for (int round = 0; round < 6000; ++round) {
      for (int k = pushes(rng); k > 0; --k) {
        const std::uint64_t key = last + (k == 1 ? 0 : step(rng));  // some at the last key itself
        const int x = item(rng);
        radix.push(key, x);
        binary.push({key, x});
      }
      if (binary.empty()) continue;
      REQUIRE(radix.size() == binary.size());
      const auto got = radix.pop();
      const auto want = binary.top();
      binary.pop();
      REQUIRE(got == want);
      if (got.first == last && popped > 0) ++tied;
      last = got.first;
      ++popped;
    }
    while (!binary.empty()) {
      REQUIRE(radix.pop() == binary.top());
      binary.pop();
    }
    CHECK(radix.empty());
    CHECK(popped > 3000);
    CHECK(tied > 50);
  });
}
