/// @file v4l2_source.cpp
/// @brief V4L2Source and the V4L2 device listing (the only file including linux/videodev2.h).
#include "capture/v4l2_source.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>

#include "capture/device_claim.h"

namespace aoscan {
namespace {

constexpr std::uint32_t kZ16 = v4l2_fourcc('Z', '1', '6', ' ');
constexpr int kBufferCount = 4;
constexpr int kFrameTimeoutMs = 2000;

/// ioctl that retries when interrupted by a signal.
int xioctl(int fd, unsigned long request, void* arg) {
  int rc;
  do {
    rc = ::ioctl(fd, request, arg);
  } while (rc < 0 && errno == EINTR);
  return rc;
}

std::string errno_text() {
  return std::strerror(errno);
}

std::string fourcc_text(std::uint32_t f) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((f >> (8 * i)) & 0xff);
    s += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  return s;
}

/// Owns a file descriptor.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

class V4l2Source : public LiveMillimetreSource {
 public:
  V4l2Source(const std::string& uri, const std::string& node) : LiveMillimetreSource(uri) {
    try {
      start(uri, node);
    } catch (...) {
      release();  // the destructor does not run for a half-built object
      throw;
    }
  }

  ~V4l2Source() override { release(); }

 private:
  void start(const std::string& uri, const std::string& node) {
    std::error_code ec;
    std::filesystem::path canonical = std::filesystem::weakly_canonical(node, ec);
    claim_ = DeviceClaim("v4l2:" + (ec ? node : canonical.string()), uri);

    fd_ = std::make_unique<Fd>(::open(node.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC));
    if (fd_->get() < 0) {
      if (errno == EBUSY) throw device_error(uri + ": busy: another program holds the camera");
      throw device_error(uri + ": cannot open: " + errno_text());
    }
    const int fd = fd_->get();
    v4l2_capability cap{};
    if (xioctl(fd, VIDIOC_QUERYCAP, &cap) < 0)
      throw device_error(uri + ": not a V4L2 device (VIDIOC_QUERYCAP: " + errno_text() + ")");
    const std::uint32_t caps =
        (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) throw device_error(uri + ": not a video capture device");
    if (!(caps & V4L2_CAP_STREAMING))
      throw device_error(uri + ": the driver does not support streaming I/O");

    // Z16 must be on offer; list what is there otherwise.
    bool has_z16 = false;
    std::string offered;
    v4l2_fmtdesc desc{};
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    for (desc.index = 0; xioctl(fd, VIDIOC_ENUM_FMT, &desc) == 0; ++desc.index) {
      has_z16 = has_z16 || desc.pixelformat == kZ16;
      offered += (offered.empty() ? "" : ", ") + fourcc_text(desc.pixelformat);
    }
    if (!has_z16)
      throw device_error(uri + ": no Z16 depth format (offers: " +
                         (offered.empty() ? std::string("none") : offered) + ")");

    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    fmt.fmt.pix.width = 640;
    fmt.fmt.pix.height = 480;
    fmt.fmt.pix.pixelformat = kZ16;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    if (xioctl(fd, VIDIOC_S_FMT, &fmt) < 0) {
      if (errno == EBUSY) throw device_error(uri + ": busy: another program is streaming from it");
      throw device_error(uri + ": VIDIOC_S_FMT Z16 failed: " + errno_text());
    }
    if (fmt.fmt.pix.pixelformat != kZ16)
      throw device_error(uri + ": the driver replaced Z16 by " +
                         fourcc_text(fmt.fmt.pix.pixelformat));
    width_ = static_cast<int>(fmt.fmt.pix.width);
    height_ = static_cast<int>(fmt.fmt.pix.height);
    bytes_per_line_ =
        static_cast<int>(std::max<std::uint32_t>(fmt.fmt.pix.bytesperline, 2 * fmt.fmt.pix.width));
    intrinsics_.width = width_;
    intrinsics_.height = height_;
    intrinsics_.fx = intrinsics_.fy = 525.0 * width_ / 640.0;
    intrinsics_.cx = (width_ - 1) * 0.5;
    intrinsics_.cy = (height_ - 1) * 0.5;

    v4l2_streamparm parm{};  // 30 Hz if the driver lets us choose; not an error otherwise
    parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    parm.parm.capture.timeperframe.numerator = 1;
    parm.parm.capture.timeperframe.denominator = 30;
    xioctl(fd, VIDIOC_S_PARM, &parm);

    v4l2_requestbuffers req{};
    req.count = kBufferCount;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd, VIDIOC_REQBUFS, &req) < 0) {
      if (errno == EBUSY) throw device_error(uri + ": busy: another program is streaming from it");
      throw device_error(uri + ": VIDIOC_REQBUFS failed: " + errno_text());
    }
    if (req.count < 2) throw device_error(uri + ": the driver granted too few buffers");
    for (std::uint32_t i = 0; i < req.count; ++i) {
      v4l2_buffer buf{};
      buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      buf.memory = V4L2_MEMORY_MMAP;
      buf.index = i;
      if (xioctl(fd, VIDIOC_QUERYBUF, &buf) < 0)
        throw device_error(uri + ": VIDIOC_QUERYBUF failed: " + errno_text());
      void* p = ::mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, buf.m.offset);
      if (p == MAP_FAILED) throw device_error(uri + ": mmap failed: " + errno_text());
      buffers_.push_back({p, buf.length});
      if (xioctl(fd, VIDIOC_QBUF, &buf) < 0)
        throw device_error(uri + ": VIDIOC_QBUF failed: " + errno_text());
    }
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd, VIDIOC_STREAMON, &type) < 0)
      throw device_error(uri + ": VIDIOC_STREAMON failed: " + errno_text());
    streaming_ = true;
  }

 public:
  Status read(DepthFrame& frame) override {
    if (!lost_.empty()) return Status::device_lost(lost_);
    const int fd = fd_->get();
    pollfd pfd{fd, POLLIN, 0};
    // Short polls up to the frame timeout, so that a stop request is seen at once.
    int rc = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kFrameTimeoutMs);
    while (std::chrono::steady_clock::now() < deadline) {
      if (stop_requested()) return Status::end_of_stream();
      rc = ::poll(&pfd, 1, static_cast<int>(kStopPollInterval.count()));
      if (rc < 0 && errno == EINTR) rc = 0;
      if (rc != 0) break;
    }
    if (rc == 0) return lose(name_ + ": no frame for 2 s (unplugged?)");
    if (rc < 0) return lose(name_ + ": poll failed: " + errno_text());
    if (pfd.revents & (POLLERR | POLLHUP | POLLNVAL))
      return lose(name_ + ": the device went away (unplugged?)");
    // The capture latency starts when a finished buffer woke us (the driver's callback, in effect).
    const auto woke = std::chrono::steady_clock::now();

    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd, VIDIOC_DQBUF, &buf) < 0) {
      if (errno == EAGAIN) return Status::corrupt_frame(name_ + ": woke without a frame");
      return lose(name_ + ": VIDIOC_DQBUF failed (unplugged?): " + errno_text());
    }
    Status status;
    if (buf.index >= buffers_.size()) {
      status = Status::corrupt_frame(name_ + ": driver returned an unknown buffer");
    } else if (buf.flags & V4L2_BUF_FLAG_ERROR) {
      status = Status::corrupt_frame(name_ + " (frame " + std::to_string(buf.sequence) +
                                     "): the driver flagged the buffer as broken");
    } else {
      const std::size_t used = std::min<std::size_t>(buf.bytesused, buffers_[buf.index].length);
      status = decode_z16(static_cast<const std::uint8_t*>(buffers_[buf.index].start), used, width_,
                          height_, bytes_per_line_, frame.depth,
                          name_ + " (frame " + std::to_string(buf.sequence) + ")");
    }
    if (buf.index < buffers_.size() && xioctl(fd, VIDIOC_QBUF, &buf) < 0)
      return lose(name_ + ": VIDIOC_QBUF failed (unplugged?): " + errno_text());
    if (!status.is_ok()) return status;
    stamp(frame,
          static_cast<double>(buf.timestamp.tv_sec) +
              static_cast<double>(buf.timestamp.tv_usec) * 1e-6,
          buf.sequence);
    frame.arrived_at = woke;
    return Status::ok();
  }

 private:
  struct Mapped {
    void* start;
    std::size_t length;
  };

  Status lose(const std::string& message) {
    lost_ = message;
    return Status::device_lost(message);
  }

  void release() {
    if (fd_ && fd_->get() >= 0 && streaming_) {
      v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      xioctl(fd_->get(), VIDIOC_STREAMOFF, &type);
    }
    for (const Mapped& m : buffers_) ::munmap(m.start, m.length);
    buffers_.clear();
  }

  DeviceClaim claim_;
  std::unique_ptr<Fd> fd_;
  int width_ = 0;
  int height_ = 0;
  int bytes_per_line_ = 0;
  std::vector<Mapped> buffers_;
  bool streaming_ = false;
  std::string lost_;
};

}  // namespace

