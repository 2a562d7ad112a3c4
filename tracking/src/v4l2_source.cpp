// Live capture from V4L2 cameras: one capture thread per camera (memory-mapped driver
// buffers, few of them for low latency, driver timestamps), frame sets assembled from the
// per-camera timestamps within a tolerance, and reconnection when a device fails.
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "kumite/common/error.hpp"
#include "kumite/tracking/tracker.hpp"

namespace kumite::tracking {
namespace {

int xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do r = ::ioctl(fd, request, arg);
  while (r == -1 && errno == EINTR);
  return r;
}

std::uint32_t fourcc(const std::string& name) {
  if (name == "GREY" || name == "Y8") return V4L2_PIX_FMT_GREY;
  if (name == "Y16") return V4L2_PIX_FMT_Y16;
  if (name == "MJPG") return V4L2_PIX_FMT_MJPEG;
  if (name == "YUYV") return V4L2_PIX_FMT_YUYV;
  throw Error("camera", "format", fmt::format("unknown pixel format \"{}\"", name));
}

/// One V4L2 device, memory-mapped streaming I/O.
class V4L2Camera {
 public:
  explicit V4L2Camera(LiveCameraConfig config) : config_(std::move(config)) {}
  ~V4L2Camera() { close(); }

  /// Opens and starts streaming. Throws kumite::Error("camera", ...) with one line.
  void open() {
    close();
    const std::string& dev = config_.device;
    fd_ = ::open(dev.c_str(), O_RDWR | O_NONBLOCK);
    if (fd_ < 0) fail("cannot open {}: {}", dev, std::strerror(errno));
    v4l2_capability cap{};
    if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) < 0) fail("{}: not a V4L2 device: {}", dev, std::strerror(errno));
    const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) fail("{}: not a video capture device", dev);
    if (!(caps & V4L2_CAP_STREAMING)) fail("{}: does not support streaming I/O", dev);

    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    fmt.fmt.pix.width = static_cast<std::uint32_t>(config_.width);
    fmt.fmt.pix.height = static_cast<std::uint32_t>(config_.height);
    fmt.fmt.pix.pixelformat = fourcc(config_.pixel_format);
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    if (xioctl(fd_, VIDIOC_S_FMT, &fmt) < 0) fail("{}: cannot set the format: {}", dev, std::strerror(errno));
    if (fmt.fmt.pix.pixelformat != fourcc(config_.pixel_format) ||
        static_cast<int>(fmt.fmt.pix.width) != config_.width || static_cast<int>(fmt.fmt.pix.height) != config_.height) {
      fail("{}: the device offers {}x{} instead of {}x{} {}", dev, fmt.fmt.pix.width, fmt.fmt.pix.height,
           config_.width, config_.height, config_.pixel_format);
    }
    stride_ = static_cast<int>(fmt.fmt.pix.bytesperline);
    format_ = fmt.fmt.pix.pixelformat;

    v4l2_streamparm parm{};
    parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    parm.parm.capture.timeperframe.numerator = 1000;
    parm.parm.capture.timeperframe.denominator = static_cast<std::uint32_t>(config_.fps * 1000);
    if (xioctl(fd_, VIDIOC_S_PARM, &parm) < 0) {
      spdlog::warn("{}: cannot set {} fps: {}", dev, config_.fps, std::strerror(errno));
    }
    if (config_.exposure >= 0) {
      set_control(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL, "manual exposure");
      set_control(V4L2_CID_EXPOSURE_ABSOLUTE, config_.exposure, "exposure");
    }
    if (config_.gain >= 0) set_control(V4L2_CID_GAIN, config_.gain, "gain");

    v4l2_requestbuffers req{};
    req.count = static_cast<std::uint32_t>(config_.buffers);
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_REQBUFS, &req) < 0) fail("{}: cannot get driver buffers: {}", dev, std::strerror(errno));
    if (req.count < 1) fail("{}: the driver gave no buffers", dev);
    for (std::uint32_t i = 0; i < req.count; ++i) {
      v4l2_buffer buf{};
      buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      buf.memory = V4L2_MEMORY_MMAP;
      buf.index = i;
      if (xioctl(fd_, VIDIOC_QUERYBUF, &buf) < 0) fail("{}: cannot query buffer {}: {}", dev, i, std::strerror(errno));
      void* p = ::mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buf.m.offset);
      if (p == MAP_FAILED) fail("{}: cannot map buffer {}: {}", dev, i, std::strerror(errno));
      buffers_.push_back({p, buf.length});
      if (xioctl(fd_, VIDIOC_QBUF, &buf) < 0) fail("{}: cannot queue buffer {}: {}", dev, i, std::strerror(errno));
    }
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd_, VIDIOC_STREAMON, &type) < 0) fail("{}: cannot start streaming: {}", dev, std::strerror(errno));
    streaming_ = true;
  }

  /// Waits up to timeout_ms for a frame. Returns false on timeout; throws on device errors.
  bool read(cv::Mat& grey, Timestamp& t, int timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, timeout_ms);
    if (r < 0 && errno != EINTR) fail("{}: poll failed: {}", config_.device, std::strerror(errno));
    if (r <= 0) return false;
    if (p.revents & (POLLERR | POLLHUP | POLLNVAL)) fail("{}: device error (unplugged?)", config_.device);
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_DQBUF, &buf) < 0) {
      if (errno == EAGAIN) return false;
      fail("{}: cannot dequeue a frame: {}", config_.device, std::strerror(errno));
    }
    // Driver timestamps are CLOCK_MONOTONIC (= std::chrono::steady_clock on Linux).
    if ((buf.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC) {
      t = static_cast<double>(buf.timestamp.tv_sec) + 1e-6 * static_cast<double>(buf.timestamp.tv_usec);
    } else {
      t = kumite::now();
    }
    const bool ok = !(buf.flags & V4L2_BUF_FLAG_ERROR) && convert(buffers_[buf.index].start, buf.bytesused, grey);
    if (xioctl(fd_, VIDIOC_QBUF, &buf) < 0) fail("{}: cannot requeue a buffer: {}", config_.device, std::strerror(errno));
    return ok;
  }

  void close() {
    if (fd_ < 0) return;
    if (streaming_) {
      v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      xioctl(fd_, VIDIOC_STREAMOFF, &type);
      streaming_ = false;
    }
    for (auto& b : buffers_) ::munmap(b.start, b.length);
    buffers_.clear();
    ::close(fd_);
    fd_ = -1;
  }

  const LiveCameraConfig& config() const { return config_; }

 private:
  template <typename... Args>
  [[noreturn]] void fail(fmt::format_string<Args...> f, Args&&... args) {
    const std::string msg = fmt::format(f, std::forward<Args>(args)...);
    close();
    throw Error("camera", "device", msg);
  }

  void set_control(std::uint32_t id, int value, const char* what) {
    v4l2_control ctrl{};
    ctrl.id = id;
    ctrl.value = value;
    if (xioctl(fd_, VIDIOC_S_CTRL, &ctrl) < 0) {
      spdlog::warn("{}: cannot set {} to {}: {}", config_.device, what, value, std::strerror(errno));
    }
  }

  bool convert(const void* data, std::uint32_t bytes, cv::Mat& grey) const {
    const int w = config_.width, h = config_.height;
    void* p = const_cast<void*>(data);
    switch (format_) {
      case V4L2_PIX_FMT_GREY:
        if (bytes < static_cast<std::uint32_t>(stride_ * h)) return false;
        cv::Mat(h, w, CV_8UC1, p, static_cast<std::size_t>(stride_)).copyTo(grey);
        return true;
      case V4L2_PIX_FMT_Y16:  // little-endian 16 bit: keep the top 8 bits
        if (bytes < static_cast<std::uint32_t>(stride_ * h)) return false;
        cv::Mat(h, w, CV_16UC1, p, static_cast<std::size_t>(stride_)).convertTo(grey, CV_8U, 1.0 / 256.0);
        return true;
      case V4L2_PIX_FMT_YUYV:
        if (bytes < static_cast<std::uint32_t>(stride_ * h)) return false;
        cv::cvtColor(cv::Mat(h, w, CV_8UC2, p, static_cast<std::size_t>(stride_)), grey, cv::COLOR_YUV2GRAY_YUYV);
        return true;
      case V4L2_PIX_FMT_MJPEG:
        grey = cv::imdecode(cv::Mat(1, static_cast<int>(bytes), CV_8UC1, p), cv::IMREAD_GRAYSCALE);
        return !grey.empty() && grey.cols == w && grey.rows == h;
      default:
        return false;
    }
  }

  struct Buffer {
    void* start;
    std::size_t length;
  };
  LiveCameraConfig config_;
  int fd_ = -1;
  bool streaming_ = false;
  int stride_ = 0;
  std::uint32_t format_ = 0;
  std::vector<Buffer> buffers_;
};

