// SPDX-License-Identifier: Apache-2.0
// A run's records and state on an MQTT broker ([output.mqtt], mqtt_output.h),
// against a real mosquitto started by the test on loopback: every record
// once and in order, nothing lost across a broker restart, the retained
// state and the last will, the queue's bound, and the named problems of bad
// credentials and an unreachable broker, the run's own records untouched.

#include "lfi/controller/mqtt_output.h"
#include "lfi/controller/run.h"
#include "lfi/sim/devices/sim_camera.h"
#include "lfi_test_support.h"
#include "mosquitto_broker.h"
#include "quick_run_bench.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>

namespace lfi {
namespace {

namespace fs = std::filesystem;
using testing_support::MosquittoBroker;
using testing_support::MqttListener;
using testing_support::MqttMessage;
using testing_support::TestFolder;
using testing_support::throwsError;

// The part numbers of the records among `messages`, in the order received.
std::vector<std::uint64_t> recordParts(const std::vector<MqttMessage>& messages, const std::string& prefix) {
  std::vector<std::uint64_t> parts;
  for (const MqttMessage& m : messages)
    if (m.topic == prefix + "/record") parts.push_back(nlohmann::json::parse(m.payload)["part"]);
  return parts;
}

std::vector<std::string> states(const std::vector<MqttMessage>& messages, const std::string& prefix) {
  std::vector<std::string> out;
  for (const MqttMessage& m : messages)
    if (m.topic == prefix + "/state") out.push_back(m.payload);
  return out;
}

std::vector<std::string> lines(const fs::path& file) {
  std::vector<std::string> out;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// The dying run of ARunThatDiesLeavesItsLastWill: this test program started with LFI_TEST_WILL_BENCH set
// publishes "running" to that bench's broker and exits without a word (no DISCONNECT), before any test runs
// and before any thread is made (a forked child of a threaded process may not make threads of its own).
[[maybe_unused]] const bool willChild = [] {
  const char* bench = std::getenv("LFI_TEST_WILL_BENCH");
  if (!bench) return false;
  try {
    MqttOutput output(*readBenchFile(bench).mqtt);
    output.publishState(RunState::Running);
    while (output.pending() > 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "the dying run: %s\n", e.what());
    ::_exit(1);
  }
  ::_exit(0);  // (no destructor, no DISCONNECT)
}();

class RunOutputTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sim::registerSimBackends();
    folder_ = new TestFolder("lfi-run-output");
    benchText_ = new std::string(testing_support::quickRunBenchText("sim"));
    package_ = new ReferencePackage(testing_support::quickRunReference(*folder_, *benchText_));
  }
  static void TearDownTestSuite() {
    delete package_;
    delete benchText_;
    delete folder_;
  }
  void SetUp() override {
    if (testing_support::mosquittoProgram().empty()) LFI_SKIP_WITHOUT_TOOL("no mosquitto (Debian: mosquitto)");
  }

  static std::string name() { return ::testing::UnitTest::GetInstance()->current_test_info()->name(); }

  // The bench with [output.mqtt] of `broker`, the topic the test's name, and `more` keys.
  static BenchFile bench(const std::string& broker, const std::string& more = "") {
    return readBenchFile(folder_->write(name() + ".toml", *benchText_ + "\n[output.mqtt]\nbroker = \"" + broker +
                                                              "\"\ntopic = \"lfi/" + name() + "\"\n" + more));
  }

  static RunOptions options(long parts) {
    RunOptions o;
    o.folder = folder_->path() / name();
    o.parts = parts;
    return o;
  }

  static std::string prefix() { return "lfi/" + name(); }

