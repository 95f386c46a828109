#pragma once
// Dense optical flow: our own variational solver, the dense engine of pg-depth, pg-sphdepth and
// pg-refine.
//
// Energy (Brox, Bruhn, Papenberg & Weickert, ECCV 2004), minimised coarse to fine with warping:
//   E(w) = sum_x  delta * psi(|I2(x + w) - I1(x)|^2 / n_I)                 brightness constancy
//                + gamma * psi(|grad I2(x + w) - grad I1(x)|^2 / n_G)      gradient constancy
//                + alpha * g(x) * psi(|grad u|^2 + |grad v|^2)             smoothness
// with the Charbonnier penalty psi(s^2) = sqrt(s^2 + eps^2), summed over colour channels inside psi,
// each constancy term normalised by its local gradient energy n = |grad|^2 + zeta^2 (Zimmer et al.
// 2011, as in DeepFlow) and g(x) an optional image-edge weight exp(-edge_weight * |grad I1|).
// Each pyramid level runs `warps` outer warps; each warp linearises the data term around the current
// flow and runs `fixed_point_iterations` lagged-nonlinearity iterations (robust weights frozen), each
// solved by `sor_iterations` red-black SOR sweeps (2x2 block per pixel, parallel over rows with TBB;
// results do not depend on the thread count); a median filter of the flow follows each warp.
//
// Combined local-global (Bruhn, Weickert & Schnorr, IJCV 2005): with clg_rho > 0 the per-pixel motion
// tensors of both constancy terms are integrated with a Gaussian of that scale before the robust
// penalty (structure-tensor data term): more robust to noise, slightly blurrier at motion boundaries.
//
// Epipolar mode (Slesareva, Bruhn & Weickert, DAGM 2005): for a static scene seen by two calibrated
// cameras, the flow of pixel x is constrained to its epipolar line, w(x) = base(x) + s(x) * dir(x),
// and the single unknown s (pixels along the line; for a rectified pair, the disparity) is solved
// with the same energy (smoothness weights epipolar_alpha and epipolar_edge_weight), the smoothness
// acting on s. Optionally s starts from a discrete semi-global search along the lines (search_range)
// instead of coarse to fine. The line field comes from the two cameras (epipolar_field) or from the
// caller (spherical images, curved lines linearised per pixel). Pixels hidden in the other view can
// take their line's background afterwards (fill_occlusions_along_lines).
//
// Images: any depth (8-bit, 16-bit, float), 1, 3 or 4 channels (colour used jointly, alpha ignored).
// Intensities are scaled to [0, 1] (8-bit / 255, 16-bit / 65535, float as given; for HDR set hdr_log,
// which applies log(1 + x) / log(2) first). Both images must have the same size and channel count. Flow is in
// pixels of `from`: from(x) ~ to(x + w(x)), CV_32FC2.
#include <opencv2/core.hpp>
#include <string>

#include "pg/camera/camera.h"

namespace pg {

struct FlowOptions {
  // Energy. The data terms are normalised (scale-free in intensity), so alpha is relative to them;
  // defaults tuned on MPI-Sintel alley_1 (see bench/bench_flow.cpp).
  double alpha = 8.0;  // smoothness weight (free 2-D flow)
  // Smoothness weight of the epipolar mode: one unknown, and real static scenes (Strecha, Middlebury)
  // favour less smoothing than Sintel's rendered motion.
  double epipolar_alpha = 3.0;
  // Edge weight of the epipolar mode: one unknown along a line follows depth edges more sharply than
  // free flow does (Middlebury bad-2px of the balanced epipolar mode at 5 / 20: tsukuba 5.25 / 4.99,
  // venus 2.23 / 1.89, teddy 13.17 / 13.12, aloe 18.58 / 17.78%; Sintel's free flow prefers 5).
  double epipolar_edge_weight = 20.0;
  double delta = 0.5;            // brightness constancy weight
  double gamma = 5.0;            // gradient constancy weight
  double zeta = 0.0004;          // data-term normalisation, intensity units ([0, 1] scale); 0 = off
  double epsilon = 0.001;        // Charbonnier epsilon, data and smoothness
  double edge_weight = 5.0;      // > 0: smoothness times exp(-edge_weight * |grad I1|) ([0, 1] scale)
  double clg_rho = 0.0;          // > 0: combined local-global data term, integration sigma (pixels)
  double presmooth_sigma = 0.6;  // Gaussian pre-smoothing of both images (pixels, finest level)
  bool hdr_log = false;          // float HDR input: log(1 + x) / log(2) first

  // Pyramid.
  double pyramid_factor = 0.9;  // size ratio between levels, in [0.5, 1)
  int min_side = 16;            // coarsest level's shorter side is at least this
  int max_levels = 0;           // 0 = as many as min_side allows
  // Stop at this level and upsample the flow to full size (0 = solve at full resolution). Each level
  // skipped saves the finest, most expensive work; 1-3 levels cost little accuracy with factor 0.9.
  int finest_level = 0;

