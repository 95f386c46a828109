#pragma once
// Large cv::Mat buffers on transparent huge pages.
//
// Why: a 3072x2048 photo's SIFT scale space (OpenCV doubles the image first) is about 1.5 GB of
// float images, allocated and freed for every frame. glibc gives such blocks fresh mappings, so
// every 4 KiB page is faulted in and zeroed one at a time: on Herz-Jesus-P8 at full resolution that
// was 27 s of kernel time in a 50 s run. With 2 MiB pages feature detection went from 25 s to 9 s.
// Results do not change (only where the memory comes from).

namespace pg {

// Makes cv::Mat allocate buffers of 4 MiB and more as their own 2 MiB-aligned mappings, advised
// for huge pages (MADV_HUGEPAGE; the kernel's transparent-huge-page mode "madvise" or "always"
// honours it, "never" leaves 4 KiB pages). Smaller buffers keep OpenCV's allocator. Once per
// process, before parallel work; later calls do nothing.
void use_huge_pages_for_large_mats();

}  // namespace pg
