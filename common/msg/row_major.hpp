// Covariances travel as row-major double[N*N] arrays in the messages; these convert them.
#pragma once

#include <Eigen/Core>

namespace fieldline::msg {

template <int N>
Eigen::Matrix<double, N, N> fromRowMajor(const double (&a)[N * N]) {
  return Eigen::Map<const Eigen::Matrix<double, N, N, Eigen::RowMajor>>(a);
}

template <int N>
void toRowMajor(const Eigen::Matrix<double, N, N>& matrix, double (&a)[N * N]) {
  Eigen::Map<Eigen::Matrix<double, N, N, Eigen::RowMajor>> out(a);
  out = matrix;
}

}  // namespace fieldline::msg
