// Flow accuracy and speed against OpenCV's dense methods, all run here in the same process.
//   bench_flow [--data DIR] [--only sintel|stereo|speed]... [--pg KEY=VALUE,...] [--no-opencv]
//              [--repeat N]
// --pg adds "pg custom": the balanced preset with these FlowOptions fields changed (tuning runs);
// --no-opencv skips the OpenCV methods; --repeat runs the speed pair N times (default 3), the
// reference and ours interleaved, and reports medians (on a loaded machine, compare the ratios).
// Sintel alley_1 clean/final: end-point error over all and non-occluded pixels. Middlebury tsukuba,
// venus, teddy and aloe as stereo (flow left -> right, truth u = -disparity): bad-pixel rates at 1 and
// 2 px and the mean disparity error over pixels with known truth; methods leaving holes report their
// density and are scored on what they estimated (pg's are dense; "dense stereo" fills the pixels
// its forward-backward check rejects, and SGBM is also shown with its holes filled the same way).
// Speed: the Strecha Herz-Jesus 0000/0001 pair at 1536x1024, wall time and the ratio to DIS +
// VariationalRefinement (medians of interleaved runs), free flow and, along the true cameras'
// epipolar lines, pg-depth's epipolar mode.
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/optflow.hpp>
#include <opencv2/video.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "pg/build_info.h"
#include "pg/eval/flo_io.h"
#include "pg/eval/flow_eval.h"
#include "pg/eval/truth_import.h"
#include "pg/flow/flow.h"
#include "pg/image/image_io.h"

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

struct Pair {
  cv::Mat from, to;  // 8-bit BGR
};

struct Method {
  std::string name;
  std::function<cv::Mat2f(const Pair&)> run;
  bool ours = false;
};

cv::Mat gray(const cv::Mat& image) {
  cv::Mat out;
  cv::cvtColor(image, out, cv::COLOR_BGR2GRAY);
  return out;
}

cv::Mat2f opencv_flow(const cv::Ptr<cv::DenseOpticalFlow>& method, const Pair& pair) {
  cv::Mat flow;
  method->calc(gray(pair.from), gray(pair.to), flow);
  return flow;
}

cv::Mat2f dis_refined(const Pair& pair) {
  const cv::Mat a = gray(pair.from), b = gray(pair.to);
  cv::Mat flow;
  cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM)->calc(a, b, flow);
  cv::VariationalRefinement::create()->calc(a, b, flow);
  return flow;
}

std::vector<Method> opencv_methods() {
  return {
      {"DIS+VariationalRefinement", dis_refined},
      {"DeepFlow", [](const Pair& p) { return opencv_flow(cv::optflow::createOptFlow_DeepFlow(), p); }},
      {"DualTVL1", [](const Pair& p) { return opencv_flow(cv::optflow::DualTVL1OpticalFlow::create(), p); }},
      {"Farneback", [](const Pair& p) { return opencv_flow(cv::FarnebackOpticalFlow::create(), p); }},
  };
}

std::vector<std::pair<std::string, pg::FlowOptions>> custom_settings;
bool run_opencv = true;
int speed_repeats = 3;

