# Every third-party dependency, found once here (all from Debian 12 packages: see
# scripts/setup.sh). Modules link the imported targets below.
find_package(Threads REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(spdlog REQUIRED)        # compiled spdlog::spdlog (not header-only)
find_package(fmt REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(TinyGLTF 2.7 REQUIRED CONFIG)  # glTF 2.0 bodies (body/); Debian's build, without Draco
find_package(PkgConfig REQUIRED)
pkg_check_modules(TOMLPP REQUIRED IMPORTED_TARGET tomlplusplus)
find_package(Boost 1.74 REQUIRED)     # header-only boost::lockfree (app_core: the recognition thread's queues)
find_package(ZLIB REQUIRED)           # session recordings: states.bin records (app_core)
find_package(OpenCV 4.6 REQUIRED COMPONENTS core imgproc imgcodecs calib3d features2d aruco)
find_package(apriltag REQUIRED)
find_package(Ceres 2.1 REQUIRED)
find_package(glm REQUIRED)
find_package(glfw3 3.3 REQUIRED)
find_package(OpenGL REQUIRED COMPONENTS OpenGL EGL)
pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)
pkg_check_modules(SYSTEMD REQUIRED IMPORTED_TARGET libsystemd)
# libyaml: a calibration file is parsed by it before OpenCV's FileStorage, whose YAML parser
# (4.6) loops forever on some malformed files (found by fuzzing, one pattern after another).
pkg_check_modules(LIBYAML REQUIRED IMPORTED_TARGET yaml-0.1)  # sd_notify: readiness and watchdog (app)
# liblo (OSC over UDP): tracking_interop's OSC in and out (Debian liblo-dev 0.31).
pkg_check_modules(LIBLO REQUIRED IMPORTED_TARGET liblo)
if(KUMITE_BUILD_TESTS)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()
if(KUMITE_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
