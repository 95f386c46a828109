#pragma once
// Dot products between two sets of descriptors: the inner loop of exhaustive descriptor matching.
// The build targets baseline x86-64, so an AVX2+FMA kernel is chosen at run time where the processor
// has it; elsewhere portable code computes the same products (to float rounding).

namespace pg {

// out[i * out_stride + j] = dot(row i of a, row j of b) for i < a_rows, j < b_rows. Rows are `dims`
// contiguous floats.
void descriptor_dots(const float* a, int a_rows, const float* b, int b_rows, int dims, float* out,
                     int out_stride);

// The portable kernel alone (what processors without AVX2+FMA run; tests compare the two).
void descriptor_dots_portable(const float* a, int a_rows, const float* b, int b_rows, int dims, float* out,
                              int out_stride);

// Whether descriptor_dots runs the AVX2+FMA kernel on this processor.
bool descriptor_dots_vectorised();

}  // namespace pg
