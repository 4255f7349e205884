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

#include "capture/colour_stream.h"
#include "capture/device_claim.h"
#include "core/log.h"

namespace aoscan {
namespace {

constexpr std::uint32_t kZ16 = v4l2_fourcc('Z', '1', '6', ' ');
constexpr int kBufferCount = 4;
constexpr int kFrameTimeoutMs = 2000;
/// The longest a depth frame waits for a colour frame that may be nearer to it in time.
constexpr auto kColourWait = std::chrono::milliseconds(40);

/// The colour formats decoded, in order of preference (cheapest to decode first).
struct ColourFourcc {
  std::uint32_t fourcc;
  ColourPixelFormat format;
};
constexpr ColourFourcc kColourFormats[] = {
    {V4L2_PIX_FMT_RGB24, ColourPixelFormat::kRgb24},
    {V4L2_PIX_FMT_YUYV, ColourPixelFormat::kYuyv},
    {V4L2_PIX_FMT_MJPEG, ColourPixelFormat::kMjpeg},
};

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

struct Mapped {
  void* start;
  std::size_t length;
};

/// Requests kBufferCount mmap buffers of `fd`, maps and queues them, and starts streaming.
/// Throws device_error naming `uri` on any failure (the buffers mapped so far are in `buffers`).
void start_streaming(int fd, const std::string& uri, std::vector<Mapped>& buffers) {
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
    buffers.push_back({p, buf.length});
    if (xioctl(fd, VIDIOC_QBUF, &buf) < 0)
      throw device_error(uri + ": VIDIOC_QBUF failed: " + errno_text());
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd, VIDIOC_STREAMON, &type) < 0)
    throw device_error(uri + ": VIDIOC_STREAMON failed: " + errno_text());
}

/// Opens `node` as a V4L2 streaming capture device; throws device_error naming `uri`.
std::unique_ptr<Fd> open_capture_node(const std::string& uri, const std::string& node) {
  auto fd = std::make_unique<Fd>(::open(node.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC));
  if (fd->get() < 0) {
    if (errno == EBUSY) throw device_error(uri + ": busy: another program holds the camera");
    throw device_error(uri + ": cannot open: " + errno_text());
  }
  v4l2_capability cap{};
  if (xioctl(fd->get(), VIDIOC_QUERYCAP, &cap) < 0)
    throw device_error(uri + ": not a V4L2 device (VIDIOC_QUERYCAP: " + errno_text() + ")");
  const std::uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) throw device_error(uri + ": not a video capture device");
  if (!(caps & V4L2_CAP_STREAMING))
    throw device_error(uri + ": the driver does not support streaming I/O");
  return fd;
}

