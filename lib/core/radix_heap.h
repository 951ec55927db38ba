// ricci — a monotone priority queue on integer keys (radix heap) for Dijkstra's algorithm.
//
// Takes: (key, item) pairs with 64-bit unsigned keys, never below the key last popped (what
// Dijkstra's algorithm with non-negative integer weights pushes). Gives: them back in the order of
// (key, item), smallest first — the order a binary heap of such pairs gives, so a search that breaks
// its ties by item index behaves the same — in amortized O(log of the key range) per item instead
// of O(log n) with a cache-missing sift per push and pop.
//
// Bucket 0 holds the items whose key is the last popped one; bucket b ≥ 1 those whose highest bit
// differing from it is bit b − 1. Popping from an empty bucket 0 takes the lowest non-empty bucket,
// makes its smallest key the last popped one and spreads its items over the lower buckets; bucket 0
// then holds the items of that key, sorted so that the smallest item comes out first.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <utility>
#include <vector>

namespace ricci::detail {

template <class Item>
class RadixHeap {
 public:
  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }

  /// Precondition: key ≥ the key last popped.
  void push(std::uint64_t key, Item item) {
    const int b = bucket(key);
    if (b == 0) {
      // Bucket 0 is kept sorted by item, largest first (pop takes the back).
      auto& z = buckets_[0];
      const auto at = std::lower_bound(z.begin(), z.end(), item,
                                       [](const Entry& e, const Item& x) { return e.second > x; });
      z.insert(at, {key, item});
    } else {
      buckets_[static_cast<std::size_t>(b)].push_back({key, item});
    }
    ++size_;
  }

  /// The smallest (key, item); precondition: not empty.
  std::pair<std::uint64_t, Item> pop() {
    auto& z = buckets_[0];
    if (z.empty()) refill();
    const Entry e = z.back();
    z.pop_back();
    --size_;
    return e;
  }

 private:
  using Entry = std::pair<std::uint64_t, Item>;

  int bucket(std::uint64_t key) const { return key == last_ ? 0 : 64 - std::countl_zero(key ^ last_); }

  void refill() {
    std::size_t b = 1;
    while (buckets_[b].empty()) ++b;
    std::vector<Entry>& from = buckets_[b];
    std::uint64_t least = from.front().first;
    for (const Entry& e : from) least = std::min(least, e.first);
    last_ = least;
    std::vector<Entry>& z = buckets_[0];
    for (const Entry& e : from) buckets_[static_cast<std::size_t>(bucket(e.first))].push_back(e);
    from.clear();
    std::sort(z.begin(), z.end(), [](const Entry& a, const Entry& c) { return a.second > c.second; });
  }

  std::array<std::vector<Entry>, 65> buckets_;
  std::uint64_t last_ = 0;
  std::size_t size_ = 0;
};

}  // namespace ricci::detail
