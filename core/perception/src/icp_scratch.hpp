#pragma once
// The alignment's per-thread scratch buffers.
// Included only by registration_icp.cpp, the one translation unit of the alignment: its
// types stay in that unit's anonymous namespace, so the hot loop inlines (and the compiler
// sees every call of each helper) exactly as when it was one file.
#include <cstddef>
#include <memory>
#include <type_traits>
#include <vector>

namespace projtour::perception {
namespace {

// Buffers an alignment fills anew and throws away: kept per thread from one alignment to the
// next, so the tracking loop allocates (and the kernel maps fresh pages) only on its first frames.
// Every element is written before it is read, so nothing carries over between alignments.
class Scratch {
 public:
  template <typename T>
  T* take(std::size_t n) {
    static_assert(std::is_trivially_copyable_v<T>);
    const std::size_t bytes = (n * sizeof(T) + 63) & ~std::size_t{63};
    if (used_ == blocks_.size()) blocks_.emplace_back();
    Block& block = blocks_[used_++];
    if (block.bytes < bytes) {
      // Grown with room to spare: the same call takes somewhat more on another frame.
      block.bytes = bytes + bytes / 2;
      block.data.reset(new std::max_align_t[block.bytes / sizeof(std::max_align_t) + 1]);
    }
    return reinterpret_cast<T*>(block.data.get());
  }

  // One per alignment on the thread's stack of them (an alignment inside a visit callback gets
  // its own).
  class Lease {
   public:
    Lease() {
      if (pool().empty()) pool().push_back(std::make_unique<Scratch>());
      scratch_ = std::move(pool().back());
      pool().pop_back();
      scratch_->used_ = 0;
    }
    ~Lease() { pool().push_back(std::move(scratch_)); }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    Scratch& operator*() { return *scratch_; }

   private:
    std::unique_ptr<Scratch> scratch_;
  };

 private:
  static std::vector<std::unique_ptr<Scratch>>& pool() {
    thread_local std::vector<std::unique_ptr<Scratch>> scratches;
    return scratches;
  }
  struct Block {
    std::unique_ptr<std::max_align_t[]> data;
    std::size_t bytes = 0;
  };
  std::vector<Block> blocks_;
  std::size_t used_ = 0;
};

}  // namespace
}  // namespace projtour::perception