  // Solver.
  int warps = 1;                   // outer warps per level
  int fixed_point_iterations = 5;  // lagged-nonlinearity iterations per warp
  int sor_iterations = 10;         // red-black SOR sweeps per fixed-point iteration
  double sor_omega = 1.6;          // over-relaxation factor in (0, 2)
  // Median filter of the flow (or of s) after each warp, radius 0 (off), 1 (3x3) or 2 (5x5): removes
  // the outliers of the linearisation (Sun, Roth & Black, CVPR 2010, "Secrets of optical flow").
  int median_radius = 2;
  // Epipolar mode without initial_along: > 0 starts s from a discrete search along each line (census
  // costs, semi-global aggregation over 8 paths, winner take all) within +- search_range * image width
  // of the line's point nearest the pixel (s >= 0), at the finest pyramid level where the search
  // stays under search_budget cost entries; the variational solver refines from that level on. Finds
  // large displacements on small structures that coarse to fine misses. 0 = coarse to fine only.
  double search_range = 0.0;
  double search_budget = 4e7;

  // Throws UsageError naming the first invalid field.
  void check() const;

  // Named settings: "fast" (close to real time), "balanced" (the default) and "accurate".
  // Throws UsageError for an unknown name.
  static FlowOptions preset(const std::string& name);
};

// Per-pixel epipolar lines of the `from` image in the `to` image: the flow of pixel x is
// base(x) + s * direction(x), s >= 0 for points in front of both cameras (s = 0: at infinity).
struct EpipolarField {
  cv::Mat2f base;       // flow to the image of the point at infinity on x's ray
  cv::Mat2f direction;  // unit vector along the line, towards nearer points
  bool empty() const { return base.empty(); }
};

// The line field for two posed cameras of any model (lines are exact for undistorted perspective
// cameras; for distorted or equirectangular ones each curve is linearised at infinity, which holds
// for the small disparities of close views). Pixels whose ray's point at infinity does not project
// into `to` (behind it) get a NaN base; the solver treats them as having no data term.
// Throws UsageError when the cameras share their centre (no baseline).
EpipolarField epipolar_field(const Camera& from, const Camera& to);

// The same field at another image size (pyramid levels, a --scale run): base scaled with the image.
EpipolarField resize_epipolar_field(const EpipolarField& field, cv::Size size);

// Free 2-D flow from `from` to `to`. `initial` (optional, full size) seeds the coarsest level used.
// Throws UsageError for empty, mismatched or unsupported images and invalid options.
cv::Mat2f compute_flow(const cv::Mat& from, const cv::Mat& to, const FlowOptions& options = {},
                       const cv::Mat2f& initial = {});

struct EpipolarFlow {
  cv::Mat2f flow;   // base + along * direction
  cv::Mat1f along;  // s, pixels along the line
};

// Epipolar-constrained flow: `field` at the images' size (epipolar_field or resize_epipolar_field).
// `initial_along` (optional) seeds s; without it s starts where the flow along each line is smallest.
EpipolarFlow compute_epipolar_flow(const cv::Mat& from, const cv::Mat& to, const EpipolarField& field,
                                   const FlowOptions& options = {}, const cv::Mat1f& initial_along = {});

// Forward-backward consistency: error(x) = |forward(x) + backward(x + forward(x))| (backward sampled
// bilinearly), NaN where x + forward(x) falls outside the image or either flow is NaN.
cv::Mat1f forward_backward_error(const cv::Mat2f& forward, const cv::Mat2f& backward);

// Occlusion mask from the consistency error: 255 where error > max_error + relative * |forward|.
cv::Mat1b occlusion_mask(const cv::Mat1f& fb_error, const cv::Mat2f& forward, double max_error = 1.0,
                         double relative = 0.05);

// Occluded pixels (nonzero in `occluded`) on epipolar lines take the background of their line: the
// smaller s (the farther point) of the nearest unoccluded pixels found walking from them both ways
// along their line's direction in `to`, which for the near-parallel views of a stereo pair is the
// line's direction in `from` too (exactly so for a rectified pair). A pixel hidden in `to` lies behind
// the nearer surface next to it, so its own surface is the one continuing on its other side. The walk
// goes at most `max_distance` pixels (0: a quarter of the longer side, at least 64); pixels finding
// nothing, or without a valid line, keep their flow. Returns the filled flow (base + s * direction).
cv::Mat2f fill_occlusions_along_lines(const cv::Mat2f& flow, const cv::Mat1b& occluded,
                                      const EpipolarField& field, int max_distance = 0);

struct BidirectionalFlow {
  cv::Mat2f forward, backward;
  cv::Mat1f fb_error;  // forward_backward_error(forward, backward)
  cv::Mat1b occluded;  // occlusion_mask(fb_error, forward)
};

// Forward and backward flow (free 2-D), with the consistency check.
BidirectionalFlow compute_flow_bidirectional(const cv::Mat& from, const cv::Mat& to,
                                             const FlowOptions& options = {});
// Forward and backward epipolar flow between two posed cameras' images.
BidirectionalFlow compute_epipolar_flow_bidirectional(const cv::Mat& from, const cv::Mat& to,
                                                      const Camera& from_camera, const Camera& to_camera,
                                                      const FlowOptions& options = {});
// The same along given line fields: `forward` for from -> to, `backward` for to -> from. Dense stereo
// with every pixel estimated is then fill_occlusions_along_lines(result.forward, mask, forward) with
// a strict mask, occlusion_mask(result.fb_error, result.forward, 0.25, 0): on Middlebury (with
// search_range 0.25) it fills 12-28% of the pixels and beats both the default mask and no filling
// (flow_test).
BidirectionalFlow compute_epipolar_flow_bidirectional(const cv::Mat& from, const cv::Mat& to,
                                                      const EpipolarField& forward,
                                                      const EpipolarField& backward,
                                                      const FlowOptions& options = {});

}  // namespace pg