class LiveSource final : public FrameSource {
 public:
  LiveSource(const RigCalibration& rig, const TrackingConfig& config)
      : tolerance_(config.frame_tolerance_s), slots_(rig.cameras.size()) {
    if (config.cameras.empty()) {
      throw Error("config", "cameras", "tracking config: --live needs [[cameras]] entries (name, device)");
    }
    double fps = 1;
    for (std::size_t i = 0; i < config.cameras.size(); ++i) {
      const LiveCameraConfig& cc = config.cameras[i];
      const CameraCalibration* cal = rig.find(cc.name);
      if (!cal) {
        throw Error("config", "cameras", fmt::format("tracking config: cameras[{}].name: \"{}\" is not a camera in the calibration", i, cc.name));
      }
      if (cal->image_width != cc.width || cal->image_height != cc.height) {
        throw Error("config", "cameras", fmt::format("tracking config: cameras[{}]: {}x{}, but camera \"{}\" is calibrated for {}x{}",
                                                     i, cc.width, cc.height, cc.name, cal->image_width, cal->image_height));
      }
      const std::size_t index = static_cast<std::size_t>(cal - rig.cameras.data());
      cameras_.push_back(std::make_unique<V4L2Camera>(cc));
      camera_index_.push_back(index);
      fps = std::max(fps, cc.fps);
    }
    period_ = 1.0 / fps;
    for (const auto& cal : rig.cameras) {
      bool configured = false;
      for (const auto& cc : config.cameras) configured = configured || cc.name == cal.name;
      if (!configured) spdlog::warn("camera \"{}\" is calibrated but has no [[cameras]] entry: no frames from it", cal.name);
    }
    // Open every camera now; the ones that fail are retried by their threads.
    std::vector<std::string> errors;
    for (std::size_t i = 0; i < cameras_.size(); ++i) {
      try {
        cameras_[i]->open();
        slots_[camera_index_[i]].open = true;
      } catch (const Error& e) {
        errors.push_back(e.what());
        slots_[camera_index_[i]].reconnecting = true;
      }
    }
    if (errors.size() == cameras_.size()) {
      throw Error("camera", "device", errors.size() == 1 ? errors[0]
                                                        : fmt::format("{} (and {} more cameras failed)", errors[0], errors.size() - 1));
    }
    for (const auto& e : errors) spdlog::warn("{} (retrying)", e);
    for (std::size_t i = 0; i < cameras_.size(); ++i) threads_.emplace_back([this, i] { capture(i); });
  }