// "alpha=2,median_radius=1" applied to the balanced preset.
pg::FlowOptions parse_settings(const std::string& text) {
  pg::FlowOptions o = pg::FlowOptions::preset("balanced");
  const std::map<std::string, double*> reals = {{"alpha", &o.alpha},
                                                {"epipolar_alpha", &o.epipolar_alpha},
                                                {"epipolar_edge_weight", &o.epipolar_edge_weight},
                                                {"delta", &o.delta},
                                                {"gamma", &o.gamma},
                                                {"zeta", &o.zeta},
                                                {"epsilon", &o.epsilon},
                                                {"edge_weight", &o.edge_weight},
                                                {"clg_rho", &o.clg_rho},
                                                {"presmooth_sigma", &o.presmooth_sigma},
                                                {"pyramid_factor", &o.pyramid_factor},
                                                {"sor_omega", &o.sor_omega},
                                                {"search_range", &o.search_range},
                                                {"search_budget", &o.search_budget}};
  const std::map<std::string, int*> integers = {{"min_side", &o.min_side},
                                                {"max_levels", &o.max_levels},
                                                {"finest_level", &o.finest_level},
                                                {"warps", &o.warps},
                                                {"fixed_point_iterations", &o.fixed_point_iterations},
                                                {"sor_iterations", &o.sor_iterations},
                                                {"median_radius", &o.median_radius}};
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    const std::string item = text.substr(start, end - start);
    const std::size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const double value = std::stod(item.substr(eq + 1));
    if (key == "preset")
      throw std::runtime_error("preset: give it first as preset:NAME");
    else if (reals.count(key))
      *reals.at(key) = value;
    else if (integers.count(key))
      *integers.at(key) = static_cast<int>(value);
    else
      throw std::runtime_error("unknown flow option " + key);
    start = end + 1;
  }
  o.check();
  return o;
}

std::vector<Method> our_methods() {
  std::vector<Method> methods;
  for (const auto& [name, options] : custom_settings)
    methods.push_back(
        {"pg " + name, [o = options](const Pair& p) { return pg::compute_flow(p.from, p.to, o); }, true});
  if (!custom_settings.empty()) return methods;  // tuning: only the custom settings
  for (const char* preset : {"fast", "balanced", "accurate"})
    methods.push_back(
        {std::string("pg ") + preset,
         [preset](const Pair& p) { return pg::compute_flow(p.from, p.to, pg::FlowOptions::preset(preset)); },
         true});
  methods.push_back({"pg balanced CLG",
                     [](const Pair& p) {
                       pg::FlowOptions options;
                       options.clg_rho = 1.0;
                       return pg::compute_flow(p.from, p.to, options);
                     },
                     true});
  return methods;
}

