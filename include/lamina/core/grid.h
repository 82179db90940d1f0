#pragma once
/// \file
/// Voxel grids in physical space. These are plain std types on purpose: the ITK translation
/// units include this header, and ITK's bundled Eigen 3.3 must never meet the system Eigen 3.4.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace lamina {

/// Where a voxel grid sits in physical space (ITK's convention, millimetres, patient LPS).
/// The centre of voxel (i, j, k) is at origin + direction * (spacing .* [i, j, k]).
struct GridFrame {
  std::array<int64_t, 3> size{0, 0, 0};             ///< voxels along i, j, k
  std::array<double, 3> spacing_mm{1.0, 1.0, 1.0};  ///< voxel size along i, j, k, mm, > 0
  std::array<double, 3> origin_mm{0.0, 0.0, 0.0};   ///< centre of voxel (0,0,0), mm
  /// Row-major 3x3; column c is the physical direction of index axis c (orthonormal).
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};

  int64_t voxel_count() const { return size[0] * size[1] * size[2]; }
  double voxel_volume_mm3() const { return spacing_mm[0] * spacing_mm[1] * spacing_mm[2]; }
  /// Linear index of voxel (i, j, k); i is fastest.
  int64_t index(int64_t i, int64_t j, int64_t k) const { return i + size[0] * (j + size[1] * k); }
  /// Physical position (mm) of a continuous index position.
  std::array<double, 3> to_physical(double i, double j, double k) const;
};

/// A segmentation as read from disk: one integer label per voxel (0 = background).
struct LabelVolume {
  GridFrame frame;
  std::vector<int32_t> labels;  ///< frame.voxel_count() values, i fastest
  std::string source;           ///< where it came from (a path, or "built-in phantom")
};

/// A binary organ mask ready for meshing (1 = inside), with what preparing it changed.
struct Mask {
  GridFrame frame;
  std::vector<uint8_t> inside;  ///< frame.voxel_count() values of 0 or 1, i fastest
};

/// A dense signed distance field: mm, negative inside, on a voxel grid.
struct DistanceField {
  GridFrame frame;
  std::vector<float> phi;  ///< frame.voxel_count() values, i fastest
};

}  // namespace lamina
