// BandMatrix, banded Cholesky/Takahashi and Khan et al. Alg. 1 (docs/algorithms.md §2.3 properties 1–5).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>

#include "eigen_gtest.hpp"
#include "swarmloc/estimators/centralized/band_inversion.hpp"
#include "swarmloc/estimators/centralized/band_matrix.hpp"

namespace swarmloc::estimators::centralized {
namespace {

// Random SPD matrix of the given bandwidth (diagonally dominant).
MatX random_spd_band(int n, int bandwidth, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MatX a = MatX::Zero(n, n);
  for (int j = 0; j < n; ++j) {
    for (int i = j + 1; i <= std::min(n - 1, j + bandwidth); ++i) a(i, j) = a(j, i) = u(rng);
  }
  for (int i = 0; i < n; ++i) a(i, i) = a.row(i).cwiseAbs().sum() + 0.5 + std::abs(u(rng));
  return a;
}

// Random dense SPD matrix.
MatX random_spd(int n, std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  MatX b(n, n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) b(i, j) = g(rng);
  }
  return b * b.transpose() / n + MatX::Identity(n, n);
}

MatX band_of(const MatX& a, int bandwidth) { return BandMatrix::from_dense(a, bandwidth).to_dense(); }

MatX dense_inverse(const MatX& a) { return a.llt().solve(MatX::Identity(a.rows(), a.cols())); }

TEST(BandMatrix, RoundTripsTheBandOfADenseMatrix) {
  std::mt19937_64 rng(1);
  const MatX a = random_spd(9, rng);
  const BandMatrix band = BandMatrix::from_dense(a, 3);
  EXPECT_EQ(band.size(), 9);
  EXPECT_EQ(band.bandwidth(), 3);
  EXPECT_EQ(band.storage().rows(), 4);
  const MatX dense = band.to_dense();
  for (int i = 0; i < 9; ++i) {
    for (int j = 0; j < 9; ++j) EXPECT_DOUBLE_EQ(dense(i, j), std::abs(i - j) <= 3 ? a(i, j) : 0.0);
  }
  EXPECT_EQ(matrix_bandwidth(dense), 3);
}

TEST(BandMatrix, MultiplyAndAddDiagonalMatchDense) {
  std::mt19937_64 rng(2);
  const MatX a = band_of(random_spd(12, rng), 4);
  BandMatrix band = BandMatrix::from_dense(a, 4);
  const VecX x = VecX::LinSpaced(12, -1.0, 2.0);
  EXPECT_MATRIX_NEAR(band.multiply(x), a * x, 1e-12);
  band.add_diagonal(0.7);
  EXPECT_MATRIX_NEAR(band.to_dense(), a + 0.7 * MatX::Identity(12, 12), 1e-12);
  EXPECT_MATRIX_NEAR(band.principal_block(3, 5), (a + 0.7 * MatX::Identity(12, 12)).block(3, 3, 5, 5), 1e-12);
}

TEST(BandMatrix, RejectsBandwidthOutsideRange) {
  EXPECT_THROW(BandMatrix(4, 4), std::invalid_argument);
  EXPECT_THROW(BandMatrix(4, -1), std::invalid_argument);
}

TEST(BandCholesky, SolvesAndSelectedInverseMatchesDenseInverseInBand) {
  std::mt19937_64 rng(3);
  for (int bandwidth : {0, 1, 3, 7}) {
    const MatX a = random_spd_band(25, bandwidth, rng);
    const BandCholesky chol(BandMatrix::from_dense(a, bandwidth));
    const VecX b = VecX::LinSpaced(25, 1.0, -3.0);
    EXPECT_MATRIX_NEAR(chol.solve(b), a.llt().solve(b), 1e-10);
    EXPECT_MATRIX_NEAR(chol.selected_inverse().to_dense(), band_of(dense_inverse(a), bandwidth), 1e-10);
  }
}

TEST(BandCholesky, ThrowsOnIndefiniteMatrix) {
  MatX a = MatX::Identity(4, 4);
  a(2, 2) = -1.0;
  EXPECT_THROW(BandCholesky(BandMatrix::from_dense(a, 1)), std::domain_error);
}

// Property 3: L = n − 1 returns the exact inverse.
TEST(BandInverse, FullBandwidthIsTheExactInverse) {
  std::mt19937_64 rng(4);
  const MatX a = random_spd(10, rng);
  for (auto method : {BandInversionMethod::kWindows, BandInversionMethod::kSlidingCholesky}) {
    EXPECT_MATRIX_NEAR(band_inverse(a, 9, method), dense_inverse(a), 1e-10);
  }
}

// Property 3: L = 0 returns diag(1/A_ll).
TEST(BandInverse, ZeroBandwidthIsTheInverseDiagonal) {
  std::mt19937_64 rng(5);
  const MatX a = random_spd(8, rng);
  const MatX expected = a.diagonal().cwiseInverse().asDiagonal();
  for (auto method : {BandInversionMethod::kWindows, BandInversionMethod::kSlidingCholesky}) {
    EXPECT_MATRIX_NEAR(band_inverse(a, 0, method), expected, 1e-14);
  }
}

// Properties 1 and 2: Z is symmetric and L-banded, and Z⁻¹ matches A on the band.
TEST(BandInverse, InverseOfResultMatchesInputInBand) {
  std::mt19937_64 rng(6);
  const MatX a = random_spd(20, rng);
  for (int bandwidth : {1, 2, 5, 11}) {
    for (auto method : {BandInversionMethod::kWindows, BandInversionMethod::kSlidingCholesky}) {
      const MatX z = band_inverse(a, bandwidth, method);
      EXPECT_MATRIX_NEAR(z, z.transpose(), 0.0);
      EXPECT_LE(matrix_bandwidth(z), bandwidth);
      EXPECT_MATRIX_NEAR(band_of(dense_inverse(z), bandwidth), band_of(a, bandwidth), 1e-10);
    }
  }
}

// Property 3: if A⁻¹ is L-banded, Z = A⁻¹ exactly.
TEST(BandInverse, BandedInverseIsRecoveredExactly) {
  std::mt19937_64 rng(7);
  const MatX z0 = random_spd_band(30, 4, rng);
  const MatX a = dense_inverse(z0);
  for (auto method : {BandInversionMethod::kWindows, BandInversionMethod::kSlidingCholesky}) {
    EXPECT_MATRIX_NEAR(band_inverse(a, 4, method), z0, 1e-10);
    EXPECT_MATRIX_NEAR(band_inverse(a, 6, method), z0, 1e-10);  // any L above the true bandwidth
  }
}

// Property 4: entries outside the band are never read.
TEST(BandInverse, ReadsOnlyTheBand) {
  std::mt19937_64 rng(8);
  const MatX a = random_spd(15, rng);
  MatX scrambled = a;
  for (int i = 0; i < 15; ++i) {
    for (int j = 0; j < 15; ++j) {
      if (std::abs(i - j) > 3) scrambled(i, j) = 1e6 * (i + 1) - j;
    }
  }
  for (auto method : {BandInversionMethod::kWindows, BandInversionMethod::kSlidingCholesky}) {
    EXPECT_MATRIX_NEAR(band_inverse(scrambled, 3, method), band_inverse(a, 3, method), 0.0);
  }
}

TEST(BandInverse, SlidingCholeskyAgreesWithAlgorithm1OnRandomBandMatrices) {
  std::mt19937_64 rng(9);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 10 + trial * 7;
    const int a_bandwidth = 1 + trial % 9;
    const int bandwidth = std::min(n - 1, (trial * 5) % 13);
    const BandMatrix a = BandMatrix::from_dense(random_spd_band(n, a_bandwidth, rng), a_bandwidth);
    const BandMatrix windows = band_inverse_windows(a, bandwidth);
    const BandMatrix sliding = band_inverse_sliding(a, bandwidth);
    EXPECT_MATRIX_NEAR(sliding.storage(), windows.storage(), 1e-9) << "n=" << n << " L=" << bandwidth;
  }
}

TEST(BandInverse, RejectsBandwidthOutsideRange) {
  const BandMatrix a = BandMatrix::from_dense(MatX::Identity(5, 5), 1);
  EXPECT_THROW((void)band_inverse_windows(a, 5), std::invalid_argument);
  EXPECT_THROW((void)band_inverse_sliding(a, -1), std::invalid_argument);
}

}  // namespace
}  // namespace swarmloc::estimators::centralized
