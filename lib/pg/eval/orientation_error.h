#pragma once
// Orientation accuracy of tracked cameras independent of their centres. A similarity fitted to the
// camera centres alone passes its own error into every rotation: on nearly collinear paths (the
// Strecha arcs) a millimetre of centre error tilts the fitted rotation by a tenth of a degree about
// the path's axis. Here the estimate's world is instead rotated onto the truth's by the rotation that
// best agrees with every camera's orientation, and each camera's residual angle is what remains.
#include <vector>

#include "pg/camera/cameras_io.h"

namespace pg {

// Per camera matched by id (in truth order): the angle in degrees of R_e A R_t^T, where A is the
// chordal mean of the per-camera alignments R_e^T R_t. Empty when no id matches.
std::vector<double> orientation_aligned_rotation_errors_deg(const CameraSet& estimate,
                                                            const CameraSet& truth);

}  // namespace pg
