// The service on loopback: HTTP through civetweb, the size limits, the live view over WebSocket,
// many connections, garbage, and the command line's checks.
#include "serve/service.h"

#include <arpa/inet.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <thread>

#include <civetweb.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "io/colour_image.h"
#include "serve/live_stream.h"
#include "serve/sessions.h"
#include "support/cli_util.h"
#include "support/http_client.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::ScratchDir;

using Reply = testing::HttpReply;

Reply http(int port, const std::string& method, const std::string& path,
           const std::string& body = "", const std::string& extra_headers = "") {
  return testing::http_request(port, method, path, body, extra_headers);
}

/// POSTs a session request and returns the new session's id ("" and a failure when refused).
std::string start_session(int port, const std::string& body) {
  const Reply r = http(port, "POST", "/api/sessions", body);
  EXPECT_EQ(r.status, 201) << r.body;
  return r.status == 201 ? nlohmann::json::parse(r.body)["id"].get<std::string>() : "";
}

/// What a WebSocket client received.
struct Received {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::string> texts;
  std::vector<std::string> frames;
  bool closed = false;
};

int on_data(mg_connection*, int flags, char* data, std::size_t size, void* user) {
  auto* r = static_cast<Received*>(user);
  const int opcode = flags & 0x0f;
  std::lock_guard<std::mutex> lock(r->mutex);
  if (opcode == MG_WEBSOCKET_OPCODE_TEXT) r->texts.emplace_back(data, size);
  if (opcode == MG_WEBSOCKET_OPCODE_BINARY) r->frames.emplace_back(data, size);
  r->changed.notify_all();
  return 1;
}

void on_close(const mg_connection*, void* user) {
  auto* r = static_cast<Received*>(user);
  std::lock_guard<std::mutex> lock(r->mutex);
  r->closed = true;
  r->changed.notify_all();
}

class ServiceTest : public ::testing::Test {
 protected:
  void start(const std::string& token_file = "") {
    ServiceOptions options;
    options.listen = "127.0.0.1:0";
    options.data_dir = scratch_.file("data");
    options.token_file = token_file;
    options.threads = 2;
    options.version = "test";
    service_ = std::make_unique<Service>(options);
    port_ = service_->port();
    ASSERT_GT(port_, 0);
  }
  ScratchDir scratch_;
  std::unique_ptr<Service> service_;
  int port_ = 0;
};

TEST_F(ServiceTest, AnswersOverLoopbackAndLimitsBodies) {
  start();
  Reply r = http(port_, "GET", "/api/status");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(nlohmann::json::parse(r.body)["version"], "test");
  r = http(port_, "GET", "/");
  EXPECT_EQ(r.status, 200);
  EXPECT_NE(r.body.find("<title>aoscan</title>"), std::string::npos);
  r = http(port_, "POST", "/api/sessions", std::string(70 * 1024, 'x'));
  EXPECT_EQ(r.status, 413);
  EXPECT_NE(r.body.find("larger than 65536 bytes"), std::string::npos);
  r = http(port_, "POST", "/api/sessions", "{\"source\": \"nosuch\"}");
  EXPECT_EQ(r.status, 404);
  EXPECT_EQ(nlohmann::json::parse(r.body)["error"],
            "source 'nosuch': no such recording in the data folder");
  // A request line with a percent-encoded traversal is cleaned by the server, then refused.
  r = http(port_, "GET", "/api/sessions/x/files/..%2F..%2F..%2Fetc%2Fpasswd");
  EXPECT_GE(r.status, 400);
  EXPECT_EQ(r.body.find("root:"), std::string::npos);
  // Header fields beyond the limit: the connection is refused, the service goes on.
  const std::string huge = "X-Filler: " + std::string(20000, 'a') + "\r\n";
  r = http(port_, "GET", "/api/status", "", huge);
  EXPECT_NE(r.status, 200);
  EXPECT_EQ(http(port_, "GET", "/api/status").status, 200);
}

