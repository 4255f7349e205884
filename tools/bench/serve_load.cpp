// aoscan-serve-load: the service under viewers. Starts `aoscan serve` on a free loopback port,
// starts a session replaying SOURCE at full speed (looped), connects N WebSocket viewers that
// read every frame they are sent, and samples for T seconds the session's fused frames (fusion
// fps over the window after a warm-up, and the service's CPU time per fused frame) and the
// service's resident memory. Prints one JSON object.
//
//   aoscan-serve-load --data DIR --source NAME --viewers 20 --seconds 60
#include <arpa/inet.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <civetweb.h>
#include <nlohmann/json.hpp>

#include "support/http_client.h"

namespace {

using Reply = aoscan::testing::HttpReply;

Reply http(int port, const std::string& method, const std::string& path, const std::string& body = "") {
  return aoscan::testing::http_request(port, method, path, body, "X-Aoscan-Client: load\r\n");
}

int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
  socklen_t size = sizeof(address);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size);
  ::close(fd);
  return ntohs(address.sin_port);
}

double rss_mb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

/// CPU seconds (user + system) the process has used so far.
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), {});
  const std::size_t close = text.rfind(')');
  if (close == std::string::npos) return 0.0;
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  double utime = 0.0;
  double stime = 0.0;
  for (int i = 3; fields >> field; ++i) {  // field 3 is the state
    if (i == 14) utime = std::stod(field);
    if (i == 15) {
      stime = std::stod(field);
      break;
    }
  }
  return (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

struct Viewer {
  std::atomic<std::size_t> frames{0};
  std::atomic<std::size_t> bytes{0};
  std::atomic<std::size_t> texts{0};
  mg_connection* conn = nullptr;
};

int on_data(mg_connection*, int flags, char*, std::size_t size, void* user) {
  auto* v = static_cast<Viewer*>(user);
  const int opcode = flags & 0x0f;
  if (opcode == MG_WEBSOCKET_OPCODE_BINARY) {
    ++v->frames;
    v->bytes += size;
  } else if (opcode == MG_WEBSOCKET_OPCODE_TEXT) {
    ++v->texts;
  }
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"aoscan-serve-load: fusion fps and memory of aoscan serve under N live viewers"};
  std::string aoscan;
  std::string data;
  std::string source;
  std::string view = "shaded";
  int viewers = 20;
  double seconds = 60.0;
  double warmup_s = 5.0;
  int loop = 100;
  int threads = 2;
  app.add_option("--aoscan", aoscan, "the aoscan binary (default: beside this one)");
  app.add_option("--data", data, "the service's --data folder")->required();
  app.add_option("--source", source, "recording under --data (or synth:...)")->required();
  app.add_option("--viewers", viewers, "WebSocket viewers")->capture_default_str();
  app.add_option("--seconds", seconds, "how long the viewers watch")->capture_default_str();
  app.add_option("--warmup", warmup_s, "seconds left out of the fps window")->capture_default_str();
  app.add_option("--view", view, "the view the viewers ask for")->capture_default_str();
  app.add_option("--loop", loop, "passes of the recording (replay --loop)")->capture_default_str();
  app.add_option("--threads", threads, "the service's --threads")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (aoscan.empty()) {
    const std::string self = argv[0];
    const std::size_t slash = self.rfind('/');
    aoscan = (slash == std::string::npos ? std::string(".") : self.substr(0, slash)) + "/aoscan";
  }
  mg_init_library(0);

  const int port = free_port();
  const std::string listen = "127.0.0.1:" + std::to_string(port);
  const std::string threads_text = std::to_string(threads);
  const pid_t service = fork();
  if (service == 0) {
    freopen("/dev/null", "w", stderr);
    execl(aoscan.c_str(), aoscan.c_str(), "serve", "--listen", listen.c_str(), "--data",
          data.c_str(), "--threads", threads_text.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  Reply r;
  for (int i = 0; i < 200 && r.status != 200; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    r = http(port, "GET", "/api/status");
  }
  if (r.status != 200) {
    std::cerr << "aoscan-serve-load: the service did not start\n";
    kill(service, SIGKILL);
    return 1;
  }
  const nlohmann::json body = {{"source", source}, {"loop", loop}};
  r = http(port, "POST", "/api/sessions", body.dump());
  if (r.status != 201) {
    std::cerr << "aoscan-serve-load: POST /api/sessions: " << r.status << " " << r.body << "\n";
    kill(service, SIGTERM);
    waitpid(service, nullptr, 0);
    return 1;
  }
  const std::string id = nlohmann::json::parse(r.body)["id"];

  std::vector<std::unique_ptr<Viewer>> clients;
  const std::string path = "/api/sessions/" + id + "/live?view=" + view;
  for (int i = 0; i < viewers; ++i) {
    auto v = std::make_unique<Viewer>();
    char error[256] = "";
    v->conn = mg_connect_websocket_client("127.0.0.1", port, 0, error, sizeof(error), path.c_str(),
                                          nullptr, on_data, nullptr, v.get());
    if (!v->conn) std::cerr << "aoscan-serve-load: viewer " << i << ": " << error << "\n";
    clients.push_back(std::move(v));
  }

  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  nlohmann::json samples = nlohmann::json::array();
  std::size_t window_first = 0;
  std::size_t window_last = 0;
  double window_t0 = 0.0;
  double window_t1 = 0.0;
  double window_cpu0 = 0.0;
  double window_cpu1 = 0.0;
  for (int tick = 1;; ++tick) {
    std::this_thread::sleep_until(start + std::chrono::seconds(tick));
    const double t = std::chrono::duration<double>(Clock::now() - start).count();
    r = http(port, "GET", "/api/sessions/" + id);
    const nlohmann::json s = r.status == 200 ? nlohmann::json::parse(r.body) : nlohmann::json();
    if (!s.contains("live")) break;  // the session ended early
    const std::size_t fused = s["live"]["frames_processed"].get<std::size_t>();
    samples.push_back({{"t_s", t}, {"frames_processed", fused}, {"rss_mb", rss_mb(service)}});
    const double cpu = cpu_seconds(service);
    if (t >= warmup_s && window_t0 == 0.0) {
      window_first = fused;
      window_t0 = t;
      window_cpu0 = cpu;
    }
    window_last = fused;
    window_t1 = t;
    window_cpu1 = cpu;
    if (t >= seconds) break;
  }
  std::vector<double> viewer_fps;
  std::size_t bytes = 0;
  const double watched = std::chrono::duration<double>(Clock::now() - start).count();
  for (const auto& v : clients) {
    viewer_fps.push_back(static_cast<double>(v->frames.load()) / watched);
    bytes += v->bytes.load();
    if (v->conn) mg_close_connection(v->conn);
  }
  std::sort(viewer_fps.begin(), viewer_fps.end());
  http(port, "POST", "/api/sessions/" + id + "/stop");
  for (int i = 0; i < 600; ++i) {
    r = http(port, "GET", "/api/status");
    if (r.status == 200 && nlohmann::json::parse(r.body)["session"].is_null()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  kill(service, SIGTERM);
  waitpid(service, nullptr, 0);

  // Memory: the peak of the last ten samples against the sample at the tenth second.
  double rss_at_10 = 0.0;
  double rss_last_peak = 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double rss = samples[i]["rss_mb"];
    if (i + 1 == 10) rss_at_10 = rss;
    if (i + 10 >= samples.size()) rss_last_peak = std::max(rss_last_peak, rss);
  }
  nlohmann::json out = {
      {"viewers", viewers},
      {"view", view},
      {"seconds", watched},
      {"fusion_fps", window_t1 > window_t0 ? (window_last - window_first) / (window_t1 - window_t0) : 0.0},
      {"fps_window_s", {window_t0, window_t1}},
      // The service's CPU time per fused frame over the window: on a busy machine the fps
      // depends on the other load, this much less.
      {"cpu_ms_per_frame", window_last > window_first
                               ? 1000.0 * (window_cpu1 - window_cpu0) / (window_last - window_first)
                               : 0.0},
      {"viewer_fps", viewer_fps.empty() ? nlohmann::json(nullptr)
                                        : nlohmann::json({{"min", viewer_fps.front()},
                                                          {"median", viewer_fps[viewer_fps.size() / 2]},
                                                          {"max", viewer_fps.back()}})},
      {"stream_mb_per_s", bytes / watched / 1e6},
      {"rss_mb_at_10s", rss_at_10},
      {"rss_mb_peak_last_10s", rss_last_peak},
      {"samples", samples}};
  std::cout << out.dump(2) << "\n";
  return 0;
}
