// The service's API as a function of a request (no sockets): every endpoint and its errors,
// the token, the controlling client, the session records.
#include "serve/api.h"

#include <chrono>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "serve/sessions.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::ScratchDir;

/// A short synthetic replay (no files needed).
constexpr const char* kSynth = "synth:corner?frames=12";

HttpRequest request(const std::string& method, const std::string& path,
                    const std::string& body = "") {
  HttpRequest r;
  r.method = method;
  r.path = path;
  r.body = body;
  r.remote_address = "127.0.0.1";
  return r;
}

nlohmann::json json_of(const HttpResponse& response) {
  return nlohmann::json::parse(response.body);
}

std::string error_of(const HttpResponse& response) {
  return json_of(response).at("error").get<std::string>();
}

/// Waits (at most 60 s) until `id` is no longer running.
void wait_finished(SessionManager& sessions, const std::string& id) {
  for (int i = 0; i < 6000 && sessions.running() == id; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_NE(sessions.running(), id) << "session " << id << " still running after 60 s";
}

class ApiTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SessionManagerOptions options;
    options.data_dir = scratch_.path("data");
    options.threads = 2;
    sessions_ = std::make_unique<SessionManager>(options);
    api_ = std::make_unique<Api>(*sessions_, ApiOptions{std::nullopt, "9.9.9"});
  }
  ScratchDir scratch_;
  std::unique_ptr<SessionManager> sessions_;
  std::unique_ptr<Api> api_;
};

TEST_F(ApiTest, StatusNamesVersionAndNoSession) {
  const HttpResponse r = api_->handle(request("GET", "/api/status"));
  ASSERT_EQ(r.status, 200);
  const nlohmann::json j = json_of(r);
  EXPECT_EQ(j["version"], "9.9.9");
  EXPECT_TRUE(j["session"].is_null());
  EXPECT_GE(j["uptime_s"].get<double>(), 0.0);
  EXPECT_EQ(api_->handle(request("POST", "/api/status")).status, 405);
}

TEST_F(ApiTest, DevicesListsWhatWasSearched) {
  const HttpResponse r = api_->handle(request("GET", "/api/devices"));
  ASSERT_EQ(r.status, 200);
  const nlohmann::json j = json_of(r);
  EXPECT_TRUE(j["devices"].is_array());
  EXPECT_NE(j["searched"].get<std::string>().find("OpenNI2"), std::string::npos);
}

TEST_F(ApiTest, RecordingsAreTumFoldersAndOniFilesUnderTheDataFolder) {
  const std::filesystem::path data = scratch_.path("data");
  std::filesystem::create_directories(data / "kitchen");
  std::ofstream(data / "kitchen" / "depth.txt") << "# depth\n";
  std::filesystem::create_directories(data / "takes" / "a");
  std::ofstream(data / "takes" / "a" / "depth.txt") << "# depth\n";
  std::ofstream(data / "room.oni") << "x";
  std::filesystem::create_directories(data / ".hidden");
  std::ofstream(data / ".hidden" / "depth.txt") << "# depth\n";
  std::filesystem::create_directories(data / "sessions" / "x");
  std::ofstream(data / "sessions" / "x" / "depth.txt") << "# depth\n";
  std::ofstream(data / "notes.txt") << "x";
  const HttpResponse r = api_->handle(request("GET", "/api/recordings"));
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(json_of(r)["recordings"],
            nlohmann::json::array({"kitchen", "room.oni", "takes/a"}));
}

