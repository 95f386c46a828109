// Hoppe normals and their orientation over a minimum spanning tree.
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <opencv2/flann.hpp>
#include <queue>

#include "pg/core/error.h"
#include "pg/fusion/point_surface.h"

namespace pg::fusion {
namespace {

// Exact k nearest neighbours of every point (itself first), by a kd-tree without a check limit.
std::vector<std::vector<int>> nearest_neighbours(const std::vector<Eigen::Vector3f>& points, int k) {
  const int n = int(points.size());
  k = std::min(k, n);
  cv::Mat data(n, 3, CV_32F);
  for (int i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) data.at<float>(i, a) = points[i][a];
  cv::flann::Index index(data, cv::flann::KDTreeIndexParams(1));
  cv::Mat indices, distances;
  index.knnSearch(data, indices, distances, k, cv::flann::SearchParams(-1));
  std::vector<std::vector<int>> result(n, std::vector<int>(k));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < k; ++j) result[i][j] = indices.at<int>(i, j);
  return result;
}

// A camera sees a point when the point projects into the image in front of it and is within
// `tolerance` of the nearest point in its cell of a coarse depth buffer (8 x 8 pixel cells): the
// points behind a surface are hidden. Adds cos(normal, direction to the camera) of seen points.
void add_view_votes(const Camera& camera, const std::vector<Eigen::Vector3f>& points,
                    const std::vector<Eigen::Vector3f>& normals, double tolerance,
                    std::vector<double>& votes) {
  constexpr int cell = 8;
  const int columns = (camera.width + cell - 1) / cell, rows = (camera.height + cell - 1) / cell;
  std::vector<float> nearest(std::size_t(columns) * rows, INFINITY);
  std::vector<int> cell_of(points.size(), -1);
  std::vector<float> range_of(points.size());
  const Eigen::Vector3d centre = camera.cam_from_world.centre();
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d pixel;
    const Eigen::Vector3d p = points[i].cast<double>();
    if (!camera.project_world(p, pixel) || !camera.in_image(pixel)) continue;
    const int c = std::clamp(int(std::lround(pixel.x())) / cell, 0, columns - 1);
    const int r = std::clamp(int(std::lround(pixel.y())) / cell, 0, rows - 1);
    cell_of[i] = r * columns + c;
    range_of[i] = float((p - centre).norm());
    nearest[cell_of[i]] = std::min(nearest[cell_of[i]], range_of[i]);
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (cell_of[i] < 0 || range_of[i] > nearest[cell_of[i]] + tolerance) continue;
    votes[i] += normals[i].cast<double>().dot((centre - points[i].cast<double>()).normalized());
  }
}

}  // namespace

std::vector<Eigen::Vector3f> estimate_normals(const std::vector<Eigen::Vector3f>& points, int k) {
  if (points.size() < 3) throw FailedError("normals need at least 3 points");
  const auto neighbours = nearest_neighbours(points, std::max(3, k));
  std::vector<Eigen::Vector3f> normals(points.size());
  tbb::parallel_for(std::size_t(0), points.size(), [&](std::size_t i) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int j : neighbours[i]) mean += points[j].cast<double>();
    mean /= double(neighbours[i].size());
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (int j : neighbours[i]) {
      const Eigen::Vector3d d = points[j].cast<double>() - mean;
      covariance += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
    normals[i] = solver.eigenvectors().col(0).cast<float>().normalized();  // smallest eigenvalue first
  });
  return normals;
}

void orient_normals(const std::vector<Eigen::Vector3f>& points, std::vector<Eigen::Vector3f>& normals, int k,
                    const CameraSet* cameras) {
  const int n = int(points.size());
  if (n == 0) return;
  const auto neighbours = nearest_neighbours(points, std::max(2, k));
  // Symmetric graph: i-j is an edge if either is among the other's neighbours.
  std::vector<std::vector<int>> graph(n);
  for (int i = 0; i < n; ++i)
    for (int j : neighbours[i])
      if (j != i) {
        graph[i].push_back(j);
        graph[j].push_back(i);
      }

  // How strongly each point's normal agrees with the cameras that see it (sum of cosines).
  std::vector<double> view_vote(n, 0.0);
  if (cameras) {
    double spacing = 0;
    for (int i = 0; i < n; ++i) spacing += (points[neighbours[i].back()] - points[i]).norm();
    spacing /= n;
    for (const Camera& camera : cameras->cameras)
      add_view_votes(camera, points, normals, 3 * spacing, view_vote);
  }

  // Prim's algorithm from each unvisited point; a flip is propagated along every tree edge.
  std::vector<char> visited(n, 0);
  std::vector<int> piece;
  using Edge = std::pair<float, std::pair<int, int>>;  // cost, (from, to)
  for (int seed = 0; seed < n; ++seed) {
    if (visited[seed]) continue;
    piece.clear();
    std::priority_queue<Edge, std::vector<Edge>, std::greater<>> queue;
    queue.push({0.0f, {seed, seed}});
    while (!queue.empty()) {
      const auto [cost, edge] = queue.top();
      queue.pop();
      const int to = edge.second;
      if (visited[to]) continue;
      visited[to] = 1;
      piece.push_back(to);
      if (normals[edge.first].dot(normals[to]) < 0) {
        normals[to] = -normals[to];
        view_vote[to] = -view_vote[to];
      }
      for (int next : graph[to])
        if (!visited[next]) queue.push({1.0f - std::abs(normals[to].dot(normals[next])), {to, next}});
    }
    double vote = 0;
    if (cameras) {
      for (int i : piece) vote += view_vote[i];
    } else {
      int highest = piece.front();
      for (int i : piece)
        if (points[i].z() > points[highest].z()) highest = i;
      vote = normals[highest].z();
    }
    if (vote < 0)
      for (int i : piece) normals[i] = -normals[i];
  }
}

}  // namespace pg::fusion