  ~LiveSource() override { close(); }

  bool next(FrameSet& out, double timeout_s) override {
    std::unique_lock lock(mutex_);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
      if (closed_) return false;
      int pending = 0, active = 0;
      Timestamp newest = -1, first_arrival = 1e300;
      for (const auto& s : slots_) {
        active += s.open && !s.reconnecting;
        if (s.pending) {
          ++pending;
          newest = std::max(newest, s.time);
          first_arrival = std::min(first_arrival, s.arrival);
        }
      }
      // Complete, or waited long enough for the stragglers (they join the next set).
      const bool complete = pending > 0 && pending >= active;
      const bool waited = pending > 0 && kumite::now() - first_arrival > std::max(tolerance_, 0.5 * period_);
      if (complete || waited) {
        out.frame = frame_++;
        out.timestamp = newest;
        out.images.assign(slots_.size(), cv::Mat());
        out.camera_times.assign(slots_.size(), newest);
        for (std::size_t c = 0; c < slots_.size(); ++c) {
          auto& s = slots_[c];
          if (!s.pending) continue;
          s.pending = false;
          if (newest - s.time > tolerance_) continue;  // too old for this set: dropped
          out.images[c] = std::move(s.image);
          out.camera_times[c] = s.time;
        }
        return true;
      }
      if (cv_.wait_until(lock, deadline) == std::cv_status::timeout) return false;
    }
  }

  bool end_of_stream() const override { return closed_; }

  bool reconnecting(std::size_t camera) const override {
    std::lock_guard lock(mutex_);
    return camera < slots_.size() && slots_[camera].reconnecting;
  }

  void close() override {
    {
      std::lock_guard lock(mutex_);
      if (closed_) return;
      closed_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_) t.join();
    threads_.clear();
  }

 private:
  void capture(std::size_t i) {
    V4L2Camera& cam = *cameras_[i];
    const std::size_t c = camera_index_[i];
    cv::Mat grey;
    while (!is_closed()) {
      if (reconnecting(c)) {
        try {
          cam.open();
          std::lock_guard lock(mutex_);
          slots_[c].reconnecting = false;
          slots_[c].open = true;
          spdlog::info("{}: camera \"{}\" is back", cam.config().device, cam.config().name);
        } catch (const Error&) {
          for (int k = 0; k < 10 && !is_closed(); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(100));
          continue;
        }
      }
      try {
        Timestamp t = 0;
        if (!cam.read(grey, t, 100)) continue;
        {
          std::lock_guard lock(mutex_);
          auto& s = slots_[c];
          s.image = grey.clone();
          s.time = t;
          s.arrival = kumite::now();
          s.pending = true;
        }
        cv_.notify_one();
      } catch (const Error& e) {
        spdlog::warn("{}: reconnecting", e.what());
        cam.close();
        std::lock_guard lock(mutex_);
        slots_[c].reconnecting = true;
      }
    }
    cam.close();
  }

  bool is_closed() const {
    std::lock_guard lock(mutex_);
    return closed_;
  }

  struct Slot {
    cv::Mat image;
    Timestamp time = 0, arrival = 0;
    bool pending = false;
    bool open = false;
    bool reconnecting = false;
  };
  double tolerance_;
  double period_ = 1.0 / 60;
  std::vector<std::unique_ptr<V4L2Camera>> cameras_;
  std::vector<std::size_t> camera_index_;
  std::vector<std::thread> threads_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<Slot> slots_;
  bool closed_ = false;
  std::uint64_t frame_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> open_live_source(const RigCalibration& rig, const TrackingConfig& config) {
  return std::make_unique<LiveSource>(rig, config);
}

}  // namespace kumite::tracking