TEST_F(ApiTest, SessionRunsToTheEndWithTheOutputsOfReplay) {
  HttpResponse r = api_->handle(request(
      "POST", "/api/sessions",
      std::string(R"({"source": ")") + kSynth + R"(", "set": {"ao.radius_m": 0.2}})"));
  ASSERT_EQ(r.status, 201) << r.body;
  const std::string id = json_of(r)["id"].get<std::string>();
  EXPECT_TRUE(plausible_session_id(id));
  wait_finished(*sessions_, id);

  r = api_->handle(request("GET", "/api/sessions/" + id));
  ASSERT_EQ(r.status, 200);
  const nlohmann::json s = json_of(r);
  EXPECT_EQ(s["state"], "finished");
  EXPECT_EQ(s["source"], kSynth);
  EXPECT_EQ(s["set"]["ao.radius_m"], "0.2");
  EXPECT_EQ(s["stats"]["status"], "complete");
  EXPECT_EQ(s["stats"]["frames_processed"], 12);
  for (const char* name : {"mesh.ply", "mesh.glb", "trajectory.txt", "stats.json"})
    EXPECT_NE(std::find(s["files"].begin(), s["files"].end(), name), s["files"].end()) << name;

  r = api_->handle(request("GET", "/api/sessions"));
  ASSERT_EQ(json_of(r)["sessions"].size(), 1u);
  EXPECT_EQ(json_of(r)["sessions"][0]["id"], id);

  // Downloads: the file itself; anything else is refused.
  r = api_->handle(request("GET", "/api/sessions/" + id + "/files/trajectory.txt"));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.file_path, (scratch_.path("data") / "sessions" / id / "trajectory.txt").string());
  EXPECT_EQ(r.content_type, "text/plain");
  r = api_->handle(request("GET", "/api/sessions/" + id + "/files/volume.vdb"));
  EXPECT_EQ(r.status, 404);
  EXPECT_NE(error_of(r).find("no file 'volume.vdb'"), std::string::npos);
  for (const char* bad : {"..", ".hidden", "a%2Fb", "mesh.ply%00"}) {
    r = api_->handle(request("GET", "/api/sessions/" + id + "/files/" + bad));
    EXPECT_EQ(r.status, 400) << bad;
  }
  // A name with a slash never reaches the files: it is another (unknown) endpoint.
  r = api_->handle(request("GET", "/api/sessions/" + id + "/files/../" + id + ".json"));
  EXPECT_EQ(r.status, 404);
  r = api_->handle(request("GET", "/api/sessions/nosuch/files/mesh.ply"));
  EXPECT_EQ(r.status, 404);

  // Controls of a finished session: 409; unknown session or action: 404.
  r = api_->handle(request("POST", "/api/sessions/" + id + "/pause"));
  EXPECT_EQ(r.status, 409);
  EXPECT_EQ(error_of(r), "session " + id + " is not running");
  EXPECT_EQ(api_->handle(request("POST", "/api/sessions/nosuch/pause")).status, 404);
  r = api_->handle(request("POST", "/api/sessions/" + id + "/explode"));
  EXPECT_EQ(r.status, 404);
  EXPECT_NE(error_of(r).find("pause, resume, reset, save or stop"), std::string::npos);
  EXPECT_EQ(api_->handle(request("GET", "/api/sessions/" + id + "/pause")).status, 405);
  EXPECT_EQ(api_->handle(request("GET", "/api/sessions/" + id + "/live")).status, 400);
}

