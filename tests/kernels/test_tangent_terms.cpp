// The terms of the device's assembled tangent blocks (tangent_terms.hpp): each block (a, b),
// b <= a, lists every pair of frame a with every pair of its sample whose frame is b, in the
// reverse table's order and then the sample's; the blocks with b > a list none. Checked against
// a direct enumeration on models whose frames share samples with many others.
#include "integrate/tangent_probing.hpp"
#include "kernels_fixtures.hpp"
#include "tangent_terms.hpp"

#include <catch2/catch.hpp>
#include <omp.h>

#include <vector>

using namespace fascia;
using namespace fascia::gpu;
using namespace fascia::test;

namespace {

// Block p's terms by enumerating frame a's pairs and their samples' pairs directly.
std::vector<int> direct_terms(const Model& model, int a, int b) {
  std::vector<int> terms;
  if (b > a) return terms;
  const NeighbourTable& nb = model.neighbours;
  for (int r = model.reverse.offsets[a]; r < model.reverse.offsets[a + 1]; ++r) {
    const int pa = model.reverse.pairs[r], s = model.reverse.pair_samples[pa];
    for (int pb = nb.offsets[s]; pb < nb.offsets[s + 1]; ++pb)
      if (nb.frames[pb] == b) terms.insert(terms.end(), {pa, pb});
  }
  return terms;
}

void check_terms(const Model& model) {
  const TangentProbing t = tangent_probing(model);
  const TangentTerms terms = tangent_terms(model.neighbours, model.reverse, t.block_offsets, t.block_frames);
  REQUIRE(terms.offsets.size() == t.block_frames.size() + 1);
  REQUIRE(terms.pairs.size() == 2 * static_cast<size_t>(terms.offsets.back()));
  long long listed = 0;
  for (int a = 0; a < model.frame_count(); ++a)
    for (int p = t.block_offsets[a]; p < t.block_offsets[a + 1]; ++p) {
      const std::vector<int> expected = direct_terms(model, a, t.block_frames[p]);
      const std::vector<int> got(terms.pairs.begin() + 2 * terms.offsets[p],
                                 terms.pairs.begin() + 2 * terms.offsets[p + 1]);
      REQUIRE(got == expected);
      listed += static_cast<long long>(got.size()) / 2;
    }
  // Every pair of pairs of one sample with frame(p_b) <= frame(p_a) is listed once.
  long long expected_total = 0;
  const NeighbourTable& nb = model.neighbours;
  for (int s = 0; s < model.sample_count(); ++s)
    for (int pa = nb.offsets[s]; pa < nb.offsets[s + 1]; ++pa)
      for (int pb = nb.offsets[s]; pb < nb.offsets[s + 1]; ++pb) expected_total += nb.frames[pb] <= nb.frames[pa];
  CHECK(listed == expected_total);
}

}  // namespace

TEST_CASE("tangent terms: every block lists its frames' shared pairs, for any threads", "[kernels][layout]") {
  for (const CellType type : {CellType::tetrahedron, CellType::hexahedron}) {
    const Model model = kernels_test_model(type, MaterialLaw::stvk, 5, 4, 3);
    check_terms(model);
    // The same lists with one thread as with the team.
    const TangentProbing t = tangent_probing(model);
    const TangentTerms team = tangent_terms(model.neighbours, model.reverse, t.block_offsets, t.block_frames);
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    const TangentTerms one = tangent_terms(model.neighbours, model.reverse, t.block_offsets, t.block_frames);
    omp_set_num_threads(threads);
    CHECK(one.offsets == team.offsets);
    CHECK(one.pairs == team.pairs);
  }
}
