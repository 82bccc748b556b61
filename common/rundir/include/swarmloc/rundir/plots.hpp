#pragma once
// The plots of a run directory (plots/): gnuplot scripts plus the data files they read, computed here
// from the run's own record. The scripts and data are always written; the PNGs only when gnuplot is
// on PATH (pngcairo terminal).
//   error.png            RMSE / mean / max error vs step with the accumulated CRLB (log scale)
//   nees.png             mean NEES vs step with its 95 % chi-square band
//   positions.png        final truth, estimates, 95 % covariance ellipses, anchors, links coloured by
//                        delivered fraction (equal aspect)
//   error_histogram.png  histogram of the non-anchor agents' final errors
//   efficiency.png       RMSE over the optimum of the run's own data (and over the bound) at the optimum's
//                        solved steps (optimum.csv; docs/algorithms.md §1.3.2); error.png draws the optimum
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "swarmloc/rundir/run_record.hpp"

namespace swarmloc::rundir {

/// Chi-square 2-dof quantile at 95 %: the 95 % covariance ellipse is eᵀP⁻¹e = 5.991.
inline constexpr double kChiSquare2Dof95 = 5.991;

/// Standard normal quantile Φ⁻¹(p), p in (0, 1) (Acklam's rational approximation, |rel. error| < 1.2e-9).
double normal_quantile(double p);

/// Chi-square quantile χ²_dof(p) by the Wilson–Hilferty approximation
/// dof·(1 − 2/(9 dof) + z_p·√(2/(9 dof)))³.
double chi_square_quantile(double p, double dof);

struct NeesBand {
  double lower = 0.0;
  double upper = 0.0;
};

/// The two-sided `coverage` band of the mean NEES of `agents` consistent agents with d = `dimensions` dof
/// each: [χ²_{dn}((1−c)/2)/n, χ²_{dn}((1+c)/2)/n]. NaN bounds when agents <= 0.
NeesBand nees_band(int agents, double coverage = 0.95, int dimensions = 2);

/// `points` points on the ellipse (x − mean)ᵀ covariance⁻¹ (x − mean) = chi_square; the first point
/// is repeated at the end so the curve closes. Empty if the covariance is not finite and positive definite.
std::vector<Vec2> covariance_ellipse(const Vec2& mean, const Mat2& covariance,
                                     double chi_square = kChiSquare2Dof95, int points = 64);

/// Writes plots/ under `directory` (which must already hold metrics.csv) and runs gnuplot if present.
/// Returns true if gnuplot ran and succeeded on every script. Throws OutputError if a file, or a PNG
/// gnuplot could not write for want of room, did not make it to disk.
bool write_plots(const std::filesystem::path& directory, const RunRecord& record);

/// `text` as a gnuplot single-quoted string literal ('' stands for a quote inside it).
std::string gnuplot_quote(std::string_view text);

enum class GnuplotResult { kDone, kNotInstalled, kFailed };

/// Runs `gnuplot script` in `directory` (no shell; stdout and stderr discarded) and checks that every
/// file of `outputs` (names in `directory`) exists and is whole afterwards (a PNG ends with its IEND
/// chunk; any other file is non-empty). A missing or partial output throws
/// OutputError when the directory cannot take a write (disk full, quota, read-only, file size limit);
/// otherwise a gnuplot failure is a warning on stderr and kFailed. Without gnuplot on PATH: kNotInstalled.
GnuplotResult run_gnuplot(const std::filesystem::path& directory, const std::string& script,
                          const std::vector<std::string>& outputs);

}  // namespace swarmloc::rundir