TEST_F(ApiTest, ASecondSessionWaitsAndStopWritesTheOutputs) {
  // A long paced replay: it runs until stopped.
  HttpResponse r = api_->handle(request(
      "POST", "/api/sessions", R"({"source": "synth:corner?frames=3000", "realtime": true})"));
  ASSERT_EQ(r.status, 201) << r.body;
  const std::string id = json_of(r)["id"].get<std::string>();
  r = api_->handle(request("POST", "/api/sessions", std::string(R"({"source": ")") + kSynth + "\"}"));
  EXPECT_EQ(r.status, 409);
  EXPECT_EQ(error_of(r), "session " + id + " is running; stop it first");

  // Live figures while it runs.
  nlohmann::json s;
  for (int i = 0; i < 3000; ++i) {  // up to a minute (a sanitizer build is slow to start)
    s = json_of(api_->handle(request("GET", "/api/sessions/" + id)));
    if (s["live"]["frames_processed"].get<std::size_t>() >= 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(s["state"], "running");
  EXPECT_GE(s["live"]["frames_processed"].get<std::size_t>(), 3u);
  EXPECT_EQ(s["live"]["frames_expected"], 3000);
  EXPECT_EQ(json_of(api_->handle(request("GET", "/api/status")))["session"], id);
  r = api_->handle(request("GET", "/api/sessions/" + id + "/files/mesh.ply"));
  EXPECT_EQ(r.status, 409);

  for (const char* action : {"pause", "resume", "reset", "save"}) {
    r = api_->handle(request("POST", std::string("/api/sessions/") + id + "/" + action));
    EXPECT_EQ(r.status, 200) << action << ": " << r.body;
  }
  r = api_->handle(request("POST", "/api/sessions/" + id + "/stop"));
  ASSERT_EQ(r.status, 200);
  wait_finished(*sessions_, id);
  s = json_of(api_->handle(request("GET", "/api/sessions/" + id)));
  EXPECT_EQ(s["state"], "interrupted");  // a recording stopped before its end
  EXPECT_EQ(s["stats"]["status"], "interrupted");
  EXPECT_EQ(s["stats"]["stopped_by"], "quit");
  EXPECT_LT(s["stats"]["frames_processed"].get<std::size_t>(), 3000u);
  EXPECT_EQ(s["stats"]["model_resets"], 1);
  EXPECT_NE(std::find(s["files"].begin(), s["files"].end(), "mesh.ply"), s["files"].end());
}

TEST_F(ApiTest, BadSessionRequestsAreRefusedWithTheirReason) {
  struct Case {
    std::string body;
    int status;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"not json", 400, "the body is not JSON"},
      {"[1]", 400, "the body must be a JSON object"},
      {"{}", 400, "\"source\" is missing"},
      {R"({"source": 3})", 400, "\"source\" must be a string"},
      {R"({"source": "../etc"})", 400, "no absolute path, no '..'"},
      {R"({"source": "/etc"})", 400, "no absolute path, no '..'"},
      {R"({"source": "nosuch"})", 404, "source 'nosuch': no such recording in the data folder"},
      {R"({"source": "synth:corner", "set": {"ao.radius_m": -1}})", 400, "ao.radius_m"},
      {R"({"source": "synth:corner", "set": {"no.such": 1}})", 400, "no.such"},
      {R"({"source": "synth:corner", "set": {"ao.radius_m": [1]}})", 400, "string, number or boolean"},
      {R"({"source": "synth:corner", "set": 3})", 400, "\"set\" must be an object"},
      {R"({"source": "synth:corner", "frames": 0})", 400, "\"frames\" must be a whole number"},
      {R"({"source": "synth:corner", "realtime": "yes"})", 400, "\"realtime\" must be true"},
      {R"({"source": "synth:corner", "bogus": 1})", 400, "unknown key \"bogus\""},
      {R"({"source": "synth:nosuchscene"})", 400, "nosuchscene"},
      {R"({"source": "synth:corner", "loop": "2"})", 400, "\"loop\" must be a whole number"},
      {R"({"source": "synth:corner", "loop": 0})", 400, "--loop"},
  };
  for (const Case& c : cases) {
    const HttpResponse r = api_->handle(request("POST", "/api/sessions", c.body));
    EXPECT_EQ(r.status, c.status) << c.body << " -> " << r.body;
    EXPECT_NE(error_of(r).find(c.message), std::string::npos) << c.body << " -> " << r.body;
  }
  EXPECT_EQ(json_of(api_->handle(request("GET", "/api/sessions")))["sessions"].size(), 0u);
  EXPECT_EQ(api_->handle(request("PUT", "/api/sessions")).status, 405);
  EXPECT_EQ(api_->handle(request("GET", "/api/nosuch")).status, 404);
  EXPECT_EQ(api_->handle(request("GET", "/api/sessions/nosuch")).status, 404);
  EXPECT_EQ(api_->handle(request("GET", "/api/sessions/..")).status, 404);
}

TEST_F(ApiTest, OneClientControlsOthersWatch) {
  HttpRequest start = request("POST", "/api/sessions",
                              R"({"source": "synth:corner?frames=3000", "realtime": true})");
  start.headers.emplace_back("X-Aoscan-Client", "alice");
  HttpResponse r = api_->handle(start);
  ASSERT_EQ(r.status, 201) << r.body;
  const std::string id = json_of(r)["id"].get<std::string>();

  HttpRequest bob = request("POST", "/api/sessions/" + id + "/stop");
  bob.headers.emplace_back("x-aoscan-client", "bob");
  r = api_->handle(bob);
  EXPECT_EQ(r.status, 409);
  EXPECT_NE(error_of(r).find("another client controls the service"), std::string::npos);
  // Bob still watches.
  EXPECT_EQ(api_->handle(request("GET", "/api/sessions/" + id)).status, 200);

  HttpRequest alice = request("POST", "/api/sessions/" + id + "/stop");
  alice.headers.emplace_back("X-Aoscan-Client", "alice");
  EXPECT_EQ(api_->handle(alice).status, 200);
  wait_finished(*sessions_, id);
}

TEST_F(ApiTest, AnIdleControllerHandsOver) {
  Api api(*sessions_, ApiOptions{std::nullopt, "1", std::chrono::milliseconds(50)});
  HttpRequest alice = request("POST", "/api/sessions/nosuch/stop");
  alice.headers.emplace_back("X-Aoscan-Client", "alice");
  EXPECT_EQ(api.handle(alice).status, 404);  // alice controls (the session is unknown)
  HttpRequest bob = request("POST", "/api/sessions/nosuch/stop");
  bob.headers.emplace_back("X-Aoscan-Client", "bob");
  EXPECT_EQ(api.handle(bob).status, 409);
  std::this_thread::sleep_for(std::chrono::milliseconds(80));
  EXPECT_EQ(api.handle(bob).status, 404);  // bob took over
}

TEST_F(ApiTest, WebPageAndItsScriptsAreServed) {
  HttpResponse r = api_->handle(request("GET", "/"));
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "text/html");
  EXPECT_NE(r.body.find("<canvas id=\"live\""), std::string::npos);
  EXPECT_EQ(api_->handle(request("GET", "/index.html")).body, r.body);
  r = api_->handle(request("GET", "/app.js"));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "text/javascript");
  EXPECT_NE(r.body.find("/api/sessions/current/live"), std::string::npos);
  r = api_->handle(request("GET", "/vendor/three.module.js"));
  EXPECT_EQ(r.status, 200);
  EXPECT_GT(r.body.size(), 100000u);
  EXPECT_NE(r.body.find("three.core.js"), std::string::npos);
  EXPECT_EQ(api_->handle(request("GET", "/vendor/nosuch.js")).status, 404);
  EXPECT_EQ(api_->handle(request("POST", "/")).status, 405);
}

