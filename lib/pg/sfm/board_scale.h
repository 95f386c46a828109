#pragma once
// Metric scale for a reconstruction from a checkerboard of known square size seen in some of its
// frames. Each view's board pose (PnP on its detected corners, in metres) gives the metric distance
// from the camera to the board's centre; the same centre triangulated from the reconstruction's
// rays gives that distance in reconstruction units. The centre, unlike the corner order, does not
// depend on which way round the detector numbered the corners, so views need no agreement on it.
#include <filesystem>
#include <vector>

#include "pg/calib/board.h"
#include "pg/camera/camera.h"

namespace pg {

struct BoardScale {
  double metres_per_unit = 0;     // multiply reconstruction lengths by this
  int views = 0;                  // views whose board was found and used
  double relative_spread = 0;     // median absolute deviation of the per-view ratios over their median
  std::vector<std::string> used;  // their camera ids
};

// `cameras[i]` (posed) photographed `images[i]`. Throws FailedError when fewer than two views show the
// board or their rays to its centre are too close to parallel to triangulate it.
BoardScale scale_from_board(const std::vector<Camera>& cameras,
                            const std::vector<std::filesystem::path>& images, const calib::BoardSpec& board);

}  // namespace pg
