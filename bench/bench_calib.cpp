// pg-calib against OpenCV's cv::calibrateCamera on the same detected corners (OpenCV's sample boards,
// or any folder given): RMS per corner, focal length and time for each, and the ratios.
//   bench_calib [folder with left01.jpg ... | default $PG_DATA_DIR or ../shared/data,
//   calib/opencv-chessboard]
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "pg/build_info.h"
#include "pg/calib/calibrate.h"
#include "pg/calib/detect.h"
#include "pg/image/image_io.h"

namespace fs = std::filesystem;
using namespace pg::calib;

namespace {

double seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  const char* data = std::getenv("PG_DATA_DIR");
  const fs::path dir =
      argc > 1 ? fs::path(argv[1])
               : fs::path(data ? data : pg::build_info::default_data_dir) / "calib" / "opencv-chessboard";
  const BoardSpec board{9, 6, 0.025};
  for (const std::string side : {"left", "right"}) {
    std::vector<fs::path> files;
    if (fs::is_directory(dir))
      for (const auto& e : fs::directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        if (name.rfind(side, 0) == 0 && name.size() == side.size() + 6 && e.path().extension() == ".jpg")
          files.push_back(e.path());
      }
    std::sort(files.begin(), files.end());
    if (files.empty()) {
      std::cerr << "bench_calib: no " << side << "NN.jpg images in " << dir << "\n";
      return 1;
    }
    std::vector<ViewInput> views;
    cv::Size size;
    for (const fs::path& f : files) {
      const cv::Mat image = pg::read_image(f);
      size = image.size();
      const Detection d = detect_board(image, board);
      if (d.found) views.push_back({f.filename().string(), d.corners});
    }
    CalibrationOptions options;
    options.max_view_rms = 100;  // same views for both
    const auto t0 = std::chrono::steady_clock::now();
    const OpenCvCalibration cv_only = opencv_calibrate(views, board, size, options);
    const double cv_time = seconds(t0);
    const auto t1 = std::chrono::steady_clock::now();
    const CalibrationResult plain = calibrate(views, board, size, options);
    const double plain_time = seconds(t1);
    options.board_warp = true;
    const auto t2 = std::chrono::steady_clock::now();
    const CalibrationResult warped = calibrate(views, board, size, options);
    const double warped_time = seconds(t2);
    std::cout << side << ": " << views.size() << " views, " << views.size() * board.corner_count()
              << " corners\n"
              << "  OpenCV calibrateCamera     RMS " << cv_only.rms << " px  fx "
              << cv_only.camera.intrinsics.fx << "  " << cv_time << " s\n"
              << "  pg-calib (corner outliers) RMS " << plain.rms << " px  fx " << plain.camera.intrinsics.fx
              << "  " << plain_time << " s  (" << plain.corners_dropped << " corners dropped)\n"
              << "  pg-calib (+ board warp)    RMS " << warped.rms << " px  fx "
              << warped.camera.intrinsics.fx << "  " << warped_time << " s  (" << warped.corners_dropped
              << " corners dropped)\n"
              << "  ratio RMS pg/OpenCV " << warped.rms / cv_only.rms << ", time pg/OpenCV "
              << warped_time / cv_time << "\n";
  }
  return 0;
}