TEST_F(ServiceTest, TheLiveViewStreamsChangingFramesAndTheStatus) {
  start();
  const std::string id = start_session(port_, R"({"source": "synth:corner?frames=3000", "realtime": true})");
  ASSERT_FALSE(id.empty());

  Received received;
  char error[256] = "";
  const std::string path = "/api/sessions/" + id + "/live?view=mvao";
  mg_connection* ws = mg_connect_websocket_client("127.0.0.1", port_, 0, error, sizeof(error),
                                                  path.c_str(), nullptr, on_data, on_close,
                                                  &received);
  ASSERT_NE(ws, nullptr) << error;
  {
    std::unique_lock<std::mutex> lock(received.mutex);
    received.changed.wait_for(lock, std::chrono::seconds(60),
                              [&] { return received.frames.size() >= 4 && received.texts.size() >= 2; });
  }
  std::vector<std::string> frames;
  std::vector<std::string> texts;
  {
    std::lock_guard<std::mutex> lock(received.mutex);
    frames = received.frames;
    texts = received.texts;
  }
  ASSERT_GE(frames.size(), 4u);
  ASSERT_GE(texts.size(), 2u);
  // Each frame is a JPEG of the model raycast's size (half the camera's); not all the same; not
  // blank.
  bool changed = false;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    Image<Rgb8> image;
    ASSERT_TRUE(decode_colour_image(reinterpret_cast<const std::uint8_t*>(frames[i].data()),
                                    frames[i].size(), image, "frame")
                    .is_ok());
    EXPECT_EQ(image.width(), 320);
    EXPECT_EQ(image.height(), 240);
    int lit = 0;
    for (int y = 0; y < image.height(); y += 4)
      for (int x = 0; x < image.width(); x += 4) lit += image(x, y).r > 60 ? 1 : 0;
    EXPECT_GT(lit, 100) << "frame " << i << " is nearly blank";
    if (i > 0 && frames[i] != frames[0]) changed = true;
  }
  EXPECT_TRUE(changed);
  const nlohmann::json status = nlohmann::json::parse(texts.back());
  EXPECT_EQ(status["session"], id);
  EXPECT_EQ(status["state"]["state"], "running");
  EXPECT_EQ(status["viewers"], 1);

  // Garbage from the client changes nothing; a view request does.
  const std::string garbage = "\x01\x02{not json";
  mg_websocket_client_write(ws, MG_WEBSOCKET_OPCODE_TEXT, garbage.data(), garbage.size());
  const std::string depth = R"({"view": "depth"})";
  mg_websocket_client_write(ws, MG_WEBSOCKET_OPCODE_TEXT, depth.data(), depth.size());
  mg_close_connection(ws);

  Reply r = http(port_, "POST", "/api/sessions/" + id + "/stop");
  EXPECT_EQ(r.status, 200) << r.body;
  for (int i = 0; i < 3000; ++i) {
    r = http(port_, "GET", "/api/status");
    if (nlohmann::json::parse(r.body)["session"].is_null()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_TRUE(nlohmann::json::parse(r.body)["session"].is_null());
  r = http(port_, "GET", "/api/sessions/" + id + "/files/mesh.ply");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body.rfind("ply\n", 0), 0u);
}

TEST_F(ServiceTest, ManyConnectionsAndAViewerThatVanishesMidFrame) {
  start();
  // 1000 raw connections opened at once and dropped: a third send half a request, a third
  // binary garbage, a third nothing.
  std::vector<int> sockets;
  for (int i = 0; i < 1000; ++i) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port_));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0) {
      if (i % 3 == 0) {
        const char partial[] = "GET /api/sta";
        (void)!::write(fd, partial, sizeof(partial) - 1);
      } else if (i % 3 == 1) {
        const char garbage[] = "\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03\r\n\r\n\xff\xfe";
        (void)!::write(fd, garbage, sizeof(garbage) - 1);
      }
      sockets.push_back(fd);
    } else {
      ::close(fd);
    }
  }
  EXPECT_GT(sockets.size(), 500u);
  for (int fd : sockets) ::close(fd);
  // The service drains them and answers at once.
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(http(port_, "GET", "/api/status").status, 200);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(20));
  // A WebSocket viewer that goes away without a close frame while frames are sent.
  const std::string id = start_session(port_, R"({"source": "synth:corner?frames=3000", "realtime": true})");
  ASSERT_FALSE(id.empty());
  for (int k = 0; k < 3; ++k) {
    Received received;
    char error[256] = "";
    mg_connection* ws = mg_connect_websocket_client("127.0.0.1", port_, 0, error, sizeof(error),
                                                    "/api/sessions/current/live", nullptr,
                                                    on_data, on_close, &received);
    ASSERT_NE(ws, nullptr) << error;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    mg_close_connection(ws);
  }
  // The service goes on answering and fusing (its frames keep coming; a slow build, such as a
  // sanitizer's, may take seconds for the first ones).
  const auto fused = [&] {
    const Reply r = http(port_, "GET", "/api/sessions/" + id);
    EXPECT_EQ(r.status, 200);
    return r.status == 200
               ? nlohmann::json::parse(r.body)["live"]["frames_processed"].get<std::size_t>()
               : std::size_t{0};
  };
  const auto wait_beyond = [&](std::size_t frames) {
    std::size_t now = fused();
    for (int i = 0; i < 600 && now <= frames; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      now = fused();
    }
    return now;
  };
  const std::size_t before = wait_beyond(0);
  EXPECT_GT(before, 0u);
  EXPECT_GT(wait_beyond(before), before);
  EXPECT_EQ(http(port_, "POST", "/api/sessions/" + id + "/stop").status, 200);
}

