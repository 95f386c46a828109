#include "pg/image/exif.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "pg/testing/exif_writer.h"
#include "pg/testing/testing.h"

namespace pg {
namespace {

std::vector<unsigned char> jpeg_with_exif(const pg::testing::ExifFields& fields, bool big_endian) {
  std::vector<unsigned char> plain;
  cv::imencode(".jpg", cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), plain);
  return pg::testing::with_exif(plain, fields, big_endian);
}

TEST(Exif, FocalFromThePixelPitchScalesToTheImageWidth) {
  // A 6000 px wide sensor, 23.5 mm wide: 255.3 px/mm; 35 mm lens; the image was resized to 1500 px.
  pg::testing::ExifFields f;
  f.focal_mm = 35.0;
  f.plane_px_per_unit = 6000 / 2.35;  // per centimetre
  f.plane_unit = 3;
  f.pixel_width = 6000;
  f.make = "Nikon";
  const std::vector<unsigned char> jpeg = jpeg_with_exif(f, /*big_endian=*/false);
  const ExifFocal exif = parse_exif_focal(jpeg);
  EXPECT_EQ(exif.make, "Nikon");
  ASSERT_TRUE(exif.focal_mm && exif.focal_plane_px_per_mm);
  const auto focal = focal_px_from_exif(exif, 1500, 1000);
  ASSERT_TRUE(focal);
  EXPECT_NEAR(*focal, 35.0 * 6000 / 23.5 / 4, 1e-3);  // the rationals carry 3 decimals
}

TEST(Exif, FocalFromThe35mmEquivalentInBigEndianFiles) {
  pg::testing::ExifFields f;
  f.focal_35mm = 28;
  const std::vector<unsigned char> jpeg = jpeg_with_exif(f, /*big_endian=*/true);
  const auto focal = focal_px_from_exif(parse_exif_focal(jpeg), 3000, 2000);
  ASSERT_TRUE(focal);
  EXPECT_NEAR(*focal, 28 * std::hypot(3000.0, 2000.0) / std::hypot(36.0, 24.0), 1e-6);
}

TEST(Exif, AbsentOrMalformedExifGivesNothing) {
  std::vector<unsigned char> plain;
  cv::imencode(".jpg", cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), plain);
  EXPECT_FALSE(focal_px_from_exif(parse_exif_focal(plain), 8, 8));
  pg::testing::ExifFields f;
  f.focal_35mm = 28;
  std::vector<unsigned char> jpeg = jpeg_with_exif(f, false);
  // Every truncation and every corrupted byte of the EXIF block parses without a crash.
  for (std::size_t n = 0; n < 200 && n < jpeg.size(); ++n) {
    parse_exif_focal(std::span(jpeg.data(), n));
    std::vector<unsigned char> bad = jpeg;
    bad[n] ^= 0xFF;
    parse_exif_focal(bad);
  }
}

}  // namespace
}  // namespace pg
