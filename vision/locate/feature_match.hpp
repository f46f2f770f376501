// Shared pieces of the ORB feature methods (orb-ransac, orb-prosac, orb-adk; papers 000/001):
// ORB detection, paper 001's bidirectional FLANN matching, the grasp point and angle from a
// homography (paper 001, eq. 15), and the loop that finds several parts per image.
// Internal to vision/locate (not part of the public locator contract). Pure image code: an
// instance of anything here is used by one thread at a time.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "core/result.hpp"
#include "vision/locate/locator.hpp"
#include "vision/locate/params.hpp"

namespace vgr::vision::detail {

struct FeatureSearch;

// The part of the image a job searches: TaughtTemplate::searchRoi clipped to the image, or
// the whole image when the ROI is empty.
cv::Rect searchRect(const cv::Mat& gray, const TaughtTemplate& taught);

// ORB (FAST-9 corners ranked by the Harris response of paper 000 eq. 1 / paper 001 eq. 9,
// rotated BRIEF descriptors).
struct OrbParams {
  int templateFeatures = 1500;  // [50, 20000] keypoints kept in the template
  int imageFeatures = 6000;     // [50, 50000] keypoints kept in the searched image
  double scaleFactor = 1.2;     // (1, 2] pyramid step
  int levels = 3;               // [1, 8] pyramid levels (parts are seen at one scale)
  int fastThreshold = 20;       // [1, 100] FAST-9 gray-level difference (eps_d of paper 001 eq. 9)
};
void readOrbParams(ParamReader& r, OrbParams& p);

struct FeatureSearch;
// The job's scale range (TaughtTemplate::scaleMin/scaleMax) for an ORB method: the accepted
// scales, and enough pyramid levels that the template's features at one end of the range
// meet the image's at the other (ORB pairs features of about the same size: a part seen at
// scale s matches template level log(1/s) / log(scaleFactor) against image level 0, or
// image level log(s) / log(scaleFactor) against template level 0).
void applyScaleRange(const TaughtTemplate& taught, OrbParams& orb, FeatureSearch& search);

struct Features {
  std::vector<cv::KeyPoint> keypoints;  // px, in the coordinates of the image given
  cv::Mat descriptors;                  // CV_8U, 32 bytes per row
};
Features detectOrb(const cv::Mat& gray, const cv::Mat& mask, int nFeatures, const OrbParams& p);

// One template -> image correspondence: indices into the template's and the image's
// Features, and the Hamming distance of their descriptors.
struct Match {
  int t = 0, i = 0;
  float distance = 0;
};

// Paper 001, section 4.2: FLANN nearest neighbours (LSH index: ORB descriptors are binary,
// so Hamming distance stands in for the Euclidean distance of eq. 10) from the template to
// the image and back; in each direction a pair is kept when its distance D < T = mu * minD
// (minD over that direction, floored at minDFloor so that an exact duplicate, D = 0, does
// not reject everything else); then only pairs found in both directions are kept (the
// symmetric check). `alive` masks image keypoints already given to an earlier part.
// Result sorted by distance, best first (the order PROSAC needs).
std::vector<Match> matchBidirectional(const Features& tmpl, const Features& img, const std::vector<char>& alive,
                                      double mu, double minDFloor);
// The plain alternative (FeatureSearch::symmetric = false): each template keypoint's FLANN
// nearest neighbour among the free image keypoints, no distance gate, no symmetric check.
std::vector<Match> matchNearest(const Features& tmpl, const Features& img, const std::vector<char>& alive);

// Paper 001, eq. (15): the template's grasp point through the homography H (template px ->
// image px), the rotation of H at that point, counter-clockwise as displayed, in
// (-180, 180], and its scale there (sqrt of the Jacobian's determinant, Detection::scale;
// locateFeatureParts reports the job's scale instead for a job without a scale range).
// Returns false when H is degenerate there (w ~ 0, a mirror) or its scale is outside
// [minScale, maxScale].
bool poseFromHomography(const cv::Matx33d& H, PixelPoint grasp, double minScale, double maxScale, Detection& out);

// What a method's filter returns for one part: the homography template -> image and the
// correspondences it accepted (a subset of the candidates it was given).
struct PartFit {
  cv::Matx33d H;
  std::vector<Match> accepted;
  // Image keypoints (indices) this fit used up even if it is rejected (e.g. PROSAC's inliers
  // when ADK's cluster is too small), so the next round looks elsewhere.
  std::vector<int> consumed;
  // Matches that show the part is there, for its score: the fit's inliers; for orb-adk
  // PROSAC's inliers (ADK's cluster, which gives the pose, holds one height level's
  // matches of a multi-height part and would score it as a fraction of a part).
  std::size_t support = 0;
};
// One robust homography over the candidates' keypoint pairs (template -> image) with
// cv::findHomography's `robust` method (cv::RANSAC, cv::USAC_PROSAC: the candidates arrive
// best first, PROSAC's "sorted by similarity" order, paper 001 section 4.2). `accepted` are
// the inliers in candidate order. Empty when fewer than 4 candidates or no fit.
std::optional<PartFit> robustHomography(const std::vector<Match>& candidates, const Features& tmpl,
                                        const Features& img, int robust, double thresholdPx, int maxIters,
                                        double confidence);

// candidates index into tmpl's and img's keypoints.
using FitFn = std::function<std::optional<PartFit>(const std::vector<Match>& candidates, const Features& tmpl,
                                                    const Features& img)>;

struct FeatureSearch {
  std::string method;      // for messages
  double mu = 5;           // paper 001: T = mu * minD
  double minDFloor = 8;    // Hamming bits
  int minInliers = 12;     // fewer accepted matches: not a part
  // Scales accepted (poseFromHomography): the job's range [scaleMin, scaleMax] widened by the
  // factor maxScale ("max_scale", the fit's tolerance), so a fixed-scale job takes
  // [1 / maxScale, maxScale]: parts on a conveyor are seen at one scale.
  double maxScale = 1.25;
  double scaleMin = 1, scaleMax = 1;  // TaughtTemplate::scaleMin/scaleMax (applyScaleRange)
  double fullScoreInliers = 0;  // accepted matches that score 1 (set at teach time)
  bool symmetric = true;   // paper 001's coarse stage; false = plain nearest neighbour template -> image
};

// The one the search asks for.
std::vector<Match> coarseMatches(const Features& tmpl, const Features& img, const std::vector<char>& alive,
                                 const FeatureSearch& search);

// The teach-time reference for the score: half the matches the method's own pipeline
// accepts between the template and a copy of itself turned by 30 degrees with sensor noise
// (sigma 5). Errors name the method when the template has too few features to find itself.
Result<double> selfMatchInliers(const cv::Mat& templateGray, const Features& tmpl, const OrbParams& orb,
                                const FeatureSearch& search, const FitFn& fit);

// Several parts per image: detect ORB once in the search ROI, then repeat {match the
// template against the image keypoints not yet taken, fit, accept} until maxParts parts
// are found or the fit fails; after each fit the image keypoints inside the template's
// outline (its keypoints' convex hull through H) are taken away; a fit whose grasp point lies
// within half the outline's radius of an earlier part's is the same part again and dropped.
// score = accepted matches / fullScoreInliers, clipped to [0, 1]. LocateOutput::matches are the best part's accepted
// matches, candidateMatches the candidates that part was fitted from.
Result<LocateOutput> locateFeatureParts(const cv::Mat& gray, const TaughtTemplate& taught, const Features& tmpl,
                                        const std::vector<cv::Point2f>& templateHull, const OrbParams& orb,
                                        const FeatureSearch& search, const FitFn& fit);

// The convex hull of the template's keypoints (template px).
std::vector<cv::Point2f> keypointHull(const Features& f);

}  // namespace vgr::vision::detail
