#include "mechanics/assembled_tangent.hpp"

#include <Eigen/Dense>
#include <omp.h>

namespace fascia {

Eigen::SparseMatrix<double> assemble_tangent(const Elasticity& elasticity) {
  const Model& model = elasticity.model();
  const NeighbourTable& nb = model.neighbours;
  const int s_count = model.sample_count();
  const int nthreads = elasticity.threads();
  std::vector<std::vector<Eigen::Triplet<double>>> triplets(nthreads);
#pragma omp parallel num_threads(nthreads) if (s_count > 1024)
  {
    auto& out = triplets[omp_get_thread_num()];
    Eigen::Matrix<double, 9, 9, Eigen::RowMajor> D;
    Eigen::Matrix<double, 9, Eigen::Dynamic> B;
    Eigen::Matrix<double, 9, 6, Eigen::RowMajor> Bp;
#pragma omp for schedule(static)
    for (int s = 0; s < s_count; ++s) {
      const int begin = nb.offsets[s], k = nb.offsets[s + 1] - begin;
      elasticity.material_matrix(s, D.data());
      B.resize(9, 6 * k);
      for (int a = 0; a < k; ++a) {
        elasticity.pair_jacobian(begin + a, Bp.data());
        B.middleCols(6 * a, 6) = Bp;
      }
      // D rows are vec(dP[E_k]); D is symmetric for hyperelastic laws, use its transpose as the
      // column-acting operator to stay exact for any row/column convention.
      const Eigen::MatrixXd H = model.samples.volumes[s] * (B.transpose() * D.transpose() * B);
      for (int a = 0; a < k; ++a)
        for (int b = 0; b < k; ++b) {
          const int i = nb.frames[begin + a], j = nb.frames[begin + b];
          for (int r = 0; r < 6; ++r)
            for (int c = 0; c < 6; ++c) out.emplace_back(6 * i + r, 6 * j + c, H(6 * a + r, 6 * b + c));
        }
    }
  }
  std::vector<Eigen::Triplet<double>> all;
  for (auto& t : triplets) all.insert(all.end(), t.begin(), t.end());
  const std::vector<double>& blocks = elasticity.rotational_blocks();
  for (int i = 0; i < model.frame_count(); ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) all.emplace_back(6 * i + 3 + r, 6 * i + 3 + c, blocks[9 * i + 3 * r + c]);
  Eigen::SparseMatrix<double> K(model.dof_count(), model.dof_count());
  K.setFromTriplets(all.begin(), all.end());
  return K;
}

}  // namespace fascia
