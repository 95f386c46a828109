#include "pg/image/huge_page_mats.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace pg {
namespace {

cv::Mat test_image(int rows, int cols, int type) {
  cv::Mat m(rows, cols, type);
  cv::RNG rng(7);
  rng.fill(m, cv::RNG::UNIFORM, 0, 255);
  return m;
}

// Large buffers come from the huge-page allocator, small ones from OpenCV's: both must lay rows out
// densely and give the same results as the standard allocator.
TEST(HugePageMats, LargeAndSmallMatsBehaveAsWithOpenCvsAllocator) {
  const cv::Mat small_before = test_image(64, 48, CV_32FC1);
  const cv::Mat large_before = test_image(1200, 1700, CV_32FC3);  // 24 MB
  cv::Mat blurred_before;
  cv::GaussianBlur(large_before, blurred_before, cv::Size(7, 7), 1.6);

  use_huge_pages_for_large_mats();
  use_huge_pages_for_large_mats();  // a second call does nothing

  const cv::Mat small_after = test_image(64, 48, CV_32FC1);
  const cv::Mat large_after = test_image(1200, 1700, CV_32FC3);
  EXPECT_EQ(large_after.u->currAllocator, cv::Mat::getDefaultAllocator());
  EXPECT_NE(small_after.u->currAllocator, cv::Mat::getDefaultAllocator());
  ASSERT_TRUE(large_after.isContinuous());
  EXPECT_EQ(large_after.step[0], 1700u * 3 * sizeof(float));
  EXPECT_EQ(cv::norm(small_before, small_after, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(large_before, large_after, cv::NORM_INF), 0.0);

  cv::Mat blurred_after;
  cv::GaussianBlur(large_after, blurred_after, cv::Size(7, 7), 1.6);
  EXPECT_EQ(cv::norm(blurred_before, blurred_after, cv::NORM_INF), 0.0);

  const int sizes[3] = {40, 300, 200};  // 2.4 M floats in three dimensions
  cv::Mat volume(3, sizes, CV_32F, cv::Scalar(2.5f));
  EXPECT_EQ(volume.step[2], sizeof(float));
  EXPECT_EQ(volume.step[1], 200u * sizeof(float));
  EXPECT_EQ(volume.step[0], 300u * 200u * sizeof(float));
  EXPECT_EQ(cv::sum(volume)[0], 2.5 * 40 * 300 * 200);

  cv::Mat roi = large_after(cv::Rect(100, 200, 300, 400)).clone();  // a view keeps its parent's buffer
  EXPECT_EQ(cv::norm(roi, large_before(cv::Rect(100, 200, 300, 400)), cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace pg
