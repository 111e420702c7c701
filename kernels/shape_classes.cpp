#include "shape_classes.hpp"

#include "core/small_math.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace fascia::gpu {

namespace {

struct ClassInfo {
  int first = 0;    // first reference pair in class_pairs
  int count = 0;    // pairs per sample
  Mat3 gram_inverse;  // (sum_a r_a r_a^T)^-1, m^2
};

// Sum over a sample's pairs of u_a v_a^T.
Mat3 sum_outer(const double* u, const double* v, int count) {
  Mat3 sum = zero3();
  for (int a = 0; a < count; ++a) sum += outer(load3(u + 3 * a), load3(v + 3 * a));
  return sum;
}

}  // namespace

std::optional<ShapeClasses> find_shape_classes(const NeighbourTable& nb, int max_classes, double rel_tol) {
  const int S = static_cast<int>(nb.offsets.size()) - 1;
  ShapeClasses out;
  out.sample_class.resize(static_cast<size_t>(std::max(S, 0)));
  out.sample_maps.resize(9 * static_cast<size_t>(std::max(S, 0)));
  out.class_offsets = {0};
  std::vector<ClassInfo> classes;
  // Classes by pair count and weights quantised to rel_tol / 2: samples with the same key have
  // weights within rel_tol of each other (equal weights that straddle a step give two classes).
  std::map<std::vector<long long>, int> index;
  const double quantum = 0.5 * rel_tol;
  std::vector<long long> key;
  for (int s = 0; s < S; ++s) {
    const int p0 = nb.offsets[s], count = nb.offsets[s + 1] - p0;
    const double* w = nb.weights.data() + p0;
    const double* g = nb.weight_gradients.data() + 3 * static_cast<size_t>(p0);
    key.assign(1, count);
    for (int a = 0; a < count; ++a) key.push_back(std::llround(w[a] / quantum));
    auto found = index.find(key);
    if (found == index.end()) {
      if (static_cast<int>(classes.size()) >= max_classes) return std::nullopt;
      // A new class with this sample's gradients as its reference: they must span 3D.
      const Mat3 gram = sum_outer(g, g, count);
      const double scale = (gram.m[0][0] + gram.m[1][1] + gram.m[2][2]) / 3;
      if (!(scale > 0) || !(det(gram) > 1e-9 * scale * scale * scale)) return std::nullopt;
      ClassInfo c;
      c.first = out.class_offsets.back();
      c.count = count;
      c.gram_inverse = transpose(inverse_transpose(gram));
      for (int a = 0; a < count; ++a) {
        out.class_pairs.push_back(w[a]);
        for (int k = 0; k < 3; ++k) out.class_pairs.push_back(g[3 * a + k]);
      }
      out.class_offsets.push_back(c.first + count);
      found = index.emplace(key, static_cast<int>(classes.size())).first;
      classes.push_back(c);
    }
    const ClassInfo& c = classes[static_cast<size_t>(found->second)];
    const double* r = out.class_pairs.data() + 4 * static_cast<size_t>(c.first);
    std::vector<double> ref(3 * static_cast<size_t>(count));
    for (int a = 0; a < count; ++a)
      for (int k = 0; k < 3; ++k) ref[3 * a + k] = r[4 * a + 1 + k];
    // g_a = A r_a for all a: A = (sum g_a r_a^T) (sum r_a r_a^T)^-1 (least squares), then checked.
    const Mat3 A = sum_outer(g, ref.data(), count) * c.gram_inverse;
    double largest = 0, error = 0;
    for (int a = 0; a < count; ++a) {
      largest = std::max(largest, norm(load3(g + 3 * a)));
      if (std::fabs(w[a] - r[4 * a]) > rel_tol) return std::nullopt;
    }
    for (int a = 0; a < count; ++a) error = std::max(error, norm(A * load3(&ref[3 * a]) - load3(g + 3 * a)));
    error = largest > 0 ? error / largest : error;
    if (!(error <= rel_tol)) return std::nullopt;
    out.max_error = std::max(out.max_error, error);
    out.sample_class[s] = found->second;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) out.sample_maps[9 * static_cast<size_t>(s) + 3 * i + j] = A.m[i][j];
  }
  return out;
}

}  // namespace fascia::gpu
