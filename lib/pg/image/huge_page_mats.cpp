#include "pg/image/huge_page_mats.h"

#include <sys/mman.h>

#include <cstdint>
#include <mutex>
#include <opencv2/core/mat.hpp>

namespace pg {
namespace {

constexpr std::size_t kHugePage = std::size_t{2} << 20;
constexpr std::size_t kLargeFrom = std::size_t{4} << 20;

// The next multiple of the huge-page size (a length or an address).
std::size_t round_up(std::size_t bytes) {
  return (bytes + kHugePage - 1) / kHugePage * kHugePage;
}

// A mapping of round_up(bytes) starting on a huge-page boundary, or nullptr.
void* map_aligned(std::size_t bytes) {
  const std::size_t length = round_up(bytes);
  void* raw = mmap(nullptr, length + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) return nullptr;
  const auto base = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t aligned = round_up(base);
  if (aligned > base) munmap(raw, aligned - base);
  if (const std::size_t tail = base + kHugePage - aligned; tail > 0)
    munmap(reinterpret_cast<void*>(aligned + length), tail);
  void* data = reinterpret_cast<void*>(aligned);
  madvise(data, length, MADV_HUGEPAGE);  // advice only: without it the mapping still works
  return data;
}

class HugePageMatAllocator final : public cv::MatAllocator {
 public:
  explicit HugePageMatAllocator(cv::MatAllocator* small) : small_(small) {}

  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data0, size_t* step,
                         cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    std::size_t total = CV_ELEM_SIZE(type);
    for (int i = 0; i < dims; ++i) total *= static_cast<std::size_t>(sizes[i]);
    if (data0 || total < kLargeFrom) return small_->allocate(dims, sizes, type, data0, step, flags, usage);
    void* data = map_aligned(total);
    if (!data)
      return small_->allocate(dims, sizes, type, data0, step, flags, usage);  // it reports the failure
    if (step) {  // dense rows, as OpenCV's own allocator lays them out
      std::size_t stride = CV_ELEM_SIZE(type);
      for (int i = dims - 1; i >= 0; --i) {
        step[i] = stride;
        stride *= static_cast<std::size_t>(sizes[i]);
      }
    }
    auto* u = new cv::UMatData(this);
    u->data = u->origdata = static_cast<uchar*>(data);
    u->size = total;
    return u;
  }

  bool allocate(cv::UMatData* u, cv::AccessFlag, cv::UMatUsageFlags) const override { return u != nullptr; }

  void deallocate(cv::UMatData* u) const override {
    if (!u) return;
    munmap(u->origdata, round_up(u->size));
    delete u;
  }

 private:
  cv::MatAllocator* small_;
};

}  // namespace

void use_huge_pages_for_large_mats() {
  static std::once_flag once;
  std::call_once(once, [] {
    // Never destroyed: Mats that outlive main's statics still hand their buffers back to it.
    static auto* allocator = new HugePageMatAllocator(cv::Mat::getStdAllocator());
    cv::Mat::setDefaultAllocator(allocator);
  });
}

}  // namespace pg