/// The colour node beside a depth node: RGB24, YUYV or MJPEG frames, streamed once colour is
/// wanted, each frame decoded into a ColourPairer on the depth frames' clock (both nodes stamp
/// buffers with the same monotonic clock).
class V4l2ColourNode {
 public:
  /// Opens and configures `node` (the depth's size preferred); throws device_error naming it.
  V4l2ColourNode(const std::string& node, int width, int height) : what_("colour node " + node) {
    fd_ = open_capture_node(what_, node);
    const int fd = fd_->get();
    std::string offered;
    const ColourFourcc* chosen = nullptr;
    v4l2_fmtdesc desc{};
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    for (desc.index = 0; xioctl(fd, VIDIOC_ENUM_FMT, &desc) == 0; ++desc.index) {
      offered += (offered.empty() ? "" : ", ") + fourcc_text(desc.pixelformat);
      for (const ColourFourcc& f : kColourFormats)
        if (f.fourcc == desc.pixelformat && (!chosen || &f < chosen)) chosen = &f;
    }
    if (!chosen)
      throw device_error(what_ + ": no RGB3, YUYV or MJPG format (offers: " +
                         (offered.empty() ? std::string("none") : offered) + ")");
    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    fmt.fmt.pix.width = static_cast<std::uint32_t>(width);
    fmt.fmt.pix.height = static_cast<std::uint32_t>(height);
    fmt.fmt.pix.pixelformat = chosen->fourcc;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    if (xioctl(fd, VIDIOC_S_FMT, &fmt) < 0)
      throw device_error(what_ + ": VIDIOC_S_FMT " + fourcc_text(chosen->fourcc) +
                         " failed: " + errno_text());
    if (fmt.fmt.pix.pixelformat != chosen->fourcc)
      throw device_error(what_ + ": the driver replaced " + fourcc_text(chosen->fourcc) + " by " +
                         fourcc_text(fmt.fmt.pix.pixelformat));
    format_ = chosen->format;
    width_ = static_cast<int>(fmt.fmt.pix.width);
    height_ = static_cast<int>(fmt.fmt.pix.height);
    bytes_per_line_ = static_cast<int>(fmt.fmt.pix.bytesperline);
    v4l2_streamparm parm{};
    parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    parm.parm.capture.timeperframe.numerator = 1;
    parm.parm.capture.timeperframe.denominator = 30;
    xioctl(fd, VIDIOC_S_PARM, &parm);
  }
  ~V4l2ColourNode() { release(); }
  V4l2ColourNode(const V4l2ColourNode&) = delete;
  V4l2ColourNode& operator=(const V4l2ColourNode&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  int fd() const { return failed_ || !streaming_ ? -1 : fd_->get(); }
  bool streaming() const { return streaming_ && !failed_; }
  ColourPairer& pairer() { return pairer_; }

  /// Starts streaming; false (with a warning) when it cannot.
  bool start(const std::string& source_name) {
    try {
      start_streaming(fd_->get(), what_, buffers_);
      streaming_ = true;
    } catch (const Error& e) {
      spdlog::warn("{}: {}; continuing without colour", source_name, e.what());
      release();
    }
    return streaming_;
  }

  /// Takes one finished buffer into the pairer (call when poll says the node is readable). A
  /// node that fails stops delivering colour (the depth goes on; its frames count the skips).
  void take_frame(const std::string& source_name) {
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_->get(), VIDIOC_DQBUF, &buf) < 0) {
      if (errno != EAGAIN) fail(source_name, "VIDIOC_DQBUF failed: " + errno_text());
      return;
    }
    const double timestamp_s = static_cast<double>(buf.timestamp.tv_sec) +
                               static_cast<double>(buf.timestamp.tv_usec) * 1e-6;
    const std::string where = what_ + " (frame " + std::to_string(buf.sequence) + ")";
    if (buf.index >= buffers_.size()) {
      pairer_.commit_failed(timestamp_s, where + ": the driver returned an unknown buffer");
      return;
    }
    Status status;
    if (buf.flags & V4L2_BUF_FLAG_ERROR) {
      status = Status::corrupt_frame(where + ": the driver flagged the buffer as broken");
    } else {
      const std::size_t used = std::min<std::size_t>(buf.bytesused, buffers_[buf.index].length);
      status = decode_colour_frame(format_, static_cast<const std::uint8_t*>(buffers_[buf.index].start),
                                   used, width_, height_, bytes_per_line_, pairer_.next_buffer(),
                                   where);
    }
    if (status.is_ok())
      pairer_.commit(timestamp_s);
    else
      pairer_.commit_failed(timestamp_s, status.message());
    if (xioctl(fd_->get(), VIDIOC_QBUF, &buf) < 0)
      fail(source_name, "VIDIOC_QBUF failed: " + errno_text());
  }

  /// The node went away or broke: colour stops, with one warning.
  void fail(const std::string& source_name, const std::string& why) {
    if (failed_) return;
    failed_ = true;
    spdlog::warn("{}: {}: {}; the depth goes on without colour", source_name, what_, why);
  }

  void release() {
    if (fd_ && fd_->get() >= 0 && streaming_) {
      v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      xioctl(fd_->get(), VIDIOC_STREAMOFF, &type);
    }
    streaming_ = false;
    for (const Mapped& m : buffers_) ::munmap(m.start, m.length);
    buffers_.clear();
  }

 private:
  std::string what_;
  std::unique_ptr<Fd> fd_;
  ColourPixelFormat format_ = ColourPixelFormat::kRgb24;
  int width_ = 0;
  int height_ = 0;
  int bytes_per_line_ = 0;
  std::vector<Mapped> buffers_;
  bool streaming_ = false;
  bool failed_ = false;
  ColourPairer pairer_;
};

