#include "solve/block_jacobi.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace fascia {

BlockJacobi::BlockJacobi(std::vector<double> blocks, const std::uint8_t* fixed) : m_inverse(std::move(blocks)) {
  const int frames = static_cast<int>(m_inverse.size() / 36);
  for (int i = 0; i < frames; ++i) {
    Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> B(&m_inverse[36 * static_cast<size_t>(i)]);
    double largest = 0;
    for (int k = 0; k < 6; ++k) largest = std::max(largest, std::abs(B(k, k)));
    if (largest == 0) largest = 1;
    for (int k = 0; k < 6; ++k)
      if (fixed && fixed[6 * i + k]) {
        B.row(k).setZero();
        B.col(k).setZero();
        B(k, k) = largest;
      }
    Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(B);
    if (llt.info() == Eigen::Success) {
      B = llt.solve(Eigen::Matrix<double, 6, 6>::Identity());
    } else {
      Eigen::Matrix<double, 6, 6> D = Eigen::Matrix<double, 6, 6>::Zero();
      for (int k = 0; k < 6; ++k) D(k, k) = 1.0 / std::max(std::abs(B(k, k)), 1e-12 * largest);
      B = D;
    }
  }
}

void BlockJacobi::apply(const std::vector<double>& r, std::vector<double>& z) const {
  const int frames = static_cast<int>(m_inverse.size() / 36);
  z.resize(r.size());
  for (int i = 0; i < frames; ++i)
    for (int a = 0; a < 6; ++a) {
      double s = 0;
      for (int c = 0; c < 6; ++c) s += m_inverse[36 * static_cast<size_t>(i) + 6 * a + c] * r[6 * i + c];
      z[6 * i + a] = s;
    }
}

}  // namespace fascia
