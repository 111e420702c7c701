// Poisson-disk sampling of the inside of a voxelised object (Bridson, "Fast Poisson disk sampling
// in arbitrary dimensions", SIGGRAPH 2007 sketches), as the paper's §2.1 does for frames (radius
// r_f) and samples (r_s < r_f).
//
// Guarantees, for the returned points P:
//  * every point is inside: interpolated signed distance < 0;
//  * minimum distance: |p - q| >= r for all p != q in P;
//  * maximal with respect to the interior voxel centres: every voxel centre c with
//    signed distance < 0 has |c - p| < r for some p (so every inside point lies within
//    r + h sqrt(3) / 2 of P). Bridson's dart throwing alone leaves gaps; here every interior voxel
//    centre, in index order, is also tried as a seed and starts a new front when accepted, which
//    fills the gaps and reaches every connected component (thin sheets included);
//  * prescribed points (options.prescribed, e.g. frames a caller places on a clamped face) count as
//    already placed: every returned point lies at least r from them, and Bridson's front starts
//    around them, so the set is maximal and the first layer beside them regular;
//  * deterministic: the same domain, radius and seed give the same points in the same order
//    (own 64-bit generator, no std:: distributions, single-threaded).
#pragma once

#include "discretise/voxel_domain.hpp"

#include <cstdint>
#include <vector>

namespace fascia {

struct PoissonDiskOptions {
  double radius = 0;        // r, minimum distance between points, m
  std::uint64_t seed = 1;   // random stream
  int attempts = 30;        // Bridson's k: candidates tried around each active point
  std::vector<double> prescribed;  // [K][3] m, points kept r away; anywhere (on the boundary, outside)
};

// Points [M][3] (m), the prescribed ones not included.
std::vector<double> poisson_disk_sample(const VoxelDomain& domain, const PoissonDiskOptions& options);

// Small deterministic generator (splitmix64 seeding + xoshiro256**), identical on every platform.
class Random {
 public:
  explicit Random(std::uint64_t seed);
  std::uint64_t next();
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)

 private:
  std::uint64_t m_s[4];
};

}  // namespace fascia
