# Third-party dependencies, all from Debian bookworm packages (scripts/install-deps.sh).
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
# dnn: the grasp network (vision/grasp/ggcnn_detector.cpp) runs from ONNX through cv::dnn.
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs features2d flann calib3d aruco ml dnn)
find_package(yaml-cpp REQUIRED)
find_package(spdlog REQUIRED)
find_package(fmt REQUIRED)
find_package(Boost 1.74 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
pkg_check_modules(ARAVIS REQUIRED IMPORTED_TARGET aravis-0.8)
pkg_check_modules(MODBUS REQUIRED IMPORTED_TARGET libmodbus)
pkg_check_modules(SYSTEMD REQUIRED IMPORTED_TARGET libsystemd)
# vgrd's plant interfaces (docs/plant.md): prometheus-cpp's core library only (its text
# serializer behind our own Beast server, not prometheus-cpp-pull), and libmosquitto.
find_package(prometheus-cpp REQUIRED CONFIG)  # Debian 1.0.1; its config file has no version
pkg_check_modules(MOSQUITTO REQUIRED IMPORTED_TARGET libmosquitto)

# OpenCV's config exports include dirs, not SYSTEM targets: wrap them so -Werror stays on our code.
add_library(vgr_opencv INTERFACE)
target_include_directories(vgr_opencv SYSTEM INTERFACE ${OpenCV_INCLUDE_DIRS})
target_link_libraries(vgr_opencv INTERFACE opencv_core opencv_imgproc opencv_imgcodecs opencv_features2d opencv_flann opencv_calib3d)
# 3D (paper 004, docs/3d.md): Open3D 0.16 from Debian's libopen3d-dev, linked by vision/cloud/
# alone (privately; its headers are in one translation unit there), and OpenMP to bound its
# threads.
find_package(Open3D REQUIRED CONFIG)
find_package(OpenMP REQUIRED COMPONENTS CXX)
# nanoflann (Debian libnanoflann-dev, header-only): the exact 3-D k-d tree of the 3D locator's
# ICP (vision/cloud/open3d_backend.cpp IcpTarget, docs/3d.md "Speed"): fixed 3 dimensions and a
# distance bound per query, which Open3D's KDTreeFlann (dynamic dimension, no bound) lacks.
find_package(nanoflann REQUIRED CONFIG)
