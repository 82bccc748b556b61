#include "swarmloc/estimators/bp/multipath_bp.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "swarmloc/models/multipath.hpp"

namespace swarmloc::estimators::bp {
namespace {

/// The smaller eigenvalue of the symmetric part of m exceeds min_eigenvalue (closed form for 2 × 2:
/// (a + c)/2 − √(((a − c)/2)² + b²); an iterative eigensolver per neighbour and iteration cost more
/// than the message itself).
bool positive_definite(const Mat2& m, double min_eigenvalue) {
  if (!m.allFinite()) return false;
  const double off_diagonal = 0.5 * (m(0, 1) + m(1, 0));
  const double smaller = 0.5 * (m(0, 0) + m(1, 1)) - std::hypot(0.5 * (m(0, 0) - m(1, 1)), off_diagonal);
  return smaller > min_eigenvalue;
}

bool full_column_rank(const MatX& G) {
  if (G.rows() < 2) return false;
  const Mat2 gram = G.transpose() * G;
  return positive_definite(gram, 1e-12 * std::max(1.0, gram.trace()));
}

/// A belief as mean and information Λ = P⁻¹.
struct MeanInformation {
  Vec2 mean;
  Mat2 information;
};

/// Exact GaBP: the sender's belief without what `self` contributed to it. nullopt if what is left is not
/// PD (the sender knows nothing but what came from `self`).
std::optional<MeanInformation> cavity(const BeliefMessage& belief, AgentId self, double min_information) {
  if (!positive_definite(belief.information, min_information)) return std::nullopt;
  const auto own = std::find_if(belief.contributions.begin(), belief.contributions.end(),
                                [&](const BeliefContribution& c) { return c.from == self; });
  if (own == belief.contributions.end()) return MeanInformation{belief.mean_m, belief.information};
  Mat2 information = belief.information - own->information;
  information = 0.5 * (information + information.transpose());
  if (!positive_definite(information, min_information)) return std::nullopt;
  const Vec2 mean = information.ldlt().solve(Vec2(belief.information * belief.mean_m - own->info_vec));
  if (!mean.allFinite()) return std::nullopt;
  return MeanInformation{mean, information};
}

}  // namespace

PathSet path_set(const std::vector<MultipathMeasurement>& paths, AgentId peer, double los_threshold) {
  std::vector<const MultipathMeasurement*> selected;
  for (const auto& path : paths) {
    if (path.peer == peer) selected.push_back(&path);
  }
  std::sort(selected.begin(), selected.end(),
            [](const auto* a, const auto* b) { return a->path_index < b->path_index; });
  PathSet set;
  const auto rows = static_cast<Eigen::Index>(selected.size());
  set.G.resize(rows, 2);
  set.d.resize(rows);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const auto& path = *selected[static_cast<std::size_t>(r)];
    // [D-1]: rows g(θ_ij, θ_ji)ᵀ, θ_ij measured at the peer S_j, θ_ji here at S_i.
    set.G.row(r) = models::path_direction(path.aoa_there_rad, path.aoa_here_rad, los_threshold).transpose();
    set.d(r) = path.length_m;
  }
  return set;
}

VecX path_variances(const PathSet& paths, const MultipathBpParams& params) {
  VecX variances = VecX::Constant(paths.G.rows(), params.sigma2);
  if (params.doa_variance_rad2 > 0.0) {
    for (Eigen::Index r = 0; r < paths.G.rows(); ++r) {
      const double cot2_half_angle = std::max(0.0, paths.G.row(r).squaredNorm() - 1.0);
      const double half_length = 0.5 * paths.d(r);
      variances(r) += params.doa_variance_rad2 * cot2_half_angle * 2.0 * half_length * half_length;
    }
  }
  return variances;
}

namespace {
/// GᵀV⁻¹G and GᵀV⁻¹d of one link's paths (V = diag(variances)): its weighted least-squares terms.
InformationPair weighted_normal_terms(const PathSet& paths, const VecX& variances) {
  const MatX weighted_transpose = paths.G.transpose() * variances.cwiseInverse().asDiagonal();
  return InformationPair{weighted_transpose * paths.G, weighted_transpose * paths.d};
}
}  // namespace

LinkModel link_model(PathSet paths, const MultipathBpParams& params) {
  LinkModel link;
  link.variances = path_variances(paths, params);
  link.full_rank = full_column_rank(paths.G);
  if (link.full_rank) {
    const InformationPair terms = weighted_normal_terms(paths, link.variances);
    link.A = 0.5 * (terms.information + terms.information.transpose());
    link.relative = link.A.ldlt().solve(terms.info_vec);
  }
  link.paths = std::move(paths);
  return link;
}