class V4l2Source : public LiveMillimetreSource {
 public:
  V4l2Source(const std::string& uri, const std::string& node, const std::string& colour_node)
      : LiveMillimetreSource(uri) {
    try {
      start(uri, node);
      if (!colour_node.empty()) {
        colour_ = std::make_unique<V4l2ColourNode>(colour_node, width_, height_);
        colour_camera_ = ColourCamera::nominal(colour_->width(), colour_->height(), 0.0);
      }
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

    fd_ = open_capture_node(uri, node);
    const int fd = fd_->get();

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

    start_streaming(fd, uri, buffers_);
    streaming_ = true;
  }

 public:
  std::string colour_origin() const override {
    return colour_camera_ ? "nominal (the colour node's size, fx = fy = 525 * width / 640, at "
                            "the depth camera)"
                          : "";
  }

  Status read(DepthFrame& frame) override {
    if (colour_ && !colour_decided_) {
      colour_decided_ = true;
      if (!colour_wanted() || !colour_->start(name_)) {
        colour_.reset();
        colour_camera_.reset();
      }
    }
    if (!lost_.empty()) return Status::device_lost(lost_);
    const int fd = fd_->get();
    pollfd pfd[2] = {{fd, POLLIN, 0}, {colour_ ? colour_->fd() : -1, POLLIN, 0}};
    // Short polls up to the frame timeout, so that a stop request is seen at once; colour frames
    // that arrive meanwhile are taken into the pairer.
    int rc = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kFrameTimeoutMs);
    while (std::chrono::steady_clock::now() < deadline) {
      if (stop_requested()) return Status::end_of_stream();
      pfd[1].fd = colour_ ? colour_->fd() : -1;  // negative: poll ignores it
      pfd[0].revents = pfd[1].revents = 0;
      rc = ::poll(pfd, 2, static_cast<int>(kStopPollInterval.count()));
      if (rc < 0 && errno == EINTR) rc = 0;
      if (rc > 0 && pfd[1].revents != 0) take_colour(pfd[1].revents);
      if (rc < 0 || pfd[0].revents != 0) break;
      rc = 0;
    }
    if (rc == 0) return lose(name_ + ": no frame for 2 s (unplugged?)");
    if (rc < 0) return lose(name_ + ": poll failed: " + errno_text());
    if (pfd[0].revents & (POLLERR | POLLHUP | POLLNVAL))
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
    pair_colour(frame, name_ + " (frame " + std::to_string(buf.sequence) + ")");
    return Status::ok();
  }

 private:
  /// The colour node polled readable (or broken).
  void take_colour(short revents) {
    if (revents & (POLLERR | POLLHUP | POLLNVAL))
      colour_->fail(name_, "the colour node went away");
    else
      colour_->take_frame(name_);
  }

  /// The depth frame just read gets its colour: the colour frames already there are taken in,
  /// and while the colour node is behind it waits up to kColourWait for a nearer one.
  void pair_colour(DepthFrame& frame, const std::string& where) {
    if (!colour_camera_) {
      frame.clear_colour();
      return;
    }
    const auto deadline = std::chrono::steady_clock::now() + kColourWait;
    for (int wait_ms = 0;;) {
      if (!colour_->streaming() || stop_requested()) break;
      pollfd p{colour_->fd(), POLLIN, 0};
      const int rc = ::poll(&p, 1, wait_ms);
      if (rc > 0) {
        take_colour(p.revents);
        wait_ms = 0;  // take in whatever else is there first
        continue;
      }
      if (rc < 0 && errno != EINTR) break;
      // Nothing more there: wait for a nearer frame only while the stream is behind and flowing.
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0 || !colour_->pairer().worth_waiting(frame.timestamp_s)) break;
      wait_ms = static_cast<int>(left.count());
    }
    colour_->pairer().pair(frame, *colour_camera_, where);
  }

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
  std::unique_ptr<V4l2ColourNode> colour_;     ///< the colour node, when one was given
  std::optional<ColourCamera> colour_camera_;  ///< set while the source delivers colour
  bool colour_decided_ = false;
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

V4l2Uri parse_v4l2_uri(const std::string& uri) {
  const std::string prefix = "v4l2:";
  const std::string forms = ": expected v4l2:/dev/videoN or v4l2:/dev/videoN?colour=/dev/videoM";
  if (uri.compare(0, prefix.size(), prefix) != 0 || uri.size() == prefix.size())
    throw usage_error(uri + forms);
  V4l2Uri parsed;
  parsed.depth_node = uri.substr(prefix.size());
  if (const auto q = parsed.depth_node.find('?'); q != std::string::npos) {
    const std::string query = parsed.depth_node.substr(q + 1);
    parsed.depth_node.resize(q);
    const std::string key = "colour=";
    if (query.compare(0, key.size(), key) != 0)
      throw usage_error(uri + ": unknown option '" + query + "' (colour=/dev/videoM)");
    parsed.colour_node = query.substr(key.size());
    if (parsed.colour_node.empty()) throw usage_error(uri + forms);
  }
  if (parsed.depth_node.empty()) throw usage_error(uri + forms);
  return parsed;
}

std::unique_ptr<Source> open_v4l2_source(const std::string& uri) {
  const V4l2Uri parsed = parse_v4l2_uri(uri);
  return std::make_unique<V4l2Source>(uri, parsed.depth_node, parsed.colour_node);
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
