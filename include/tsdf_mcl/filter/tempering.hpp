#pragma once
// Adaptive tempering: the weights of an update, exp(prior + beta * log-likelihood), with the largest beta in
// (0, 1] that leaves an effective sample size of at least a target. A global belief's log-likelihoods differ by
// hundreds between particles, and beta = 1 would hand all weight to a few of them before the scan has told the
// right place from its look-alikes; tempering lets the evidence sharpen over several scans instead.
#include <cstddef>

namespace tsdf_mcl {

struct Tempering {
  double beta = 1.0;    // the factor applied to the log-likelihoods
  double ess = 0.0;     // the effective sample size of the weights written
  int evaluations = 0;  // weight sets evaluated to find beta (for tests and benchmarks)
};

// Writes w[i] = exp(prior[i] + beta * l[i] - max) and returns beta and the weights' ESS. beta = 1 where the ESS
// there is at least `target_ess`; otherwise the largest beta in [1e-7, 1) found to keep it, to a relative
// precision of 2.5e-4 in beta or 1e-3 in the ESS (1e-7 where even that falls short). The sums run in
// fixed-size chunks combined in order: the result does not depend on the thread count.
Tempering temper(const double* prior, const float* l, std::size_t n, double target_ess, double* w);

// The ESS of exp(prior + beta * l) (the same sums as temper(); nothing written).
double tempered_ess(const double* prior, const float* l, std::size_t n, double beta);

}  // namespace tsdf_mcl
