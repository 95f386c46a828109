#pragma once
// Internal: discrete initialisation of the epipolar mode. A winner-take-all search along each
// pixel's epipolar line with census costs aggregated over 8 paths (semi-global matching after
// Hirschmuller, PAMI 2008) finds large displacements on small structures that coarse-to-fine misses;
// the variational solver then refines it.
#include <opencv2/core.hpp>
#include <vector>

namespace pg::flow_detail {

// Number of cost entries (pixels x candidates) a search of `radius` costs at `size`.
double line_search_cost(cv::Size size, int radius);

// s per pixel (pixels along the line, sub-pixel) within [foot - radius, foot + radius], s >= 0,
// where foot = -base . direction is the point of the line nearest the pixel. Pixels without a valid
// line get the foot (or 0).
cv::Mat1f search_along_lines(const std::vector<cv::Mat1f>& from, const std::vector<cv::Mat1f>& to,
                             const cv::Mat2f& base, const cv::Mat2f& direction, int radius);

}  // namespace pg::flow_detail
