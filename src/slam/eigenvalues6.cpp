// See eigenvalues6.h.
#include "slam/eigenvalues6.h"

#include <Eigen/Eigenvalues>

namespace ef::slam {

Eigen::Matrix<double, 6, 1> symmetric_eigenvalues6(const Eigen::Matrix<double, 6, 6>& a) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(a, Eigen::EigenvaluesOnly);
  return eig.eigenvalues();
}

}  // namespace ef::slam
