// TSDF integration into dense 8^3 blocks (see tsdf_blocks.h), one work-item per voxel. Geometry in
// PG_REAL (double where the device has fp64, as the CPU reference), accumulation in float as there.
#if PG_HAVE_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif
#pragma OPENCL FP_CONTRACT OFF
typedef PG_REAL real;

// params: rotation (row-major 3x3), translation (3), fx, fy, cx, cy, voxel size, truncation.
__kernel void integrate(__global const int* origins, __global float* distance, __global float* weight,
                        __global const float* depth, __global const float* pixel_weight,
                        __global const float* cos_angle, int has_cos_angle, int cols, int rows, int range_depth,
                        __constant real* params) {
  const int b = get_global_id(1), n = get_global_id(0);
  const real voxel = params[16], truncation = params[17];
  const real wx = (origins[3 * b] + (n >> 6)) * voxel;
  const real wy = (origins[3 * b + 1] + ((n >> 3) & 7)) * voxel;
  const real wz = (origins[3 * b + 2] + (n & 7)) * voxel;
  // The sums in the order of the CPU's Eigen product (Matrix3d * Vector3d with SSE2): rows 0 and 1
  // go as one packet, left to right; row 2 is a scalar reduction, split as a0 + (a1 + a2). Any other
  // order moves a voxel that projects exactly onto a pixel boundary to the neighbouring pixel.
  const real px3 = params[0] * wx + params[1] * wy + params[2] * wz + params[9];
  const real py3 = params[3] * wx + params[4] * wy + params[5] * wz + params[10];
  const real pz3 = params[6] * wx + (params[7] * wy + params[8] * wz) + params[11];
  if (pz3 <= 0) return;
  const real u = params[12] * px3 / pz3 + params[14], v = params[13] * py3 / pz3 + params[15];
  const int x = (int)floor(u + (real)0.5), y = (int)floor(v + (real)0.5);
  if (x < 0 || y < 0 || x >= cols || y >= rows) return;
  const int p = y * cols + x;
  if (!(pixel_weight[p] > 0)) return;
  const float d = depth[p];
  if (!isfinite(d)) return;
  const real range = sqrt(px3 * px3 + py3 * py3 + pz3 * pz3);
  const real signed_distance = range_depth ? d - range : range * (d / pz3 - (real)1);
  const real cos_value = has_cos_angle ? cos_angle[p] : (real)1;
  const real depth_behind = -fmin((real)0, signed_distance * cos_value);
  if (depth_behind >= truncation) return;
  const float w = (float)(pixel_weight[p] * ((real)1 - depth_behind / truncation));
  const float sample = (float)clamp(signed_distance, -truncation, truncation);
  const int i = b * 512 + n;
  const float w0 = weight[i];
  const float d0 = w0 > 0 ? distance[i] : 0.0f;
  const float w1 = w0 + w;
  distance[i] = (d0 * w0 + sample * w) / w1;
  weight[i] = w1;
}
