#pragma once
// Importers of published ground-truth cameras into a CameraSet (for evaluation and known-intrinsics
// runs). Camera ids are the image file stems, as pg-track names its frames.
#include <filesystem>

#include "pg/camera/cameras_io.h"

namespace pg {

// Middlebury multi-view `*_par.txt`: a count, then per image `name k11..k33 r11..r33 t1 t2 t3` with
// x = K [R | t] X (world to camera). Image paths are the names, relative to the file's folder; sizes
// are read from the images beside it (640x480 when they are absent). `image_quarter_turns`: the
// images are stored turned that many times 90 degrees counter-clockwise from the frames the file
// describes (turned_camera); the cameras returned describe the images as stored. Throws
// InputError(path, ...).
CameraSet import_middlebury_par(const std::filesystem::path& par_file, int image_quarter_turns = 0);

// Strecha et al. `*.camera` files in `folder` (one per image, named `<image>.camera`): 3 lines K,
// 1 line radial distortion, 3 lines R (camera to world), 1 line centre C, 1 line `width height`.
// `image_scale` (e.g. 0.5) describes images resized by that factor: intrinsics and sizes follow
// (pixel-centre convention). Images are named `<image>` relative to `image_folder`.
CameraSet import_strecha_cameras(const std::filesystem::path& folder,
                                 const std::filesystem::path& image_folder = {}, double image_scale = 1.0);

}  // namespace pg