std::optional<Gaussian2> pairwise_from_parent(const Gaussian2& parent, const PathSet& paths,
                                              const MultipathBpParams& params) {
  const LinkModel link = link_model(paths, params);
  if (!link.full_rank) return std::nullopt;
  Gaussian2 child;
  child.mean = parent.mean + link.relative;                 // eq. (2): s_j + G†d
  child.covariance = parent.covariance + link.A.inverse();  // P_j + σ²Σ_ji
  return child;
}

std::optional<InformationPair> neighbour_message(const LinkModel& link, const Vec2& mean_j,
                                                 const Mat2& info_j, bool anchor_j,
                                                 const MultipathBpParams& params) {
  if (link.paths.G.rows() == 0) return std::nullopt;
  if (!anchor_j && !positive_definite(info_j, params.min_information)) return std::nullopt;  // P_j infinite
  InformationPair message;
  if (link.full_rank) {
    const Mat2& A = link.A;                  // A_ji = (σ²Σ_ji)⁻¹
    const Vec2 nu = mean_j + link.relative;  // ν_ji = μ_j + G†d
    // W_ji⁻¹ = A − A(A + Λ_j)⁻¹A = (A⁻¹ + Λ_j⁻¹)⁻¹ (docs/algorithms.md §5.2); anchor: W⁻¹ = A.
    message.information = anchor_j ? A : Mat2(A - A * (A + info_j).ldlt().solve(A));
    message.information = 0.5 * (message.information + message.information.transpose());
    message.info_vec = message.information * nu;  // eq. (4) numerator term
    return message;
  }
  // General message (R = 1 or rank-deficient G): C = σ²I + G P_j Gᵀ.
  const PathSet& paths = link.paths;
  MatX C = link.variances.asDiagonal();
  if (!anchor_j) C += paths.G * info_j.inverse() * paths.G.transpose();
  const Eigen::LDLT<MatX> ldlt(C);
  message.information = paths.G.transpose() * ldlt.solve(paths.G);
  message.info_vec = paths.G.transpose() * ldlt.solve(paths.d + paths.G * mean_j);
  return message;
}

std::optional<InformationPair> neighbour_message(const PathSet& paths, const Vec2& mean_j, const Mat2& info_j,
                                                 bool anchor_j, const MultipathBpParams& params) {
  return neighbour_message(link_model(paths, params), mean_j, info_j, anchor_j, params);
}

std::optional<std::vector<Gaussian2>> centralized_from_paths(
    const std::vector<std::optional<Vec2>>& anchor_positions, const std::vector<LinkPaths>& links,
    const MultipathBpParams& params) {
  const auto nodes = anchor_positions.size();
  std::vector<Eigen::Index> unknown(nodes, -1);  // node -> first row of its block in the normal equations
  Eigen::Index unknowns = 0;
  for (std::size_t k = 0; k < nodes; ++k) {
    if (!anchor_positions[k]) unknown[k] = 2 * unknowns++;
  }
  MatX normal = MatX::Zero(2 * unknowns, 2 * unknowns);
  VecX rhs = VecX::Zero(2 * unknowns);
  for (const auto& link : links) {
    if (link.i < 0 || link.j < 0 || static_cast<std::size_t>(link.i) >= nodes ||
        static_cast<std::size_t>(link.j) >= nodes || link.i == link.j) {
      throw std::invalid_argument("centralized_from_paths: link with an unknown or repeated node");
    }
    if (link.paths.G.rows() == 0) continue;
    // Residual d − G(s_i − s_j): s_i enters with +G, s_j with −G.
    const auto [information, path_info_vec] =
        weighted_normal_terms(link.paths, path_variances(link.paths, params));
    Vec2 info_vec = path_info_vec;
    const std::array<std::pair<AgentId, double>, 2> ends{{{link.i, 1.0}, {link.j, -1.0}}};
    for (const auto& [node, sign] : ends) {
      const auto& fixed = anchor_positions[static_cast<std::size_t>(node)];
      if (fixed) info_vec -= sign * information * *fixed;  // move a known position to the right side
    }
    for (const auto& [row_node, row_sign] : ends) {
      const Eigen::Index row = unknown[static_cast<std::size_t>(row_node)];
      if (row < 0) continue;
      rhs.segment<2>(row) += row_sign * info_vec;
      for (const auto& [col_node, col_sign] : ends) {
        const Eigen::Index col = unknown[static_cast<std::size_t>(col_node)];
        if (col >= 0) normal.block<2, 2>(row, col) += row_sign * col_sign * information;
      }
    }
  }
  const Eigen::LLT<MatX> llt(0.5 * (normal + normal.transpose()));
  if (llt.info() != Eigen::Success) return std::nullopt;
  const VecX solution = llt.solve(rhs);
  const MatX covariance = llt.solve(MatX::Identity(2 * unknowns, 2 * unknowns));
  std::vector<Gaussian2> result(nodes);
  for (std::size_t k = 0; k < nodes; ++k) {
    if (anchor_positions[k]) {
      result[k].mean = *anchor_positions[k];
      continue;
    }
    result[k].mean = solution.segment<2>(unknown[k]);
    result[k].covariance = covariance.block<2, 2>(unknown[k], unknown[k]);
  }
  return result;
}

