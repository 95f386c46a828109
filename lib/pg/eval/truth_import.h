#pragma once
// Importers of published ground-truth cameras into a CameraSet (for evaluation and known-intrinsics
// runs). Camera ids are the image file stems, as pg-track names its frames.
#include <filesystem>
#include <functional>
#include <string>

#include "pg/camera/cameras_io.h"

namespace pg {

// Middlebury multi-view `*_par.txt`: a count, then per image `name k11..k33 r11..r33 t1 t2 t3` with
// x = K [R | t] X (world to camera). Image paths are the names, relative to the file's folder; sizes
// are read from the images beside it (640x480 when they are absent). `image_quarter_turns(name)`,
// when given: that image is stored turned so many times 90 degrees counter-clockwise (negative:
// clockwise) from the frame the file describes (turned_camera); the cameras returned describe the
// images as stored. Throws InputError(path, ...).
CameraSet import_middlebury_par(const std::filesystem::path& par_file,
                                const std::function<int(const std::string& name)>& image_quarter_turns = {});

// templeRing as stored in ../shared/data: 480x640 images of the file's 640x480 frames, templeR0001 to
// templeR0031 turned a quarter counter-clockwise (1), templeR0032 to templeR0047 clockwise (-1); 0 for
// other names. Measured: each matches the templeSparseRing image with the same rotation in the files
// turned that way to 2 grey levels (40 the other way).
int temple_ring_quarter_turns(const std::string& image_name);

// Strecha et al. `*.camera` files in `folder` (one per image, named `<image>.camera`): 3 lines K,
// 1 line radial distortion, 3 lines R (camera to world), 1 line centre C, 1 line `width height`.
// `image_scale` (e.g. 0.5) describes images resized by that factor: intrinsics and sizes follow
// (pixel-centre convention). Images are named `<image>` relative to `image_folder`.
CameraSet import_strecha_cameras(const std::filesystem::path& folder,
                                 const std::filesystem::path& image_folder = {}, double image_scale = 1.0);

}  // namespace pg
