#pragma once
// Mesh refinement against photographs (after Newcombe & Davison 2010, on a mesh). For each pair of
// views (A, B): A's image is projected onto the current mesh and rendered from B (a synthetic B);
// optical flow from the synthetic B to the real B says where each surface point truly appears in B;
// triangulating that corrected correspondence against A's ray gives a 3-D displacement per pixel,
// which is accumulated per vertex (barycentric coverage x confidence, tapered at the border of the
// region both views see), regularised over the mesh and applied. Pairs are used in both directions
// and their displacements averaged. Topology never changes; pinned vertices and vertices outside the
// working set keep their coordinates bit for bit. Results do not depend on the thread count.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "pg/camera/camera.h"
#include "pg/flow/flow.h"
#include "pg/mesh/mesh.h"

namespace pg {

// One photograph with its camera (the image at the camera's full size: any depth, 1-4 channels).
struct RefineView {
  Camera camera;
  cv::Mat image;
};

// Indices into the views; each pair is used in both directions (A -> B and B -> A).
struct ViewPair {
  int a = 0, b = 0;
  bool operator==(const ViewPair&) const = default;
};

enum class RefineFlow { epipolar, free };

// The flow settings of a refinement: the flow preset `preset` ("fast", "balanced", "accurate") with
// the smoothness weights refinement needs, set here rather than inherited from the flow engine's
// defaults (tuned for general motion such as MPI-Sintel's). Refinement's flow, from a synthetic view to
// its photograph, is a correction of a few pixels between two images of the same texture, smooth
// because the surface error is: a weak smoothness lets the data term find it all; the general-motion
// weight (8) leaves most of it unmeasured, and the refinement stalls at about 2/3 of the way.
// Throws UsageError for an unknown preset.
FlowOptions refine_flow_options(const std::string& preset = "fast");

struct RefineOptions {
  int iterations = 6;
  // Image resolution used for rendering and flow, relative to the cameras' size (0.5 = half).
  double scale = 0.5;
  double step = 1.0;              // fraction of the estimated displacement applied per iteration
  double smoothness = 1.0;        // weight of the displacement field's smoothness against the data
  int smoothing_iterations = 30;  // Jacobi sweeps of the smoothing (also how far it diffuses, in rings)
  bool normal_only = false;       // move vertices only along their normals
  // Stop early when the mean displacement of the moving vertices falls below this (scene units).
  double tolerance = 0;
  // Per-pixel displacements longer than this are outliers (scene units; 0 = 5% of the mesh's
  // bounding-box diagonal).
  double max_displacement = 0;
  // Weights ramp up over this many pixels from the border of the co-visible region and of B's image
  // (a panorama's image has no edge: its columns wrap).
  double border_taper_px = 6;
  int working_set_taper_rings = 3;  // motion ramps up over this many vertex rings inside the working set
  double relative_depth_tolerance = 0.01;  // visibility test in A (fraction of the depth)
  double confidence_sigma = 0.08;          // photometric residual after flow giving weight 1/2 ([0,1] units)
  double min_triangulation_angle_deg = 2;  // pixels whose rays are closer to parallel are ignored
  // epipolar: 1-D flow along the B image of A's ray through the current surface point (the true
  // point lies on that ray when the cameras are exact, which refinement assumes); s is the signed
  // correction from the current surface, so the flow starts at zero and its smoothness acts on the
  // correction. free: 2-D flow, for images the rigid two-view model does not quite explain (a
  // rolling shutter, a surface that moved between the shots). On exact cameras both reach the same
  // accuracy (the deform scene: 93% less vertex error in 4 iterations, either mode); with camera
  // errors both degrade alike (0.5 px: 81%, 1.5 px: 50%), so free buys no robustness there.
  RefineFlow flow_mode = RefineFlow::epipolar;
  // How far the input mesh is expected to be from the truth (scene units); 0 = unknown, the photos
  // decide alone. When set, each pixel's measurement counts by how precisely its pair resolves depth
  // there (flow_precision_px of flow error, triangulated) against this prior: a mesh already more
  // accurate than a pair can see (a scan-backed merge refined from a short-baseline panorama pair)
  // barely moves, while errors well above the pair's precision are corrected as before.
  double mesh_accuracy = 0;
  double flow_precision_px = 0.25;  // standard error of the flow, in working-scale pixels
  FlowOptions flow = refine_flow_options();
  // Throws UsageError naming the first invalid field.
  void check() const;
};

// Per-vertex direction of the user (formats/vertex-masks.md), each empty or one weight per vertex.
// A vertex moves by working_set * (1 - pinned) * (ring taper inside the working set) of its update:
// weight 0 in the working set or 1 in pinned keeps it bit for bit.
struct RefineMasks {
  std::vector<float> working_set;  // empty: every vertex may move
  std::vector<float> pinned;       // empty: nothing pinned
};

struct PairError {
  int a = 0, b = 0;           // A's image projected through the mesh into B, compared with B
  double ncc_error = 0;       // 1 - mean local (7x7) zero-mean NCC over the co-visible pixels
  double mean_abs_error = 0;  // mean |synthetic - real| over the co-visible pixels ([0,1] units)
  std::size_t pixels = 0;     // co-visible pixels at the working scale
};

struct IterationStats {
  int iteration = 0;
  double mean_displacement = 0;  // over moving vertices, scene units
  double max_displacement = 0;
  std::size_t moved_vertices = 0;
  std::vector<PairError> before, after;  // per directed pair
  double render_seconds = 0, flow_seconds = 0, displacement_seconds = 0;
};

struct RefineResult {
  Mesh mesh;  // same topology, "displacement" vertex property (total, scene units)
  std::vector<IterationStats> iterations;
  std::vector<ViewPair> pairs;
  // |synthetic - real| of the first pair (A -> B) before the first and after the last iteration,
  // CV_32F at the working scale, NaN where not co-visible.
  cv::Mat error_before, error_after;
};

// Refines `mesh` (untouched) against `views`. `pairs` empty: chosen by select_view_pairs.
// Throws UsageError for invalid options, pairs or mask sizes; FailedError when no pair overlaps or
// a view in use does not see the mesh. (Files are the caller's: pg-refine names them in its errors.)
RefineResult refine_mesh(const Mesh& mesh, const std::vector<RefineView>& views, std::vector<ViewPair> pairs,
                         const RefineMasks& masks = {}, const RefineOptions& options = {});

// Chooses pairs from the cameras and the mesh: each view is paired with up to `per_view` others
// sharing the most visible vertices, among those whose triangulation angle at the shared surface
// lies in [min_angle_deg, max_angle_deg]. Deterministic; pairs are unordered and unique.
std::vector<ViewPair> select_view_pairs(const Mesh& mesh, const std::vector<Camera>& cameras,
                                        int per_view = 2, double min_angle_deg = 5,
                                        double max_angle_deg = 45);

// Whether any vertex of `mesh` lies in front of `camera` and inside its image.
bool camera_sees_mesh(const Mesh& mesh, const Camera& camera);

}  // namespace pg