Status decode_z16(const std::uint8_t* data, std::size_t bytes_used, int width, int height,
                  int bytes_per_line, Image<std::uint16_t>& out, const std::string& origin) {
  if (width <= 0 || height <= 0 || bytes_per_line < 2 * width)
    return Status::corrupt_frame(origin + ": impossible Z16 geometry " + std::to_string(width) +
                                 "x" + std::to_string(height) + ", " +
                                 std::to_string(bytes_per_line) + " bytes per line");
  const std::size_t needed =
      static_cast<std::size_t>(bytes_per_line) * (height - 1) + static_cast<std::size_t>(2 * width);
  if (!data || bytes_used < needed)
    return Status::corrupt_frame(origin + ": short Z16 buffer (" + std::to_string(bytes_used) +
                                 " of " + std::to_string(needed) + " bytes)");
  if (out.width() != width || out.height() != height) out.resize(width, height);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* in = data + static_cast<std::size_t>(y) * bytes_per_line;
    std::uint16_t* row = out.row(y);
    for (int x = 0; x < width; ++x)
      row[x] = static_cast<std::uint16_t>(in[2 * x] | (in[2 * x + 1] << 8));
  }
  return Status::ok();
}

std::unique_ptr<Source> open_v4l2_source(const std::string& uri) {
  const std::string prefix = "v4l2:";
  if (uri.compare(0, prefix.size(), prefix) != 0 || uri.size() == prefix.size())
    throw usage_error(uri + ": expected v4l2:/dev/videoN");
  return std::make_unique<V4l2Source>(uri, uri.substr(prefix.size()));
}

std::vector<DeviceInfo> list_v4l2_devices() {
  std::vector<std::string> nodes;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/dev", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("video", 0) == 0) nodes.push_back(entry.path().string());
  }
  std::sort(nodes.begin(), nodes.end());
  std::vector<DeviceInfo> found;
  for (const std::string& node : nodes) {
    Fd fd(::open(node.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC));
    if (fd.get() < 0) continue;
    v4l2_capability cap{};
    if (xioctl(fd.get(), VIDIOC_QUERYCAP, &cap) != 0) continue;
    const std::uint32_t caps =
        (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) continue;
    v4l2_fmtdesc desc{};
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    for (desc.index = 0; xioctl(fd.get(), VIDIOC_ENUM_FMT, &desc) == 0; ++desc.index) {
      if (desc.pixelformat == kZ16) {
        found.push_back({"v4l2:" + node, std::string(reinterpret_cast<const char*>(cap.card)) +
                                             " (" + reinterpret_cast<const char*>(cap.driver) +
                                             ", Z16 depth)"});
        break;
      }
    }
  }
  return found;
}

}  // namespace aoscan
