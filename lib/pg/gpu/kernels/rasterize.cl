// The per-pixel loop of pg::Renderer (pg/render/rasterizer.cpp) on the device, one work-item per pixel
// of a band of rows. Each pixel tests the faces binned into its 32x32 tile in the same order with the
// same float operations (no contraction into FMA, correctly rounded division), so the results equal
// the CPU renderer's bit for bit where the device rounds as IEEE 754 requires.
#pragma OPENCL FP_CONTRACT OFF

#define NO_TRIANGLE 0xffffffffu
#define TILE 32

// setups: 12 floats per face (edge planes 0, 1, 2 and the depth plane, xyz each); flags: bits 0-2 the
// tie bits, bits 3+ the number of pixel boxes; boxes: 2 per face as (x0, x1, y0, y1), inclusive.
// dx, dy, dz, triangle, b1, b2, depth: the band's rows only (row 0 is image row band_y0).
__kernel void rasterize(__global const float* dx, __global const float* dy, __global const float* dz,
                        int width, int band_y0, int band_rows, int tiles_x,
                        __global const uint* tile_offsets, __global const uint* tile_triangles,
                        __global const float* setups, __global const uchar* flags,
                        __global const int4* boxes, float near_range, int range_depth,
                        __global uint* triangle, __global float* b1, __global float* b2,
                        __global float* depth) {
  const int x = get_global_id(0), row = get_global_id(1);
  if (x >= width || row >= band_rows) return;
  const int y = band_y0 + row;
  const size_t i = (size_t)row * width + x;
  const float X = dx[i], Y = dy[i], Z = dz[i];
  const uint tile = (uint)(y / TILE) * (uint)tiles_x + (uint)(x / TILE);
  float best = INFINITY, w1 = 0.0f, w2 = 0.0f;
  uint id = NO_TRIANGLE;
  const uint end = tile_offsets[tile + 1];
  for (uint k = tile_offsets[tile]; k < end; ++k) {
    const uint tri = tile_triangles[k];
    const uint f = flags[tri];
    const int4 box0 = boxes[2 * tri];
    bool covered = x >= box0.x && x <= box0.y && y >= box0.z && y <= box0.w;
    if (!covered && (f >> 3) > 1) {
      const int4 box1 = boxes[2 * tri + 1];
      covered = x >= box1.x && x <= box1.y && y >= box1.z && y <= box1.w;
    }
    if (!covered) continue;
    __global const float* s = setups + 12 * (size_t)tri;
    const float e0 = X * s[0] + Y * s[1] + Z * s[2];
    const float e1 = X * s[3] + Y * s[4] + Z * s[5];
    const float e2 = X * s[6] + Y * s[7] + Z * s[8];
    const bool inside = (e0 > 0 || (e0 == 0 && (f & 1))) && (e1 > 0 || (e1 == 0 && (f & 2))) &&
                        (e2 > 0 || (e2 == 0 && (f & 4)));
    if (!inside) continue;
    const float range = 1.0f / (X * s[9] + Y * s[10] + Z * s[11]);
    if (!(range > near_range && range < best)) continue;
    const float inv_sum = 1.0f / (e0 + e1 + e2);
    best = range;
    id = tri;
    w1 = e1 * inv_sum;
    w2 = e2 * inv_sum;
  }
  triangle[i] = id;
  b1[i] = w1;
  b2[i] = w2;
  depth[i] = id == NO_TRIANGLE ? NAN : (range_depth ? best : best * Z);
}
