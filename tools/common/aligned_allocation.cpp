// Every pg-* tool allocates its heap blocks of 64 bytes and more on 32-byte boundaries.
//
// Why: OpenCV routes its SVD and large products to the system LAPACK/BLAS, and on Debian that can be
// ATLAS, whose kernels take a different summation order depending on how the buffers they get are
// aligned. glibc's malloc only promises 16 bytes, so the alignment a buffer happens to get depends on
// everything allocated before it, down to the length of the command line, and pg-calib's results
// changed in the last digits when only the output path changed. Fixing the alignment makes the
// numbers a function of the inputs alone. Small blocks keep malloc's cheaper path.
#include <cstdlib>
#include <new>

namespace {

constexpr std::size_t kAlignment = 32;
constexpr std::size_t kAlignFrom = 64;

void* allocate(std::size_t size) noexcept {
  if (size < kAlignFrom) return std::malloc(size == 0 ? 1 : size);
  // aligned_alloc wants a size that is a multiple of the alignment.
  return std::aligned_alloc(kAlignment, (size + kAlignment - 1) & ~(kAlignment - 1));
}

void* allocate_or_throw(std::size_t size) {
  for (;;) {
    if (void* p = allocate(size)) return p;
    std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}

}  // namespace

void* operator new(std::size_t size) {
  return allocate_or_throw(size);
}
void* operator new[](std::size_t size) {
  return allocate_or_throw(size);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return allocate(size);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return allocate(size);
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
