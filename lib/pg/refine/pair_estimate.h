#pragma once
// The per-view state of a refinement and the work on one directed pair (A -> B): the synthetic B
// (A's image carried through the mesh into B), the flow to the real B and the per-vertex
// displacements it implies. Internal to refine_mesh; exposed for tests and the benchmark.
#include <Eigen/Core>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "pg/camera/camera.h"
#include "pg/gpu/rasterizer_opencl.h"
#include "pg/mesh/mesh.h"
#include "pg/refine/refine.h"
#include "pg/render/rasterizer.h"

namespace pg {

// One view at the working scale, with everything reused across iterations.
struct RefineViewState {
  Camera camera;   // scaled to the working resolution
  cv::Mat1f gray;  // the photograph, grey in [0, 1], at the working resolution
  std::shared_ptr<const RayTable> rays;
  // On the active device, the ray table kept there between iterations.
  std::unique_ptr<gpu::ViewRenderer> renderer;
  RenderBuffers buffers;  // the current mesh seen from this view (refreshed by render_view_state)
  Eigen::Matrix3d world_from_cam_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
};

RefineViewState make_view_state(const RefineView& view, double scale);
void render_view_state(const Mesh& mesh, RefineViewState& state);

// A's image projected through the mesh into B (both rendered with the current mesh).
struct SyntheticView {
  cv::Mat1f image;  // A's grey values where valid, B's own elsewhere (neutral for the flow)
  cv::Mat1b valid;  // 255 where B sees the mesh and A sees the same surface point
};
void synthesize(const Mesh& mesh, const RefineViewState& a, const RefineViewState& b,
                double relative_depth_tolerance, SyntheticView& out);

// The lines of the epipolar flow for a directed pair: for each synthetic-B pixel, the B image of A's
// ray through the surface point it shows, as base 0 (the pixel itself) and a unit direction (the
// line's tangent at the pixel, towards A). Pixels that are not co-visible borrow the nearest line's
// direction; all directions are NaN when no pixel is co-visible.
EpipolarField surface_epipolar_field(const Mesh& mesh, const RefineViewState& a, const RefineViewState& b,
                                     const SyntheticView& synthetic);

// Per-vertex point-to-plane normal equations. Each pixel says the surface must move by delta along
// its face normal n (the triangulated point lies delta in front of the current surface); with
// barycentric weight w it adds w n n^T to `normal_matrix` and w delta n to `rhs`. Pixels around a
// vertex with different normals constrain it in 3-D; on flat parts only the normal motion is known,
// so no tangential sliding is invented. Summed in a fixed pixel order: deterministic.
struct DisplacementSums {
  // Inverse variance of the prior that the mesh is right (RefineOptions::mesh_accuracy); 0 = none,
  // and the pixel weights are then relative confidences rather than inverse variances.
  double prior_precision = 0;
  std::vector<double> weight;
  std::vector<Eigen::Matrix3d> normal_matrix;
  std::vector<Eigen::Vector3d> rhs;
  void reset(std::size_t vertices);
  // The least-squares displacement of vertex v (regularised towards zero tangential motion), or with a
  // prior the posterior mean: the measurements' weighted mean shrunk towards no motion.
  Eigen::Vector3d solve(std::size_t v) const;
};

// Per pixel of B, the weight ramp min(1, d / taper_px), d the distance to the nearest pixel outside
// `valid` or outside the image (so 1 / taper_px on the image's edge); all 1 when taper_px is 0. A
// panorama has no edge: its columns wrap around and its poles are not borders.
cv::Mat1f border_taper(const cv::Mat1b& valid, double taper_px, bool panorama = false);

// Flow from the synthetic B to the real B, per-pixel triangulated displacements, accumulated into
// `sums`. Returns the number of pixels that contributed.
std::size_t estimate_displacements(const Mesh& mesh, const RefineViewState& a, const RefineViewState& b,
                                   const SyntheticView& synthetic, const RefineOptions& options,
                                   double max_displacement, DisplacementSums& sums,
                                   double* flow_seconds = nullptr);

}  // namespace pg
