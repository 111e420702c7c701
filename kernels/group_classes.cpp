#include "group_classes.hpp"

#include "core/small_math.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace fascia::gpu {
namespace {

constexpr int kTable = kGroupLanes * kGroupLanes;  // (thread, frame) entries of a group

struct ClassInfo {
  int first = 0;      // first entry of the class in class_pairs / 4
  Mat3 gram_inverse;  // (sum r r^T)^-1 over the class's pairs, m^2
};

void refuse(std::string* refusal, const std::string& why) {
  if (refusal) *refusal = why;
}

}  // namespace

std::optional<GroupClasses> find_group_classes(const Model& model, const GroupLayout& G, int max_classes,
                                               std::string* refusal, double rel_tol) {
  const NeighbourTable& nb = model.neighbours;
  const int groups = G.group_count();
  GroupClasses out;
  out.group_class.resize(groups);
  out.group_maps.resize(9 * static_cast<size_t>(groups));
  std::vector<ClassInfo> classes;
  // Classes by the table's shape and weights quantised to rel_tol / 2 (as find_shape_classes).
  std::map<std::vector<long long>, int> index;
  const double quantum = 0.5 * rel_tol;
  std::vector<long long> key;
  double w[kTable], g[kTable][3];
  bool present[kTable];
  for (int gi = 0; gi < groups; ++gi) {
    std::fill(present, present + kTable, false);
    for (int s = G.group_samples[gi]; s < G.group_samples[gi + 1]; ++s)
      for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
        const int e = kGroupLanes * (s - G.group_samples[gi]) + G.pair_entry[p];
        present[e] = true;
        w[e] = nb.weights[p];
        for (int c = 0; c < 3; ++c) g[e][c] = nb.weight_gradients[3 * static_cast<size_t>(p) + c];
      }
    key.assign(1, G.group_samples[gi + 1] - G.group_samples[gi]);
    for (int e = 0; e < kTable; ++e) key.push_back(present[e] ? std::llround(w[e] / quantum) : -(1LL << 62));
    auto found = index.find(key);
    if (found == index.end()) {
      if (static_cast<int>(classes.size()) >= max_classes) {
        refuse(refusal, "more than " + std::to_string(max_classes) + " classes of groups");
        return std::nullopt;
      }
      // A new class with this group's gradients as its reference: they must span 3D.
      Mat3 gram = zero3();
      for (int e = 0; e < kTable; ++e)
        if (present[e]) gram += outer(load3(g[e]), load3(g[e]));
      const double scale = (gram.m[0][0] + gram.m[1][1] + gram.m[2][2]) / 3;
      if (!(scale > 0) || !(det(gram) > 1e-9 * scale * scale * scale)) {
        refuse(refusal, "the gradients of group " + std::to_string(gi) + " do not span 3D");
        return std::nullopt;
      }
      ClassInfo c;
      c.first = static_cast<int>(out.class_pairs.size()) / 4;
      c.gram_inverse = transpose(inverse_transpose(gram));
      for (int e = 0; e < kTable; ++e) {
        out.class_pairs.push_back(present[e] ? w[e] : 0.0);
        for (int k = 0; k < 3; ++k) out.class_pairs.push_back(present[e] ? g[e][k] : 0.0);
      }
      found = index.emplace(key, static_cast<int>(classes.size())).first;
      classes.push_back(c);
    }
    const ClassInfo& c = classes[static_cast<size_t>(found->second)];
    const double* ref = out.class_pairs.data() + 4 * static_cast<size_t>(c.first);
    // g = A r for all pairs: A = (sum g r^T) (sum r r^T)^-1 (least squares), then checked.
    Mat3 gr = zero3();
    double largest = 0;
    for (int e = 0; e < kTable; ++e)
      if (present[e]) {
        gr += outer(load3(g[e]), load3(ref + 4 * e + 1));
        largest = std::max(largest, norm(load3(g[e])));
        if (std::fabs(w[e] - ref[4 * e]) > rel_tol) {
          refuse(refusal, "the weights of group " + std::to_string(gi) + " match no class");
          return std::nullopt;
        }
      }
    const Mat3 A = gr * c.gram_inverse;
    double error = 0;
    for (int e = 0; e < kTable; ++e)
      if (present[e]) error = std::max(error, norm(A * load3(ref + 4 * e + 1) - load3(g[e])));
    error = largest > 0 ? error / largest : error;
    if (!(error <= rel_tol)) {
      refuse(refusal, "the gradients of group " + std::to_string(gi) + " are no linear map of its class's");
      return std::nullopt;
    }
    out.max_error = std::max(out.max_error, error);
    out.group_class[gi] = found->second;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) out.group_maps[9 * static_cast<size_t>(gi) + 3 * i + j] = A.m[i][j];
  }
  return out;
}

}  // namespace fascia::gpu