class TokenTest : public ApiTest {
 protected:
  void SetUp() override {
    ApiTest::SetUp();
    api_ = std::make_unique<Api>(*sessions_, ApiOptions{std::string(kToken), "1"});
  }
  static constexpr const char* kToken = "0123456789abcdef-secret";
};

TEST_F(TokenTest, EveryRequestNeedsTheToken) {
  HttpResponse r = api_->handle(request("GET", "/api/status"));
  EXPECT_EQ(r.status, 401);
  EXPECT_NE(error_of(r).find("Authorization: Bearer TOKEN"), std::string::npos);
  r = api_->handle(request("GET", "/"));
  EXPECT_EQ(r.status, 303);  // the page sends a browser to the login page
  EXPECT_EQ(api_->handle(request("GET", "/login")).status, 200);
  EXPECT_EQ(api_->handle(request("GET", "/api/sessions/x/files/mesh.ply")).status, 401);

  HttpRequest wrong = request("GET", "/api/status");
  wrong.headers.emplace_back("Authorization", "Bearer 0123456789abcdef-secreT");
  EXPECT_EQ(api_->handle(wrong).status, 401);
  HttpRequest prefix = request("GET", "/api/status");
  prefix.headers.emplace_back("Authorization", "Bearer 0123456789abcdef-secre");
  EXPECT_EQ(api_->handle(prefix).status, 401);
  HttpRequest bearer = request("GET", "/api/status");
  bearer.headers.emplace_back("authorization", std::string("Bearer ") + kToken);
  EXPECT_EQ(api_->handle(bearer).status, 200);
}

