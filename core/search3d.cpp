#include "core/search3d.hpp"

namespace vgr {

#define VGR_KEY(name, field, lo, hi, integer)                                                                       \
  Search3dKey {                                                                                                    \
    name, lo, hi, integer, [](const Search3dParams& p) { return static_cast<double>(p.field); },                   \
        [](Search3dParams& p, double v) { p.field = static_cast<decltype(p.field)>(v); }                           \
  }

const std::vector<Search3dKey>& search3dKeys() {
  static const std::vector<Search3dKey> keys{
      VGR_KEY("voxel_mm", voxelMm, 0.5, 50, false),
      VGR_KEY("n_r", nRotations, 1, 36, true),
      VGR_KEY("f_l", fLow, 0, 1, false),
      VGR_KEY("f_h", fHigh, 0, 1, false),
      VGR_KEY("max_parts", maxParts, 1, 64, true),
      VGR_KEY("plane_distance_mm", planeDistanceMm, 0.1, 50, false),
      VGR_KEY("plane_min_share", planeMinShare, 0, 1, false),
      VGR_KEY("feature_radius_mm", featureRadiusMm, 1, 200, false),
      VGR_KEY("model_views", modelViews, 0, 500, true),
      VGR_KEY("cluster_mm", clusterMm, 0, 100, false),
      VGR_KEY("feature_neighbours", featureNeighbours, 1, 10, true),
      VGR_KEY("ransac_iterations", ransacIterations, 100, 10000000, true),
      VGR_KEY("ransac_confidence", ransacConfidence, 1e-6, 1, false),
      VGR_KEY("ransac_distance_mm", ransacDistanceMm, 0.5, 100, false),
      VGR_KEY("edge_similarity", edgeSimilarity, 0, 0.999, false),
      VGR_KEY("hypotheses_per_copy", hypothesesPerCopy, 1, 20, true),
      VGR_KEY("icp_distance_mm", icpDistanceMm, 0.2, 50, false),
      VGR_KEY("icp_iterations", icpIterations, 1, 1000, true),
      VGR_KEY("fitness_distance_mm", fitnessDistanceMm, 0.2, 50, false),
      VGR_KEY("max_contradiction", maxContradiction, 0, 1, false),
      VGR_KEY("retry_min_fitness", retryMinFitness, 0, 1, false),
      VGR_KEY("max_below_plane_mm", maxBelowPlaneMm, 0, 1000, false),
      VGR_KEY("visible_max_angle_deg", visibleMaxAngleDeg, 1, 89, false),
      VGR_KEY("threads", threads, 1, 64, true),
  };
  return keys;
}

#undef VGR_KEY

std::string search3dCrossCheck(const Search3dParams& p) {
  if (p.fHigh < p.fLow) return "f_h: must not be below f_l";
  if (p.retryMinFitness > p.fLow) return "retry_min_fitness: must not be above f_l";
  const auto& r = p.roi;
  if (!(r.xMin < r.xMax)) return "roi: x_min must be below x_max";
  if (!(r.yMin < r.yMax)) return "roi: y_min must be below y_max";
  if (!(r.zMin < r.zMax)) return "roi: z_min must be below z_max";
  if (!(r.zMax > 0)) return "roi: z_max must be above 0 mm (in front of the camera)";
  return "";
}

}  // namespace vgr