TEST_F(ServiceTest, WithATokenEverythingNeedsIt) {
  const std::string token_file = scratch_.file("token");
  std::ofstream(token_file) << "  s3cret-token-of-twenty  \nignored\n";
  start(token_file);
  EXPECT_EQ(http(port_, "GET", "/api/status").status, 401);
  EXPECT_EQ(http(port_, "GET", "/api/status", "", "Authorization: Bearer s3cret-token-of-twenty\r\n").status,
            200);
  Received received;
  char error[256] = "";
  mg_connection* ws = mg_connect_websocket_client("127.0.0.1", port_, 0, error, sizeof(error),
                                                  "/api/sessions/current/live", nullptr, on_data,
                                                  on_close, &received);
  if (ws) {  // refused: closed before any message
    std::unique_lock<std::mutex> lock(received.mutex);
    received.changed.wait_for(lock, std::chrono::seconds(5), [&] { return received.closed; });
    EXPECT_TRUE(received.texts.empty());
    lock.unlock();
    mg_close_connection(ws);
  }
}

TEST(ServiceOptions, ListenAddressesAndTokens) {
  EXPECT_EQ(parse_listen_address("127.0.0.1:8080"), std::make_pair(std::string("127.0.0.1"), 8080));
  EXPECT_EQ(parse_listen_address("localhost:0"), std::make_pair(std::string("127.0.0.1"), 0));
  for (const char* bad : {"8080", ":8080", "127.0.0.1:", "127.0.0.1:65536", "127.0.0.1:80a",
                          "example.org:80", "[::1]:80", "1.2.3:80"})
    EXPECT_THROW(parse_listen_address(bad), Error) << bad;
  EXPECT_TRUE(loopback_address("127.0.0.1"));
  EXPECT_TRUE(loopback_address("127.8.9.10"));
  EXPECT_FALSE(loopback_address("0.0.0.0"));
  EXPECT_FALSE(loopback_address("192.168.1.2"));

  ScratchDir scratch;
  std::ofstream(scratch.file("short")) << "abc\n";
  std::ofstream(scratch.file("empty"));
  std::ofstream(scratch.file("quoted")) << "abcdefghijkl\"mnopq\n";
  for (const char* name : {"short", "empty", "quoted", "missing"})
    EXPECT_THROW(read_token_file(scratch.file(name)), Error) << name;

  ServiceOptions open;
  open.listen = "0.0.0.0:0";
  open.data_dir = scratch.file("data");
  try {
    Service service(open);
    FAIL() << "listening on 0.0.0.0 without a token was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_NE(std::string(e.what()).find("needs --token-file"), std::string::npos);
  }
}

TEST(ServiceCommand, ABusyPortIsAUsageError) {
  ScratchDir scratch;
  ServiceOptions options;
  options.listen = "127.0.0.1:0";
  options.data_dir = scratch.file("data");
  Service first(options);
  const std::string listen = "127.0.0.1:" + std::to_string(first.port());
  const std::string command = std::string(AOSCAN_BINARY) + " serve --listen " + listen +
                              " --data " + scratch.file("data2") + " 2>" + scratch.file("err");
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  std::ifstream err(scratch.file("err"));
  const std::string text((std::istreambuf_iterator<char>(err)), {});
  EXPECT_NE(text.find("--listen " + listen + ": cannot listen there"), std::string::npos) << text;
}

