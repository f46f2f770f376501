// vision/cloud/ppf.hpp (Drost et al. 2010 point-pair-feature voting): on a part's points seen
// from one side, moved by a known pose, the most voted reference peaks give that pose.
#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "sim/depth_parts.hpp"
#include "vision/cloud/cloud_math.hpp"
#include "vision/cloud/ppf.hpp"

namespace {
using namespace vgr;
using V3 = Eigen::Vector3d;

TEST(PpfModel, VotesForTheTruePoseOfAMovedPartialView) {
  for (const char* name : {"bracket", "housing", "lever"}) {
    auto part = sim::depthPart(name);
    ASSERT_TRUE(part.has_value());
    std::vector<V3> pts, nrm;
    for (const auto& s : sim::sampleSurface(*part, 3.0)) {
      pts.emplace_back(s.x, s.y, s.z);
      nrm.emplace_back(s.nx, s.ny, s.nz);
    }
    const vision::cloud::PpfModel model(pts, nrm, 3.2, 12, 30, 150, 3.0);  // the locator's settings
    EXPECT_GT(model.pairs(), pts.size());
    // The scene: the points facing a camera looking along +z of the moved part.
    Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
    truth.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(2.0, V3(0.3, -0.5, 0.8).normalized())).toRotationMatrix();
    truth.topRightCorner<3, 1>() = V3(40, -25, 520);
    std::vector<V3> sp, sn;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const V3 p = (truth * pts[i].homogeneous()).head<3>(), n = truth.topLeftCorner<3, 3>() * nrm[i];
      if (n.dot(-p.normalized()) > 0.3) sp.push_back(p), sn.push_back(n);
    }
    ASSERT_GT(sp.size(), 50u) << name;
    const auto votes = model.match(sp, sn, 2);
    ASSERT_FALSE(votes.empty());
    int best = 0, right = 0;
    for (const auto& v : votes) {
      best = std::max(best, v.votes);
      const bool near = vision::cloud::translationErrorMm(v.sceneFromModel, truth) < 5 && vision::cloud::rotationErrorDeg(v.sceneFromModel, truth) < 8;
      right += near;
    }
    // Most references see the right pose; the most voted one is right.
    EXPECT_GT(right, static_cast<int>(votes.size()) / 2) << name;
    for (const auto& v : votes)
      if (v.votes == best) {
        EXPECT_LT(vision::cloud::translationErrorMm(v.sceneFromModel, truth), 5) << name;
        EXPECT_LT(vision::cloud::rotationErrorDeg(v.sceneFromModel, truth), 8) << name;
        break;
      }
  }
}

}  // namespace
