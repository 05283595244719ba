#pragma once
// Subset-first weighing of a large particle set: every particle is weighed on a few of the scan's points first,
// scaled to the whole scan, and only the best-scoring share then on all of them. The rest keep their scaled
// estimates: the same likelihood from fewer points, for particles whose tempered weight is small either way. In a
// global search three passes: fewer points first, the best share on more (a middle pass), and only the best of
// those on the whole scan. A later pass weighs only the points the earlier ones lacked and adds, so each point is
// weighed once per particle. A global belief of 100k particles on 512 points then needs about a seventh of the
// evaluations of the whole scan (docs/sensor-update.md, "Fewer evaluations"). Works on any SensorEvaluator:
// passes without the reduction (SensorEvaluator::weigh), each over its particles gathered into the spare set; the
// reduction runs on the host over the combined log-weights.
#include <cstdint>
#include <vector>

#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

struct SubsetFirstOptions {
  std::size_t points = 64;  // the first pass's points, every k-th of the scan (0 = off)
  double share = 0.2;       // of the particles, weighed past the first pass
  // A global search (weigh()'s `global_search`: a belief spread over the map, mostly particles at wrong places)
  // takes three passes: every particle on `global_points`, the `share` on `middle_points` (those of the first pass
  // and more, spread the same way), and only the best `whole_share` of all particles (at most `share`) on the whole
  // scan. Not within one place (a local start, a belief that has concentrated): there the first pass's few points
  // rank particles by their noise, and a wrong lock of 20,000 particles stayed spread (and unquestioned) 3-4 times
  // as long (GlobalSearch.AbandonsAForcedWrongLock). No middle pass where middle_points <= global_points or more
  // than half the scan.
  std::size_t global_points = 32;
  std::size_t middle_points = 128;
  double whole_share = 0.05;
  std::size_t min_particles = 20000;  // smaller sets are weighed on the whole scan: their map reads are cached
  // Also on a discrete GPU (SensorEvaluator::discrete_gpu)? Off: there the whole scan of 100k particles takes
  // 0.7 ms and the two passes, with the host's selection between them, 4.8 ms (NVIDIA H200, docs/sensor-update.md).
  bool on_discrete_gpu = false;
  void validate() const;
};

class SubsetFirstWeighing {
 public:
  explicit SubsetFirstWeighing(const SubsetFirstOptions& options = {});

  // Whether weigh() takes two passes for n particles and this scan and model (only the product likelihood: its
  // log-weight scales with the point count) on `evaluator`.
  bool applies(std::size_t n, std::size_t points, const EndpointModel& model, const SensorEvaluator& evaluator) const;

  // Log-weights of the evaluator's particles 0..n-1 (particles().log_weight), on the scale of the whole scan, and
  // the reduction over all of them (reduce_weights on the host when two passes ran). The spare set is
  // overwritten. `timings`: the passes' GPU and upload times summed, evaluate_ms the whole weighing.
  WeightSummary weigh(SensorEvaluator& evaluator, std::size_t n, const std::vector<Eigen::Vector3f>& points,
                      const EndpointModel& model, const Eigen::Quaternionf& reference, UpdateTimings* timings,
                      bool global_search = false);

  // The particles the last weigh() of more than one pass weighed on the whole scan, ascending.
  const std::vector<std::uint32_t>& refined() const { return refined_; }
  // Those its middle pass weighed (none without one), ascending; refined() is a subset of them.
  const std::vector<std::uint32_t>& middle() const { return middle_; }

 private:
  // Weighs particles `chosen` (ascending) of the evaluator's set on `points` with `model`, in the spare set
  // (gathered in particle order, so their map reads keep the set's locality); their log-weights are then the
  // spare set's 0..chosen.size()-1. Adds the pass's times to `sum`.
  void weigh_chosen(SensorEvaluator& evaluator, const std::vector<std::uint32_t>& chosen,
                    const std::vector<Eigen::Vector3f>& points, const EndpointModel& model, UpdateTimings& sum);

  // Which pass first weighs each of m points (pass_of_point_): the first's, the middle's (where there is one), the
  // rest.
  void assign_passes(std::size_t m, bool middle);
  // The points of one pass into subset_; returns how many.
  std::size_t points_of_pass(const std::vector<Eigen::Vector3f>& points, std::uint8_t pass);
  // A global search's middle pass over middle_ and then the rest of the scan over the best of them (refined_).
  void weigh_middle_and_rest(SensorEvaluator& evaluator, std::size_t n, const std::vector<Eigen::Vector3f>& points,
                             const EndpointModel& model, std::size_t first, UpdateTimings& sum);

  SubsetFirstOptions options_;
  std::vector<std::uint32_t> refined_;
  std::vector<std::uint32_t> middle_;
  std::vector<std::uint8_t> pass_of_point_;
  std::vector<Eigen::Vector3f> subset_;
};

}  // namespace tsdf_mcl
