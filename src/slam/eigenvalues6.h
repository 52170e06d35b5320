// The eigenvalues of a symmetric 6x6 matrix, for the tracker's conditioning tests (slam/tracker.cpp:
// the RGB boost and the lost verdict's condition number).
//
// In a translation unit of its own on purpose: Eigen's SelfAdjointEigenSolver instantiated inside
// tracker.cpp made that file take 47 s to compile with GCC 12 at -O3 (35 s of it this solver, against
// about 7 s alone here), on every build of CI (release, TSan, aarch64). The same Eigen code with the
// same flags: the values are the same bits as before.
#pragma once

#include <Eigen/Core>

namespace ef::slam {

// Ascending eigenvalues of the symmetric matrix `a` (only its lower triangle is read, as Eigen's
// solver does).
Eigen::Matrix<double, 6, 1> symmetric_eigenvalues6(const Eigen::Matrix<double, 6, 6>& a);

}  // namespace ef::slam