TEST_F(TokenTest, TheLoginPageSetsTheCookie) {
  HttpResponse r = api_->handle(request("POST", "/login", "token=wrong"));
  EXPECT_EQ(r.status, 303);
  for (const auto& [name, value] : r.headers) EXPECT_NE(name, "Set-Cookie");
  r = api_->handle(request("POST", "/login", std::string("token=") + kToken));
  ASSERT_EQ(r.status, 303);
  std::string cookie;
  for (const auto& [name, value] : r.headers)
    if (name == "Set-Cookie") cookie = value;
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos);
  EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos);
  HttpRequest with_cookie = request("GET", "/api/status");
  with_cookie.headers.emplace_back("Cookie", "other=1; " + cookie.substr(0, cookie.find(';')));
  EXPECT_EQ(api_->handle(with_cookie).status, 200);
}

TEST(TokenMatches, OnlyTheWholeToken) {
  EXPECT_TRUE(token_matches("abcdefghijklmnop", "abcdefghijklmnop"));
  EXPECT_FALSE(token_matches("abcdefghijklmnoq", "abcdefghijklmnop"));
  EXPECT_FALSE(token_matches("abcdefghijklmno", "abcdefghijklmnop"));
  EXPECT_FALSE(token_matches("abcdefghijklmnopq", "abcdefghijklmnop"));
  EXPECT_FALSE(token_matches("", ""));
}

TEST(SessionRecords, ARunningRecordLeftByAKilledServiceIsMarkedInterrupted) {
  ScratchDir scratch;
  const std::filesystem::path sessions = scratch.path("data") / "sessions";
  std::filesystem::create_directories(sessions / "20260101-000000");
  std::filesystem::create_directories(sessions / "20260101-000001");
  std::ofstream(sessions / "20260101-000000.json")
      << R"({"id": "20260101-000000", "source": "synth:corner", "state": "running"})";
  // This one finished its outputs before the service died.
  std::ofstream(sessions / "20260101-000001.json")
      << R"({"id": "20260101-000001", "source": "synth:corner", "state": "running"})";
  std::ofstream(sessions / "20260101-000001" / "stats.json") << R"({"status": "complete"})";
  std::ofstream(sessions / "broken.json") << "{";

  SessionManagerOptions options;
  options.data_dir = scratch.path("data");
  SessionManager manager(options);
  const nlohmann::json a = manager.describe("20260101-000000");
  EXPECT_EQ(a["state"], "interrupted");
  EXPECT_NE(a["error"].get<std::string>().find("outputs were not written"), std::string::npos);
  EXPECT_EQ(manager.describe("20260101-000001")["state"], "finished");
  EXPECT_EQ(manager.list().size(), 2u);  // the broken record is skipped
  EXPECT_EQ(manager.running(), std::nullopt);
}

TEST(SessionNames, PlainFileNamesAndIds) {
  EXPECT_TRUE(plain_file_name("mesh.ply"));
  EXPECT_TRUE(plain_file_name("ssao_00012.png"));
  for (const char* bad : {"", ".", "..", ".hidden", "a/b", "a\\b", "a b", "mesh.ply\n"})
    EXPECT_FALSE(plain_file_name(bad)) << bad;
  EXPECT_FALSE(plain_file_name(std::string(129, 'a')));
  EXPECT_TRUE(plausible_session_id("20261205-223739-2"));
  for (const char* bad : {"", "..", "-x", "a/b", "a.json"})
    EXPECT_FALSE(plausible_session_id(bad)) << bad;
}

}  // namespace
}  // namespace aoscan