/// `aoscan serve` as a child process on a port of its choice (read from its first line).
class ChildService {
 public:
  ChildService(const testing::ScratchDir& scratch, const std::string& data,
               const std::string& env = "")
      : process_("serve --listen 127.0.0.1:0 --threads 2 --data '" + data + "'",
                 scratch.path(""), env) {
    const std::string prefix = "aoscan: serving on http://127.0.0.1:";
    for (int i = 0; i < 500 && port_ == 0 && !process_.poll(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      const std::string err = process_.output().err;
      if (const std::size_t at = err.find(prefix); at != std::string::npos)
        port_ = std::atoi(err.c_str() + at + prefix.size());
    }
  }
  int port() const { return port_; }
  testing::AoscanProcess& process() { return process_; }

 private:
  testing::AoscanProcess process_;
  int port_ = 0;
};

/// Polls GET /api/sessions/ID until its state is not `running` (at most a minute).
nlohmann::json wait_ended(int port, const std::string& id) {
  nlohmann::json s;
  for (int i = 0; i < 3000; ++i) {
    const Reply r = http(port, "GET", "/api/sessions/" + id);
    s = nlohmann::json::parse(r.body);
    if (s["state"] != "running") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return s;
}

TEST(ServiceCommand, SessionsOfAKilledServiceAreKeptOrMarkedInterrupted) {
  ScratchDir scratch;
  const std::string data = scratch.file("data");
  ChildService service(scratch, data);
  const int port = service.port();
  ASSERT_GT(port, 0) << "the service did not start: " << service.process().output().err;
  // One session finishes; the next is running when the service is killed.
  const std::string finished = start_session(port, R"({"source": "synth:corner?frames=5"})");
  ASSERT_FALSE(finished.empty());
  EXPECT_EQ(wait_ended(port, finished)["state"], "finished");
  const std::string cut = start_session(port, R"({"source": "synth:corner?frames=3000", "realtime": true})");
  ASSERT_FALSE(cut.empty());
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(service.process().pid(), SIGKILL);
  service.process().wait_for(std::chrono::seconds(10));

  SessionManagerOptions options;
  options.data_dir = data;
  SessionManager restarted(options);
  const nlohmann::json a = restarted.describe(finished);
  EXPECT_EQ(a["state"], "finished");
  EXPECT_EQ(a["stats"]["frames_processed"], 5);
  EXPECT_EQ(restarted.describe(cut)["state"], "interrupted");
  EXPECT_TRUE(std::filesystem::exists(restarted.file(finished, "mesh.ply")));
}

TEST(ServiceCommand, ACameraUnpluggedMidSessionFailsItAndTheServiceGoesOn) {
  ScratchDir scratch;
  const std::filesystem::path dump = testing::make_fakenect_dump(scratch.path(""), 8);
  if (dump.empty()) GTEST_SKIP() << "fakenect or aoscan-fakenect-dump not available";
  ChildService service(scratch, scratch.file("data"), testing::fakenect_env(dump));
  const int port = service.port();
  ASSERT_GT(port, 0) << "the service did not start: " << service.process().output().err;
  const std::string id = start_session(port, R"({"source": "freenect"})");
  ASSERT_FALSE(id.empty());
  const nlohmann::json s = wait_ended(port, id);
  EXPECT_EQ(s["state"], "failed");
  EXPECT_EQ(s["exit_code"], 4);
  EXPECT_NE(s["error"].get<std::string>().find("unplugged"), std::string::npos) << s.dump();
  EXPECT_EQ(s["stats"]["frames_read"], 8);  // what came before the unplug is kept
  EXPECT_EQ(http(port, "GET", "/api/sessions/" + id + "/files/mesh.ply").status, 200);
  // The service goes on: it answers and runs the next session.
  const std::string next = start_session(port, R"({"source": "synth:corner?frames=4"})");
  ASSERT_FALSE(next.empty());
  EXPECT_EQ(wait_ended(port, next)["state"], "finished");
}

TEST_F(ServiceTest, ARecordingWithoutOneUsableFrameFailsTheSessionOnly) {
  start();
  const std::filesystem::path rec = scratch_.path("data") / "broken";
  std::filesystem::create_directories(rec);
  std::ofstream(rec / "depth.txt") << "1.0 depth/1.png\n1.1 depth/2.png\n1.2 depth/3.png\n";
  const std::string id = start_session(port_, R"({"source": "broken"})");
  ASSERT_FALSE(id.empty());
  const nlohmann::json s = wait_ended(port_, id);
  EXPECT_EQ(s["state"], "failed");
  EXPECT_EQ(s["exit_code"], 3);
  EXPECT_NE(s["error"].get<std::string>().find("no usable frame (3 unreadable)"), std::string::npos)
      << s.dump();
  EXPECT_EQ(http(port_, "GET", "/api/status").status, 200);
}

}  // namespace
}  // namespace aoscan
