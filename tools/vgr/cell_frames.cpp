#include "tools/vgr/cell_frames.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include <fmt/core.h>

#include "daemon/job_locator.hpp"
#include "drivers/camera.hpp"
#include "drivers/camera_worker.hpp"
#include "vision/gray_image.hpp"

namespace vgr::tools {

Result<std::vector<cv::Mat>> grabCellFrames(const config::CellConfig& cell, int count) {
  auto made = drivers::makeCamera(cell.camera);
  if (!made) return std::unexpected(made.error());
  // Open once in the foreground: a camera held by vgrd or misconfigured is a clear error.
  if (auto r = (*made)->open(); !r)
    return fail(r.error().code, r.error().message + " (is vgrd running? it holds the camera: stop it, or pass --image files)");
  (*made)->close();
  drivers::CameraWorker worker(cell.camera, std::move(*made));
  worker.start();
  if (!worker.waitStreaming(std::chrono::milliseconds(15000))) {
    worker.stop();
    return fail(Status::CameraError, worker.describe() + ": not streaming after 15 s");
  }
  std::vector<cv::Mat> frames;
  drivers::Frame frame;
  for (int i = 0; i < count; ++i) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(cell.cycleDeadlineMs);
    if (auto r = worker.grab(frame, deadline); !r) {
      worker.stop();
      return fail(Status::CameraError, fmt::format("frame {} of {}: {}", i + 1, count, r.error().message));
    }
    cv::Mat gray;
    const cv::Mat samples(frame.height, frame.width, frame.bytesPerPixel() == 2 ? CV_16UC1 : CV_8UC1, frame.data.data());
    if (frame.bytesPerPixel() == 2) vision::toGray8(samples, frame.bitDepth, gray);
    else gray = samples.clone();
    frames.push_back(std::move(gray));
  }
  worker.stop();
  return frames;
}

Result<std::vector<cv::Mat>> readFrames(const std::vector<std::string>& pathsOrGlobs, std::vector<std::string>* names) {
  std::vector<std::string> paths;
  for (const auto& p : pathsOrGlobs) {
    if (p.find_first_of("*?[") == std::string::npos) {
      paths.push_back(p);
      continue;
    }
    std::vector<cv::String> found;
    try {
      cv::glob(p, found, false);
    } catch (const cv::Exception&) {  // a folder that does not exist
      found.clear();
    }
    if (found.empty()) return fail(Status::BadArgument, p + ": no file matches");
    std::vector<std::string> sorted(found.begin(), found.end());
    std::sort(sorted.begin(), sorted.end());
    paths.insert(paths.end(), sorted.begin(), sorted.end());
  }
  if (paths.empty()) return fail(Status::BadArgument, "no image given");
  std::vector<cv::Mat> frames;
  for (const auto& p : paths) {
    auto img = vision::readGray8(p);
    if (!img) return std::unexpected(img.error());
    frames.push_back(std::move(*img));
    if (names) names->push_back(std::filesystem::path(p).filename().string());
  }
  return frames;
}

Result<CellJob> makeCellJob(const config::CellConfig& cell, int jobId) {
  const config::JobConfig* job = jobId == 0 ? (cell.jobs.empty() ? nullptr : &cell.jobs.front()) : cell.findJob(jobId);
  if (!job) return fail(Status::JobNotFound, fmt::format("{}: no job {}", cell.sourcePath, jobId));
  CellJob out;
  out.id = job->id;
  auto loc = daemon::makeJobLocator(*job);
  if (!loc) return std::unexpected(loc.error());
  out.locator = std::move(*loc);
  // As CycleRunner::prepareJobs makes them.
  out.rules.heightMm = job->partHeightMm;
  out.rules.angleOffsetDeg = job->angleOffsetDeg;
  out.rules.reference = poseFromXyzRz(job->reference.x, job->reference.y, job->reference.z, job->reference.rzDeg * M_PI / 180);
  return out;
}

Result<std::vector<PartResult>> locateParts(CellJob& job, const vision::calib::PixelMapping& mapping, const cv::Mat& gray) {
  if (const auto size = mapping.imageSize(); size && (gray.cols != size->width || gray.rows != size->height))
    return fail(Status::NotCalibrated, fmt::format("the calibration is for {}x{} px, the frame is {}x{} px", size->width,
                                                   size->height, gray.cols, gray.rows));
  auto found = job.locator->locate(gray);
  if (!found) return std::unexpected(found.error());
  return vision::partPoses(found->parts, mapping, job.rules);
}

}  // namespace vgr::tools