MultipathBp::MultipathBp(const AgentSetup& setup, const MultipathBpParams& params)
    : setup_(setup), params_(params), mu_(setup.initial_guess_m), localized_(setup.anchor) {
  if (!(params.sigma2 > 0.0)) throw std::invalid_argument("multipath_bp.sigma2: must be > 0");
  if (!(params.doa_variance_rad2 >= 0.0) || !std::isfinite(params.doa_variance_rad2))
    throw std::invalid_argument("multipath_bp.doa_variance_rad2: must be finite and >= 0");
  if (!setup.initial_guess_m.allFinite())
    throw std::invalid_argument("multipath_bp: initial guess is not finite");
}

Outbox MultipathBp::published() const {
  BeliefMessage belief;
  belief.iteration = iteration_;
  belief.mean_m = mu_;
  belief.information = Lambda_;
  belief.infinite_information = setup_.anchor;
  belief.contributions = contributions_;
  Outbox outbox;
  outbox.belief = belief;
  return outbox;
}

Outbox MultipathBp::initial_outbox() const { return published(); }

StepOutput MultipathBp::step(const StepInput& input) {
  StepOutput out;
  if (input.measurements != nullptr && !input.measurements->paths.empty()) {
    std::vector<AgentId> peers;
    for (const auto& path : input.measurements->paths) {
      if (path.peer != setup_.id && std::find(peers.begin(), peers.end(), path.peer) == peers.end()) {
        peers.push_back(path.peer);
      }
    }
    for (const AgentId peer : peers) {
      links_[peer] = link_model(path_set(input.measurements->paths, peer, params_.los_threshold), params_);
    }
  }
  ++iteration_;
  if (setup_.anchor || input.inbox == nullptr) {
    out.outbox = published();
    return out;
  }
  Mat2 information = Mat2::Zero();
  Vec2 info_vec = Vec2::Zero();
  contributions_.clear();
  for (const auto& received : input.inbox->beliefs) {
    const auto link = links_.find(received.sender);
    if (link == links_.end()) continue;
    const BeliefMessage& b = received.message;
    std::optional<InformationPair> message;
    if (params_.exact_messages && !b.infinite_information) {
      const auto belief = cavity(b, setup_.id, params_.min_information);
      if (belief)
        message = neighbour_message(link->second, belief->mean, belief->information, false, params_);
    } else {
      message = neighbour_message(link->second, b.mean_m, b.information, b.infinite_information, params_);
    }
    if (!message) {
      ++out.diagnostics.neighbours_skipped;
      continue;
    }
    information += message->information;  // eq. (3)
    info_vec += message->info_vec;
    if (params_.exact_messages) {
      contributions_.push_back(BeliefContribution{received.sender, message->information, message->info_vec});
    }
    ++out.diagnostics.neighbours_used;
  }
  Lambda_ = information;
  if (positive_definite(information, params_.min_information)) {
    mu_ = information.ldlt().solve(info_vec);  // eq. (4)
    localized_ = true;
    out.diagnostics.updated = true;
  }
  out.outbox = published();
  return out;
}

Estimate MultipathBp::estimate() const {
  Estimate estimate;
  estimate.mean_m = mu_;
  if (setup_.anchor) {
    estimate.covariance = Mat2::Zero();
  } else if (localized_ && positive_definite(Lambda_, params_.min_information)) {
    estimate.covariance = Lambda_.inverse();
  }
  estimate.valid = setup_.anchor || localized_;
  return estimate;
}

}  // namespace swarmloc::estimators::bp