template <class F>
double seconds(F&& f) {
  const auto start = Clock::now();
  f();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void bench_sintel(const fs::path& data) {
  std::printf("\n== MPI-Sintel alley_1, frame 2 -> 3: end-point error (all / non-occluded), time\n");
  for (const char* pass : {"clean", "final"}) {
    const fs::path dir = data / "flow/sintel" / pass / "alley_1";
    if (!fs::exists(dir)) continue;
    const Pair pair{pg::read_image(dir / "frame_0002.png"), pg::read_image(dir / "frame_0003.png")};
    const cv::Mat2f truth = pg::read_flo(dir / "gt/frame_0002.flo");
    const cv::Mat1b occlusion = pg::read_image(dir / "gt/occlusions/frame_0002.png");
    const cv::Mat1b invalid = pg::read_image(dir / "gt/invalid/frame_0002.png");
    double best_peer = INFINITY, best_ours = INFINITY;
    std::vector<Method> methods = our_methods();
    if (run_opencv)
      for (Method& m : opencv_methods()) methods.push_back(m);
    for (const Method& m : methods) {
      cv::Mat2f flow;
      const double t = seconds([&] { flow = m.run(pair); });
      const pg::FlowEvalResult r = pg::evaluate_flow(flow, truth, &occlusion, &invalid);
      std::printf("  %-6s %-28s EPE %.3f / %.3f   %.2f s\n", pass, m.name.c_str(), r.epe_all,
                  r.epe_non_occluded, t);
      (m.ours ? best_ours : best_peer) = std::min(m.ours ? best_ours : best_peer, r.epe_all);
    }
    std::printf("  %-6s best pg / best OpenCV EPE ratio: %.3f\n", pass, best_ours / best_peer);
  }
}

struct StereoCase {
  std::string name;
  fs::path left, right, truth;
  double truth_scale;  // disparity = stored value / truth_scale; 0 = unknown
};

struct StereoScore {
  double bad1 = 0, bad2 = 0, mean = 0, density = 0;
};

// Disparity -u against the truth over pixels with known truth; NaN estimates are holes.
StereoScore score_stereo(const cv::Mat2f& flow, const cv::Mat1f& truth) {
  StereoScore s;
  std::size_t known = 0, estimated = 0;
  for (int y = 0; y < truth.rows; ++y)
    for (int x = 0; x < truth.cols; ++x) {
      if (!(truth(y, x) > 0)) continue;
      ++known;
      const float u = flow(y, x)[0];
      if (!std::isfinite(u)) continue;
      ++estimated;
      const double error = std::abs(-u - truth(y, x));
      s.bad1 += error > 1, s.bad2 += error > 2, s.mean += error;
    }
  s.density = static_cast<double>(estimated) / known;
  s.bad1 *= 100.0 / estimated, s.bad2 *= 100.0 / estimated, s.mean /= estimated;
  return s;
}

cv::Mat2f sgbm(const Pair& pair, int max_disparity) {
  const int block = 5;
  const int disparities = (max_disparity / 16 + 1) * 16;
  auto matcher = cv::StereoSGBM::create(0, disparities, block, 8 * 3 * block * block, 32 * 3 * block * block,
                                        1, 63, 10, 100, 32, cv::StereoSGBM::MODE_SGBM_3WAY);
  cv::Mat disparity;
  matcher->compute(pair.from, pair.to, disparity);
  cv::Mat2f flow(disparity.size());
  for (int y = 0; y < flow.rows; ++y)
    for (int x = 0; x < flow.cols; ++x) {
      const short d = disparity.at<short>(y, x);
      flow(y, x) = d < 0 ? cv::Vec2f(NAN, NAN) : cv::Vec2f(-d / 16.f, 0.f);
    }
  return flow;
}

// Rectified pair: the epipolar line of every pixel is its row, nearer points further left in the
// right image (and further right in the left one, for the backward flow).
pg::EpipolarField rectified_field(cv::Size size, float direction = -1) {
  return {cv::Mat2f(size, cv::Vec2f(0, 0)), cv::Mat2f(size, cv::Vec2f(direction, 0))};
}

// Dense stereo: the discrete search, epipolar flow both ways, and the pixels whose flows disagree by
// more than 0.25 px filled with their row's background (the recipe of flow_test's
// MiddleburyDenseStereo).
cv::Mat2f dense_stereo(const Pair& pair, pg::FlowOptions options) {
  if (options.search_range == 0) options.search_range = 0.25;  // else as given
  const pg::EpipolarField forward = rectified_field(pair.from.size());
  const pg::BidirectionalFlow both = pg::compute_epipolar_flow_bidirectional(
      pair.from, pair.to, forward, rectified_field(pair.from.size(), 1), options);
  return pg::fill_occlusions_along_lines(both.forward,
                                         pg::occlusion_mask(both.fb_error, both.forward, 0.25, 0.0), forward);
}

void bench_stereo(const fs::path& data) {
  std::printf(
      "\n== Middlebury stereo as flow (left -> right): bad 1px %% / bad 2px %% / mean error px, density\n");
  const fs::path m = data / "stereo/middlebury";
  const std::vector<StereoCase> cases = {
      {"tsukuba", m / "tsukuba/im3.png", m / "tsukuba/im4.png", m / "tsukuba/disp3.pgm", 16},
      {"venus", m / "venus/im2.png", m / "venus/im6.png", m / "venus/disp2.pgm", 8},
      {"teddy", m / "teddy/im2.png", m / "teddy/im6.png", m / "teddy/disp2.png", 4},
      {"aloe", data / "stereo/aloe/aloeL.jpg", data / "stereo/aloe/aloeR.jpg",
       data / "stereo/aloe/aloeGT.png", 1},
  };
  for (const StereoCase& c : cases) {
    if (!fs::exists(c.truth)) continue;
    const Pair pair{pg::read_image(c.left, pg::ReadMode::unchanged), pg::read_image(c.right)};
    cv::Mat1f truth;
    pg::read_image(c.truth).convertTo(truth, CV_32F, 1.0 / c.truth_scale);
    double max_disparity = 0;
    cv::minMaxLoc(truth, nullptr, &max_disparity);
    std::vector<Method> methods = our_methods();
    for (const char* preset : {"balanced", "accurate"})
      if (custom_settings.empty())
        methods.push_back({std::string("pg epipolar ") + preset,
                           [preset](const Pair& p) {
                             return pg::compute_epipolar_flow(p.from, p.to, rectified_field(p.from.size()),
                                                              pg::FlowOptions::preset(preset))
                                 .flow;
                           },
                           true});
    if (custom_settings.empty())
      methods.push_back({"pg dense stereo balanced",
                         [](const Pair& p) { return dense_stereo(p, pg::FlowOptions::preset("balanced")); },
                         true});
    for (const auto& [name, options] : custom_settings) {
      methods.push_back(
          {"pg dense stereo " + name, [o = options](const Pair& p) { return dense_stereo(p, o); }, true});
      methods.push_back(
          {"pg epipolar " + name,
           [o = options](const Pair& p) {
             return pg::compute_epipolar_flow(p.from, p.to, rectified_field(p.from.size()), o).flow;
           },
           true});
    }
    if (run_opencv) {
      for (Method& peer : opencv_methods()) methods.push_back(peer);
      methods.push_back(
          {"StereoSGBM", [&](const Pair& p) { return sgbm(p, static_cast<int>(max_disparity) + 4); }});
      // SGBM made dense as pg's dense stereo is: its holes take their row's background.
      methods.push_back({"StereoSGBM, holes filled", [&](const Pair& p) {
                           const cv::Mat2f flow = sgbm(p, static_cast<int>(max_disparity) + 4);
                           cv::Mat1b holes(flow.size());
                           for (int y = 0; y < flow.rows; ++y)
                             for (int x = 0; x < flow.cols; ++x)
                               holes(y, x) = std::isfinite(flow(y, x)[0]) ? 0 : 255;
                           cv::Mat2f known = flow.clone();
                           known.setTo(cv::Scalar(0, 0), holes);
                           return pg::fill_occlusions_along_lines(known, holes, rectified_field(flow.size()));
                         }});
    }
    double best_peer = INFINITY, best_dense_peer = INFINITY, best_ours = INFINITY, best_epipolar = INFINITY;
    for (const Method& method : methods) {
      cv::Mat2f flow;
      const double t = seconds([&] { flow = method.run(pair); });
      const StereoScore s = score_stereo(flow, truth);
      std::printf("  %-8s %-28s %6.2f / %6.2f / %5.2f   density %5.1f%%   %.2f s\n", c.name.c_str(),
                  method.name.c_str(), s.bad1, s.bad2, s.mean, 100 * s.density, t);
      if (!method.ours) best_peer = std::min(best_peer, s.bad2);
      if (!method.ours && s.density == 1) best_dense_peer = std::min(best_dense_peer, s.bad2);
      if (method.ours) best_ours = std::min(best_ours, s.bad2);
      if (method.name.find("epipolar") != std::string::npos ||
          method.name.find("dense stereo") != std::string::npos)
        best_epipolar = std::min(best_epipolar, s.bad2);
    }
    std::printf("  %-8s bad-2px: best pg %.2f%%, best pg epipolar %.2f%%, best OpenCV %.2f%% (ratio %.3f), ",
                c.name.c_str(), best_ours, best_epipolar, best_peer, best_ours / best_peer);
    std::printf("best dense OpenCV %.2f%% (ratio %.3f)\n", best_dense_peer, best_ours / best_dense_peer);
  }
}

void bench_speed(const fs::path& data) {
  const fs::path dir = data / "multiview/strecha/Herz-Jesus-P8/images";
  if (!fs::exists(dir)) return;
  std::printf("\n== Speed: Herz-Jesus 0000 -> 0001 at 1536x1024 (threads: all)\n");
  Pair pair;
  cv::resize(pg::read_image(dir / "0000.jpg"), pair.from, {1536, 1024}, 0, 0, cv::INTER_AREA);
  cv::resize(pg::read_image(dir / "0001.jpg"), pair.to, {1536, 1024}, 0, 0, cv::INTER_AREA);
  // Process CPU time beside wall time: on a shared machine wall time depends on the load. Each
  // repetition runs the reference and then every method, so load changes hit all of them alike.
  struct Timing {
    std::vector<double> wall, cpu;
  };
  const auto timed = [](Timing& timing, const auto& f) {
    const std::clock_t start = std::clock();
    timing.wall.push_back(seconds(f));
    timing.cpu.push_back(static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC);
  };
  const auto median = [](std::vector<double> values) {
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
  };
  std::vector<Method> methods = our_methods();
  // pg-depth's own workload: the epipolar mode along the true cameras' lines (one unknown per pixel).
  const fs::path truth = dir.parent_path() / "gt_dense_cameras";
  if (fs::exists(truth) && custom_settings.empty()) {
    const pg::CameraSet cameras = pg::import_strecha_cameras(truth, dir, 0.5);
    const pg::Camera *from = cameras.find("0000"), *to = cameras.find("0001");
    for (const char* preset : {"fast", "balanced"})
      if (from && to)
        methods.push_back({std::string("pg epipolar ") + preset + " (true cameras)",
                           [preset, from = *from, to = *to](const Pair& p) {  // copies: `cameras` ends here
                             return pg::compute_epipolar_flow(p.from, p.to, pg::epipolar_field(from, to),
                                                              pg::FlowOptions::preset(preset))
                                 .flow;
                           },
                           true});
  }
  Timing reference;
  std::vector<Timing> ours(methods.size());
  for (int r = 0; r < speed_repeats; ++r) {
    timed(reference, [&] { dis_refined(pair); });
    for (std::size_t m = 0; m < methods.size(); ++m) timed(ours[m], [&] { methods[m].run(pair); });
  }
  const double reference_wall = median(reference.wall), reference_cpu = median(reference.cpu);
  std::printf("  %-28s %.2f s   cpu %.2f s   (median of %d)\n", "DIS+VariationalRefinement", reference_wall,
              reference_cpu, speed_repeats);
  for (std::size_t m = 0; m < methods.size(); ++m) {
    const double wall = median(ours[m].wall), cpu = median(ours[m].cpu);
    std::printf("  %-28s %.2f s   cpu %.2f s   ratio to DIS+VariationalRefinement %.2f (cpu %.2f)\n",
                methods[m].name.c_str(), wall, cpu, wall / reference_wall, cpu / reference_cpu);
  }
}

}  // namespace

