#pragma once
// Gaussian smoothing of a float grid (internal to src/geometry: the Couinaud atlas's votes and the
// outline registration's displacements).
#include <array>
#include <cstdint>
#include <vector>

namespace lamina::geometry::detail {

/// The normalised Gaussian of `sigma` (in voxels) to 4 sigma each side (as scipy.ndimage's
/// gaussian_filter, which the atlas's validation used).
std::vector<float> gaussian_kernel(double sigma);

/// `values` (size[0] x size[1] x size[2], i fastest) convolved with `kernel` along each axis in
/// turn, mirrored at the edges (d c b a | a b c d). `scratch`: reused between calls.
void smooth_grid(std::vector<float>& values, const std::array<int64_t, 3>& size,
                 const std::vector<float>& kernel, std::vector<float>& scratch);

}  // namespace lamina::geometry::detail
