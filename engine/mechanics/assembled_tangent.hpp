// The assembled sparse tangent K (6N x 6N) of the elastic energy, for direct solves (CHOLMOD)
// and for checking the matrix-free product.
#pragma once

#include "mechanics/elasticity.hpp"

#include <Eigen/SparseCore>

namespace fascia {

// K = sum_s v_s B_s^T D_s B_s + blockdiag(rotational geometric blocks), where B_s stacks the 9x6
// pair Jacobians of the sample's frames (eq. 11) and D_s = d^2 psi / dF^2. Call
// elasticity.prepare(state) first. Both triangles are stored.
Eigen::SparseMatrix<double> assemble_tangent(const Elasticity& elasticity);

}  // namespace fascia
