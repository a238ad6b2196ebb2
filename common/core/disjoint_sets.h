// Disjoint sets of the integers 0..n-1 (union-find with path halving), for grouping mesh
// vertices: connected components, welded vertices. A set's root is its least member, so
// what is built from the roots does not depend on the order of the unions.
#pragma once

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

namespace dome::core {

class DisjointSets {
 public:
  explicit DisjointSets(size_t n = 0) : parent_(n) {
    std::iota(parent_.begin(), parent_.end(), 0);
  }

  // Adds a set of its own, n, and returns n (the number of members before).
  int32_t Add() {
    parent_.push_back(int32_t(parent_.size()));
    return parent_.back();
  }

  // The root (least member) of v's set.
  int32_t Find(int32_t v) {
    while (parent_[size_t(v)] != v) v = parent_[size_t(v)] = parent_[size_t(parent_[size_t(v)])];
    return v;
  }
  // Joins the sets of a and b.
  void Union(int32_t a, int32_t b) {
    const int32_t ra = Find(a), rb = Find(b);
    if (ra != rb) parent_[size_t(std::max(ra, rb))] = std::min(ra, rb);
  }

 private:
  std::vector<int32_t> parent_;
};

}  // namespace dome::core