  static TestFolder* folder_;
  static std::string* benchText_;
  static ReferencePackage* package_;
};

TestFolder* RunOutputTest::folder_ = nullptr;
std::string* RunOutputTest::benchText_ = nullptr;
ReferencePackage* RunOutputTest::package_ = nullptr;

TEST_F(RunOutputTest, EveryRecordOfARunReachesTheBrokerOnceAndInOrder) {
  MosquittoBroker broker(folder_->path() / "broker-once");
  MqttListener listener(broker.port(), prefix() + "/#", "listener-once");
  const BenchFile b = bench(broker.url(), "qos = 1\n");
  constexpr long kParts = 50;
  const RunResult r = runParts(b, b, *package_, options(kParts));
  EXPECT_TRUE(r.outputProblems.empty()) << r.outputProblems.front();
  // finish() waited for every acknowledgement, so the broker has them all; the listener's copies follow.
  ASSERT_TRUE(listener.waitFor([&](const auto& m) { return recordParts(m, prefix()).size() >= kParts; },
                               std::chrono::seconds(20)));
  const auto messages = listener.messages();
  std::vector<std::uint64_t> expected(kParts);
  for (long i = 0; i < kParts; ++i) expected[i] = i + 1;
  EXPECT_EQ(recordParts(messages, prefix()), expected);
  // Each message is the record as the run's file has it, byte for byte.
  const auto written = lines(r.records);
  ASSERT_EQ(written.size(), static_cast<std::size_t>(kParts));
  std::size_t k = 0;
  for (const MqttMessage& m : messages) {
    if (m.topic == prefix() + "/record") {
      EXPECT_EQ(m.payload, written[k++]);
    }
  }
  EXPECT_EQ(states(messages, prefix()), (std::vector<std::string>{"running", "stopped"}));
  // The state is retained: a listener that comes later learns it at once.
  MqttListener later(broker.port(), prefix() + "/state", "listener-later", false);
  ASSERT_TRUE(later.waitFor([](const auto& m) { return !m.empty(); }, std::chrono::seconds(10)));
  EXPECT_EQ(later.messages().front().payload, "stopped");
  EXPECT_TRUE(later.messages().front().retain);
}

TEST_F(RunOutputTest, ABrokerRestartedMidRunLosesNoRecord) {
  MosquittoBroker broker(folder_->path() / "broker-restart");
  MqttListener listener(broker.port(), prefix() + "/#", "listener-restart");
  const BenchFile b = bench(broker.url(), "drain_s = 30\n");
  constexpr long kParts = 16;
  RunOptions o = options(kParts);
  o.onRecord = [&](const InspectionRecord& record) {
    if (record.part == 4) broker.stop();  // parts 5 to 10 are published while it is away
    if (record.part == 10) broker.start();
  };
  const RunResult r = runParts(b, b, *package_, o);
  EXPECT_TRUE(r.outputProblems.empty()) << r.outputProblems.front();
  ASSERT_TRUE(listener.waitFor(
      [&](const auto& m) {
        const auto parts = recordParts(m, prefix());
        return !parts.empty() && parts.back() == kParts;
      },
      std::chrono::seconds(30)));
  // QoS 1 is at least once: a record the broker had but had not acknowledged when it stopped comes again.
  // Every record is there, in order, once each but for such repeats of one already received.
  const auto parts = recordParts(listener.messages(), prefix());
  std::vector<std::uint64_t> firsts;
  for (std::uint64_t p : parts) {
    if (!firsts.empty() && p <= firsts.back()) continue;  // a repeat
    EXPECT_EQ(p, firsts.size() + 1) << "record " << firsts.size() + 1 << " lost";
    firsts.push_back(p);
  }
  EXPECT_EQ(firsts.size(), static_cast<std::size_t>(kParts));
  EXPECT_LE(parts.size(), firsts.size() + 20) << "more repeats than messages in flight";  // (the client's bound)
}

TEST_F(RunOutputTest, BadCredentialsAreNamedAndTheRunsRecordsAreKept) {
  const fs::path passwords = folder_->path() / "passwords";
  ASSERT_EQ(std::system(("mosquitto_passwd -b -c " + passwords.string() + " line-a right-secret").c_str()), 0);
  MosquittoBroker broker(folder_->path() / "broker-auth", "allow_anonymous false\npassword_file " + passwords.string());
  const fs::path wrong = folder_->write("wrong-credentials", "line-a:wrong-secret\n");
  const BenchFile b = bench(broker.url(), "drain_s = 0\ncredentials_file = \"" + wrong.string() + "\"\n");
  const RunResult r = runParts(b, b, *package_, options(3));
  EXPECT_EQ(lines(r.records).size(), 3u);
  ASSERT_FALSE(r.outputProblems.empty());
  const std::string all = fmt::format("{}", fmt::join(r.outputProblems, "\n"));
  // (the records wait for the broker to take them, to the end of the run)
  for (const std::string& part : {broker.url(), std::string("refused the connection"), wrong.string(),
                                  std::string("5 message(s) not acknowledged")})
    EXPECT_NE(all.find(part), std::string::npos) << part << " not in:\n" << all;

  // The same broker takes the records with the right credentials: what it refused was the credentials.
  MqttListener listener(broker.port(), prefix() + "/#", "listener-auth", true, "line-a", "right-secret");
  const fs::path right = folder_->write("right-credentials", "line-a:right-secret\n");
  const BenchFile good = bench(broker.url(), "credentials_file = \"" + right.string() + "\"\n");
  RunOptions o = options(1);
  o.folder += "-right";
  EXPECT_TRUE(runParts(good, good, *package_, o).outputProblems.empty());
  EXPECT_TRUE(
      listener.waitFor([&](const auto& m) { return recordParts(m, prefix()).size() == 1; }, std::chrono::seconds(10)));
}

TEST_F(RunOutputTest, AMissingCredentialsFileStopsTheRunBeforeItMakesItsFolder) {
  const BenchFile b = bench("mqtt://127.0.0.1:1", "credentials_file = \"/no/such/credentials\"\n");
  EXPECT_TRUE(throwsError([&] { runParts(b, b, *package_, options(1)); }, Errc::NotFound,
                          {"credentials_file", "/no/such/credentials"}));
  EXPECT_FALSE(fs::exists(options(1).folder));
}

TEST_F(RunOutputTest, AnUnreachableBrokerIsNamedAndTheRunsRecordsAreKept) {
  const std::string nowhere = "mqtt://127.0.0.1:" + std::to_string(testing_support::freeLoopbackPort());
  const BenchFile b = bench(nowhere, "drain_s = 0\nqueue_limit = 2\n");
  const RunResult r = runParts(b, b, *package_, options(5));
  EXPECT_EQ(lines(r.records).size(), 5u);
  const std::string all = fmt::format("{}", fmt::join(r.outputProblems, "\n"));
  // Two records wait for the broker (the bound); the three after them are not published, and the run says so.
  for (const std::string& part :
       {nowhere + ": cannot connect", std::string("3 record(s) not published, the first part 3's"),
        std::string("not acknowledged")})
    EXPECT_NE(all.find(part), std::string::npos) << part << " not in:\n" << all;
}

// A certificate authority, a certificate for 127.0.0.1 it signed (server.pem, server.key) and a stranger's
// self-signed one (stranger.pem), made by openssl in `folder`; false when openssl fails.
bool makeCertificates(const fs::path& folder) {
  const std::string key = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days 2";
  const std::string script = "cd '" + folder.string() +
                             "' && printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > san" +
                             " && openssl req -x509" + key + " -keyout ca.key -out ca.pem -subj /CN=lfi-test-ca" +
                             " && openssl req" + key + " -keyout server.key -out server.csr -subj /CN=127.0.0.1" +
                             " && openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial" +
                             " -out server.pem -days 2 -extfile san" + " && openssl req -x509" + key +
                             " -keyout stranger.key -out stranger.pem -subj /CN=stranger >/dev/null 2>&1";
  return std::system(("(" + script + ") >/dev/null 2>&1").c_str()) == 0;
}

TEST_F(RunOutputTest, AnMqttsBrokerIsReachedThroughItsAuthorityAndAnotherIsNamed) {
  if (std::system("command -v openssl >/dev/null 2>&1") != 0) LFI_SKIP_WITHOUT_TOOL("no openssl (Debian: openssl)");
  const fs::path tls = folder_->path() / "tls";
  fs::create_directories(tls);
  ASSERT_TRUE(makeCertificates(tls));
  // The broker's TLS listener, and a plain one for the test's listener.
  const int plain = testing_support::freeLoopbackPort();
  MosquittoBroker broker(tls / "broker", "allow_anonymous true\ncafile " + (tls / "ca.pem").string() + "\ncertfile " +
                                             (tls / "server.pem").string() + "\nkeyfile " +
                                             (tls / "server.key").string() + "\nlistener " + std::to_string(plain) +
                                             " 127.0.0.1");
  MqttListener listener(plain, prefix() + "/#", "listener-tls");
  const std::string url = "mqtts://127.0.0.1:" + std::to_string(broker.port());
  const BenchFile b = bench(url, "ca_file = \"" + (tls / "ca.pem").string() + "\"\n");
  const RunResult r = runParts(b, b, *package_, options(2));
  EXPECT_TRUE(r.outputProblems.empty()) << r.outputProblems.front();
  EXPECT_TRUE(
      listener.waitFor([&](const auto& m) { return recordParts(m, prefix()).size() == 2; }, std::chrono::seconds(10)));
  // A broker whose certificate another authority signed is not trusted, and the run says so.
  const BenchFile stranger = bench(url, "drain_s = 0\nca_file = \"" + (tls / "stranger.pem").string() + "\"\n");
  RunOptions o = options(1);
  o.folder += "-stranger";
  const RunResult refused = runParts(stranger, stranger, *package_, o);
  EXPECT_EQ(lines(refused.records).size(), 1u);
  const std::string all = fmt::format("{}", fmt::join(refused.outputProblems, "\n"));
  for (const std::string& part : {url + ": cannot connect", std::string("certificate verify failed")})
    EXPECT_NE(all.find(part), std::string::npos) << part << " not in:\n" << all;
}

TEST_F(RunOutputTest, ARunThatDiesLeavesItsLastWill) {
  MosquittoBroker broker(folder_->path() / "broker-will");
  MqttListener listener(broker.port(), prefix() + "/state", "listener-will");
  const BenchFile b = bench(broker.url(), "drain_s = 5\n");
  // A process that dies without a word (this program again: willChild above): the broker sees the
  // connection drop and publishes the will.
  const std::string file = b.file.string();
  const pid_t child = ::fork();
  if (child == 0) {
    const std::string variable = "LFI_TEST_WILL_BENCH=" + file;
    char* const argv[] = {const_cast<char*>("test_run_output"), nullptr};
    char* const envp[] = {const_cast<char*>(variable.c_str()), nullptr};
    ::execve("/proc/self/exe", argv, envp);
    ::_exit(127);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the dying run did not run";
  ASSERT_TRUE(listener.waitFor([](const auto& m) { return m.size() >= 2; }, std::chrono::seconds(10)));
  EXPECT_EQ(states(listener.messages(), prefix()), (std::vector<std::string>{"running", "lost"}));
  // A run that ends in an error (its output destroyed unfinished) leaves the will too; one that finishes, "stopped".
  {
    MqttOutput output(*b.mqtt);
    output.publishState(RunState::Running);
  }
  {
    MqttOutput output(*b.mqtt);
    output.publishState(RunState::Running);
    EXPECT_TRUE(output.finish().empty());
  }
  ASSERT_TRUE(listener.waitFor([](const auto& m) { return m.size() >= 6; }, std::chrono::seconds(10)));
  EXPECT_EQ(states(listener.messages(), prefix()),
            (std::vector<std::string>{"running", "lost", "running", "lost", "running", "stopped"}));
}

TEST(MqttOutputTable, ABadTableIsNamedByItsKey) {
  TestFolder folder("lfi-mqtt-settings");
  const std::string text = testing_support::quickRunBenchText("sim");
  const auto refused = [&](const std::string& table, std::initializer_list<std::string> fragments) {
    const fs::path file = folder.write("bench.toml", text + "\n[output.mqtt]\n" + table);
    return throwsError([&] { readBenchFile(file); }, Errc::Config, fragments);
  };
  EXPECT_TRUE(refused("broker = \"tcp://h\"\ntopic = \"t\"\n", {"output.mqtt.broker", "mqtt://host"}));
  EXPECT_TRUE(refused("broker = \"mqtt://h:99999\"\ntopic = \"t\"\n", {"output.mqtt.broker", "99999"}));
  EXPECT_TRUE(refused("broker = \"mqtt://:1883\"\ntopic = \"t\"\n", {"names no host"}));
  EXPECT_TRUE(refused("broker = \"mqtt://h\"\ntopic = \"a/#\"\n", {"output.mqtt.topic", "wildcards"}));
  EXPECT_TRUE(refused("broker = \"mqtt://h\"\ntopic = \"t\"\nqos = 3\n", {"output.mqtt.qos"}));
  EXPECT_TRUE(refused("broker = \"mqtts://h\"\ntopic = \"t\"\ncert_file = \"c.pem\"\n", {"key_file"}));
  EXPECT_TRUE(refused("broker = \"mqtt://h\"\ntopic = \"t\"\nca_file = \"ca.pem\"\n", {"mqtts://"}));
  EXPECT_TRUE(refused("broker = \"mqtt://h\"\ntopic = \"t\"\npassword = \"x\"\n", {"password", "credentials_file"}));
  // The credentials' file: missing, or not "<username>:<password>".
  const fs::path bad = folder.write("credentials", "no colon here\n");
  const fs::path file = folder.write("bench.toml", text +
                                                       "\n[output.mqtt]\nbroker = \"mqtt://127.0.0.1:1\"\n"
                                                       "topic = \"t\"\ncredentials_file = \"credentials\"\n");
  EXPECT_TRUE(throwsError([&] { MqttOutput output(*readBenchFile(file).mqtt); }, Errc::Config,
                          {bad.string(), "<username>:<password>"}));
  fs::remove(bad);
  EXPECT_TRUE(throwsError([&] { MqttOutput output(*readBenchFile(file).mqtt); }, Errc::NotFound,
                          {"credentials_file", bad.string()}));
}

}  // namespace
}  // namespace lfi