int main(int argc, char** argv) {
  fs::path data = pg::build_info::default_data_dir;
  if (const char* env = std::getenv("PG_DATA_DIR")) data = env;
  std::set<std::string> only;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--data" && i + 1 < argc)
      data = argv[++i];
    else if (arg == "--only" && i + 1 < argc)
      only.insert(argv[++i]);
    else if (arg == "--pg" && i + 1 < argc) {
      const std::string text = argv[++i];
      custom_settings.emplace_back("custom " + std::to_string(custom_settings.size() + 1) + " [" + text + "]",
                                   parse_settings(text));
    } else if (arg == "--no-opencv")
      run_opencv = false;
    else if (arg == "--repeat" && i + 1 < argc)
      speed_repeats = std::max(1, std::atoi(argv[++i]));
    else {
      std::cerr << "usage: bench_flow [--data DIR] [--only sintel|stereo|speed]... [--pg KEY=VALUE,...] "
                   "[--no-opencv] [--repeat N]\n";
      return 2;
    }
  }
  const auto wanted = [&](const std::string& name) { return only.empty() || only.count(name) > 0; };
  if (!fs::exists(data)) {
    std::printf("real data not found at %s: nothing to benchmark\n", data.string().c_str());
    return 0;
  }
  if (wanted("sintel")) bench_sintel(data);
  if (wanted("stereo")) bench_stereo(data);
  if (wanted("speed")) bench_speed(data);
  return 0;
}
