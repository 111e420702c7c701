// A frame's average of its samples' values (vertex_fields.hpp, frame_averages): each sample of the
// frame's pairs weighted by |w_is| v_s over the frame's sum of them. FASCIA_HD: the host's
// frame_averages (the pairs in the reverse table's order) and the device's
// (kernels/device_sample_fields.hpp: a warp's lanes take the pairs in turn) run this code.
#pragma once

#include "core/config.hpp"

#include <cmath>

namespace fascia {

// The reverse table (model.hpp, ReverseTable), the pairs' weights, the samples' volumes, and which
// samples have fibres, as arrays.
struct FrameAverageView {
  const int* offsets;       // [N+1]
  const int* pairs;         // [P]
  const int* pair_samples;  // [P]
  const double* weights;    // [P] w_is
  const double* volumes;    // [S] v_s, m^3
  const int* sample_materials;         // [S]
  const unsigned char* fibred_material;  // [materials] 1 where the law has fibres
};

// Whether sample s's law has fibres.
FASCIA_HD bool fibred(const FrameAverageView& v, int s) { return v.fibred_material[v.sample_materials[s]] != 0; }

// Frame i's sums of |w_is| v_s over its pairs first, first + stride, ... (the host: all of them,
// first 0 and stride 1; a device warp: lane l's, then the lanes' sums added): of all of them, and
// of those whose samples have fibres (the fibre stretch averages these only).
FASCIA_HD void frame_average_weights(const FrameAverageView& v, int i, int first, int stride, double& weight,
                                     double& weight_fibred) {
  weight = 0, weight_fibred = 0;
  for (int k = v.offsets[i] + first; k < v.offsets[i + 1]; k += stride) {
    const int q = v.pairs[k], s = v.pair_samples[q];
    const double w = std::fabs(v.weights[q]) * v.volumes[s];
    weight += w;
    if (fibred(v, s)) weight_fibred += w;
  }
}

// Pair q's share of its frame's average, sample s, of a frame whose weight is `weight`.
FASCIA_HD double pair_share(const FrameAverageView& v, int q, int s, double weight) {
  return std::fabs(v.weights[q]) * v.volumes[s] / weight;
}

}  // namespace fascia
