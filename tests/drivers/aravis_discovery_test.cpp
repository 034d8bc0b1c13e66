// SPDX-License-Identifier: Apache-2.0
// The Aravis backend's discovery and device ids (aravis_camera_fixture.h): the fake
// camera found by discovery, opened by id, by address and as "the first camera
// found", a wrong id, and a device at another of this host's own addresses.

#include "aravis_camera_fixture.h"

#include "aravis_discovery.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>

#include <cstdio>
#include <optional>
#include <string>

namespace lfi {
namespace {

using lfi::testing_support::discoverDevice;

TEST_F(AravisCameraTest, DiscoveryFindsTheFakeCamera) {
  int rounds = 0;
  const std::optional<AravisDeviceInfo> d = discoverDevice(fake_->id(), 3, rounds);
  ASSERT_TRUE(d) << fake_->id() << " not discovered in " << rounds << " rounds";
  EXPECT_EQ(d->vendor, "Aravis");
  EXPECT_EQ(d->model, "Fake");
  EXPECT_EQ(d->serial, fake_->serial());
  EXPECT_EQ(d->address, "127.0.0.1");
  EXPECT_EQ(d->protocol, "GigEVision");
  if (rounds > 1) std::printf("[ info     ] discovered in round %d\n", rounds);
}

TEST_F(AravisCameraTest, OpensByIdAndByAddress) {
  auto camera = openFake();
  EXPECT_EQ(camera->state(), Camera::State::Open);
  const CameraInfo info = camera->info();
  EXPECT_EQ(info.vendor, "Aravis");
  EXPECT_EQ(info.model, "Fake");
  EXPECT_EQ(info.serial, fake_->serial());
  EXPECT_EQ(info.deviceId, fake_->id());
  EXPECT_EQ(info.sensorWidth_px, 2048);
  EXPECT_EQ(info.sensorHeight_px, 2048);
  camera.reset();  // one controller at a time

  auto byAddress = openCamera("aravis:127.0.0.1");
  EXPECT_EQ(byAddress->info().serial, fake_->serial());
  byAddress.reset();

  // "The first camera found" (the only one here) is kept by its id: info() names it, so does a reopen.
  auto first = openCamera("aravis:");
  EXPECT_EQ(first->info().deviceId, fake_->id());
  first->close();
  first->open();
  EXPECT_EQ(first->info().deviceId, fake_->id());
}

TEST_F(AravisCameraTest, WrongIdIsNotFoundAndListsTheDevices) {
  const auto t0 = Clock::now();
  EXPECT_TRUE(throwsError([] { openCamera("aravis:No-Such-Camera"); }, Errc::NotFound,
                          {"No-Such-Camera", "devices found", fake_->id(), "127.0.0.1"}));
  std::printf("[ info     ] not found after %.3f s (two discovery rounds)\n", secondsSince(t0));
}

// This host's first IPv4 address outside 127/8 that is up, or "" if it has none.
std::string ownNonLoopbackAddress() {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return {};
  std::string found;
  for (const ifaddrs* a = list; a != nullptr && found.empty(); a = a->ifa_next) {
    if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET || (a->ifa_flags & IFF_UP) == 0 ||
        (a->ifa_flags & IFF_LOOPBACK) != 0)
      continue;
    char text[INET_ADDRSTRLEN] = {};
    if (::inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(a->ifa_addr)->sin_addr, text, sizeof text))
      found = text;
  }
  ::freeifaddrs(list);
  return found;
}

// A device at one of this host's own addresses sends its stream through the
// loopback interface, whatever the address. Aravis listens for the stream on
// the interface it reached the device through: opened by its eth0 address, or
// by an id whose discovery answer comes back through eth0 first (a race),
// control works and no frame ever comes, unless the backend reaches such a
// device through 127.0.0.1. Opening by address makes Aravis pick eth0 every time.
TEST_F(AravisCameraTest, ADeviceAtAnotherOwnAddressStreams) {
  const std::string address = ownNonLoopbackAddress();
  // (A skip even where skips fail the run: drivers.OwnAddressInANetworkNamespace, which must run, runs this
  // test in a namespace that has such an address.)
  if (address.empty())
    GTEST_SKIP() << "this host has no IPv4 address outside 127/8 (the test drivers.OwnAddressInANetworkNamespace "
                    "runs this one where it has)";
  FakeGvCamera other("LFIO" + std::to_string(::getpid()));
  other.start(binary_, 0, {}, address);
  auto camera = openCamera("aravis:" + address);
  camera->configure(smallSettings());
  camera->start(8);
  for (int i = 0; i < 5; ++i) {
    const Frame frame = grabComplete(*camera);
    const StreamStatistics st = camera->statistics();
    ASSERT_EQ(frame.status, FrameStatus::Complete)
        << "device at " << address << ", frame " << i << ": " << toString(frame.status) << "; stream: " << st.completed
        << " completed, " << st.failed << " failed, " << st.missingPackets << " packets missing";
  }
}

}  // namespace
}  // namespace lfi
